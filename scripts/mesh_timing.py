"""Mesh generation time of the default scene meshes (MODEL.md section 5).

Builds every model dimension of the scene geometries with their default sizes and
prints wall time, element and vertex counts; ``--out DIR`` also writes
``DIR/mesh_timing.csv``.  ``--quick`` uses coarser meshes (for tests and CI).

Scenes: A cap ``R = 1, H = 0.3, t = 0.005 r``; B gear annulus ``Ri = 1, Ro = 2,
tfi = Ri/50, tfo = Ro/100``; C plate ``R = 1, t = 0.01``; E crease layer (width 4,
thickness 1, random imperfection 1e-3 of wavelengths >= 0.1).

    python scripts/mesh_timing.py [--quick] [--out results/mesh_timing]
"""

from __future__ import annotations

import argparse
import csv
import os
import time
from collections.abc import Callable

import ngsolve

import geometries as g

R_CAP, H_CAP = 1.0, 0.3
T_CAP = 0.005 * (R_CAP**2 + H_CAP**2) / (2 * H_CAP)
RI, RO = 1.0, 2.0
CAP = dict(R=R_CAP, H=H_CAP, t=T_CAP, apex_radius=0.05)
GEAR = dict(Ri=RI, Ro=RO, tfi=RI / 50, tfo=RO / 100)
PLATE = dict(R=1.0, t=0.01)
CREASE = dict(width=4.0, thickness=1.0, amplitude=1e-3, wavelength=0.1, seed=0)

# (mesh name, builder, parameters, mesh sizes: full, quick)
SCENE_MESHES: list[tuple[str, Callable[..., g.MeshBundle], dict, dict, dict]] = [
    ("cap_solid", g.cap_solid, CAP, dict(maxh=0.04, apex_maxh=0.01),
     dict(maxh=0.1)),
    ("cap_section", g.cap_section, CAP, dict(maxh=0.01, apex_maxh=0.002),
     dict(maxh=0.05)),
    ("cap_midsurface", g.cap_midsurface, CAP, dict(maxh=0.04, apex_maxh=0.01),
     dict(maxh=0.1)),
    ("gear_annulus", g.tube_plane, GEAR, dict(maxh=0.03), dict(maxh=0.15)),
    ("plate_solid", g.plate_solid, PLATE, dict(maxh=0.03), dict(maxh=0.1)),
    ("plate_section", g.plate_section, PLATE, dict(maxh=0.01), dict(maxh=0.05)),
    ("plate_midsurface", g.plate_midsurface, PLATE, dict(maxh=0.03), dict(maxh=0.1)),
    ("crease_layer", g.layer_plane, CREASE, dict(maxh=0.1, top_maxh=0.01),
     dict(maxh=0.25, top_maxh=0.05)),
]


def run(*, quick: bool = False) -> list[dict]:
    """Build each scene mesh once; one row per mesh."""
    rows = []
    for name, builder, params, full, coarse in SCENE_MESHES:
        start = time.perf_counter()
        bundle = builder(**params, **(coarse if quick else full))
        seconds = time.perf_counter() - start
        mesh = bundle.mesh
        # a surface mesh has no volume elements: count its triangles
        elements = mesh.GetNE(ngsolve.BND) if bundle.model == g.SURFACE else mesh.ne
        rows.append(dict(mesh=name, builder=builder.__name__, model=bundle.model,
                         seconds=round(seconds, 4), elements=elements, vertices=mesh.nv))
    return rows


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="coarse meshes")
    parser.add_argument("--out", default=None, help="folder for mesh_timing.csv")
    args = parser.parse_args(argv)
    rows = run(quick=args.quick)
    print(f"{'mesh':18s} {'model':13s} {'seconds':>8s} {'elements':>9s} {'vertices':>9s}")
    for r in rows:
        print(f"{r['mesh']:18s} {r['model']:13s} {r['seconds']:8.3f} {r['elements']:9d} "
              f"{r['vertices']:9d}")
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        path = os.path.join(args.out, "mesh_timing.csv")
        with open(path, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
        print(f"written {path}")
    return rows


if __name__ == "__main__":
    main()
