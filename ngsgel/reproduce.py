"""``ngsgel reproduce``: the thesis's numbers against ours, in one report (Markdown and HTML).

Every case runs its scene through the package's API (coarse with ``--quick``) and returns rows:
the thesis's number, ours from this run, the difference, whether ours is converged (measured in
this run as the change between two resolutions where the case computes two, otherwise said),
the explanation where they differ (a link to the validation page) and the wall time and
resolution. Results the command does not recompute (shell paths of an hour or more) appear as
rows marked ``documented``: their numbers and the command that computes them are on the linked
page, not measured here. Independent checks (closed forms, Terzaghi, Fitch) have their own
section.
"""

from __future__ import annotations

import argparse
import base64
import functools
import html
import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

from .output import RunDirectory

CHAPTERS = {"ch3": "Chapter 3: hydrogel microlenses under apex loads",
            "ch4": "Chapter 4: gears from film-coated tubes",
            "ch5": "Chapter 5: plates and tubes with graded cross-links",
            "future": "Future work (chapter 6): creases during transient swelling",
            "checks": "Independent checks: closed forms and reference solutions"}


@dataclass
class Row:
    """One number of the thesis (or of an independent check) against ours."""

    quantity: str
    thesis: str
    ours: str
    difference: str = ""
    verdict: str = ""  # "agrees", "differs", "documented"
    converged: str = ""
    explanation: str = ""
    docs: str = ""  # link, relative to the repository root


@dataclass
class CaseReport:
    chapter: str
    title: str
    resolution: str
    seconds: float = 0.0
    rows: list[Row] = field(default_factory=list)
    figures: list[Path] = field(default_factory=list)


def relative_difference(ours: float, reference: float) -> str:
    return f"{(ours - reference) / abs(reference):+.1%}"


def change_between(coarse: float, fine: float) -> str:
    return f"{abs(fine - coarse) / abs(fine):.2%} change between the two resolutions"


# --- chapter 3 -------------------------------------------------------------------------------

@functools.lru_cache(maxsize=None)
def cap_onset(H: float, maxh: float, order: int) -> dict:
    """``microlens_onset.onset`` once per resolution: the microlens case's convergence check and
    the Fitch table share the H = 0.3R onset."""
    from .scenes import microlens_onset

    return microlens_onset.onset(H, maxh=maxh, order=order)


def microlens_case(out: Path, quick: bool) -> CaseReport:
    from .scenes import microlens

    depth = 0.6 if quick else 1.0
    res = (microlens.SectionResolution(maxh=0.04, layers=2, order=2) if quick
           else microlens.SectionResolution(maxh=0.02, layers=2, order=3))
    finer = microlens.SectionResolution(maxh=res.maxh, layers=res.layers, order=res.order + 1)
    case = microlens.Indentation(H=0.3, direction="inward", depth=depth)
    summary = microlens.run(case, res, str(out / "microlens_H0.3"), kmax=8)
    check = cap_onset(0.3, finer.maxh, finer.order)
    first = summary["first_nonaxisymmetric"]
    report = CaseReport("ch3", "Microlens, inward apex load, H = 0.3R (axisymmetric section + wave-number scan)",
                        f"section h = {res.maxh}, {res.layers} layers, order {res.order} "
                        f"({summary['ndof']} unknowns); onset also at order {finer.order}",
                        figures=[out / "microlens_H0.3" / "force_depth.png"])
    onset_converged = change_between(first["d_over_H"], check["depth_over_H"])
    docs = "docs/microlens.md#first-bifurcation-at-h--03r-ours-048-049-thesis-078"
    report.rows += [
        Row("first non-axisymmetric state: vertex count", "3", str(first["k"]),
            verdict="agrees" if first["k"] == 3 else "differs", converged=f"k = {check['k']} at order {finer.order}",
            docs=docs),
        Row("first non-axisymmetric state: depth d/H", "~0.78", f"{first['d_over_H']:.4f}",
            relative_difference(first["d_over_H"], 0.78), "differs", onset_converged,
            "Converged onset of the perfect cap (0.4770 at h = 0.005-0.02, shell within 0.56 %); the thesis's "
            "stabilised Abaqus run leaves the branch late, which one growth threshold fits but with k = 4, 6 "
            "(explained in part).", docs),
        Row("early response F ~ sqrt(d), d/H <= 0.1", "fits",
            f"C = {summary['fit']['C']:.3g}, relative misfit {summary['fit']['misfit']:.2g}",
            verdict="agrees" if summary["fit"]["misfit"] < 0.1 else "differs",
            docs="docs/microlens.md#results-axisymmetric-model-inward-to-d--2h"),
        Row(f"gel volume change to d/H = {depth}", "< ~0.2 %", f"{summary['max_volume_change']:.3%}",
            verdict="agrees" if summary["max_volume_change"] < 2e-3 else "differs",
            docs="docs/microlens.md#results-axisymmetric-model-inward-to-d--2h"),
    ]
    return report


def fitch_case(out: Path, quick: bool) -> CaseReport:
    heights = (0.2, 0.3) if quick else (0.2, 0.3, 0.4)
    maxh, order = (0.04, 3) if quick else (0.02, 3)
    report = CaseReport("checks", "Fitch's thresholds for a point-loaded clamped cap (first non-axisymmetric mode)",
                        f"section h = {maxh}, 2 layers, order {order}")
    for H in heights:
        row = cap_onset(H, maxh, order)
        ours = f"k = {row['k']} at d/H = {row['depth_over_H']:.4f}" if row["found"] else "none"
        waves = str(row["k"]) if row["found"] else "axisymmetric"
        report.rows.append(Row(
            f"H/R = {H}: lambda = {row['fitch_lambda']:.2f} (nu = 0.5), {row['fitch_lambda_drained']:.2f} "
            f"(drained nu = {row['nu_drained']:.3f})",
            f"Fitch: {row['fitch_waves']} (nu = 0.5), {row['fitch_waves_drained']} (drained)", ours,
            verdict="agrees" if waves == row["fitch_waves_drained"] else "differs",
            explanation="judged with the drained nu: at fixed mu the gel responds drained (microlens_onset's "
                        "docstring); with nu = 0.5 " + ("the same band" if waves == row["fitch_waves"] else
                                                       "it falls outside Fitch's band"),
            docs="docs/microlens.md#fitchs-thresholds-ngsgelscenesmicrolens_onsetpy-h--002-order-3-patch-002-r"))
    return report


MICROLENS_DOCUMENTED = [
    Row("H = 0.3R: 3 -> 4 vertices", "d/H ~ 1.487 (drop ~7 %)",
        "0.875 / 0.859 / 0.761 on h = 0.06 / 0.05 / 0.04 (shell), drop 2.5 %",
        verdict="documented", converged="no (route picked by small asymmetries)",
        explanation="robustly earlier than the thesis on three meshes",
        docs="docs/microlens.md#post-buckled-path-h--03r-inward-shell"),
    Row("H = 0.3R: inversion with a large drop", "d/H ~ 1.79", "snap at 1.79-1.82 losing 5.3 %; 5, 6 vertices never appear",
        verdict="documented", converged="one mesh (h = 0.05)", docs="docs/microlens.md#post-buckled-path-h--03r-inward-shell"),
    Row("H = 0.2R: first non-axisymmetric state", "4 vertices at d/H ~ 1.6", "k = 4 at d/H = 1.1626",
        verdict="documented", converged="h = 0.02 section", docs="docs/microlens.md#results-axisymmetric-model-inward-to-d--2h"),
    Row("H = 0.1R: snap-through", "curvature inversion, large drop",
        "clamped: no snap on any mesh; hinged edge: force maximum at d/H 1.35", verdict="documented",
        docs="docs/microlens.md#results-axisymmetric-model-inward-to-d--2h"),
    Row("outward H = 0.8R: 4 waves, load drop", "d/H ~ 0.076, ~50 %", "4-wave state, 52-54 % drop (h = 0.08 / 0.06 / 0.05)",
        verdict="documented", docs="docs/microlens.md#outward-loads-axisymmetric-model"),
    Row("mu raised after the 4-vertex state", "back to axisymmetric",
        "the clamped rim wrinkles (k = 26 from +1e-4); not restored", verdict="documented",
        docs="docs/microlens.md#mu-changed-at-the-4-vertex-state-h--03r-dh--0859-shell-added-2026-12-02"),
]


# --- chapter 4 -------------------------------------------------------------------------------

def gears_case(out: Path, quick: bool) -> CaseReport:
    from .scenes import gears

    scene = gears.Scene()
    res = gears.QUICK if quick else gears.Resolution()
    summary = gears.run_single(scene, res, str(out / "gears"), threshold=0.5, quick=quick,
                               switch_amplitude=1.0 if quick else 0.25)
    coarser = replace(res, n_theta=res.n_theta * 3 // 4)  # 3/4 of the cells around (a multiple of 4 still)
    convergence = gears.sweep_convergence(scene, [coarser], RunDirectory(out / "gears_convergence"), None)
    switch = gears.analysis_switch_point(scene, "michell")
    final, onset = summary["final"], summary["onset"]
    coarse, fine = convergence[0]["mu_cr"], onset["mu_cr"]
    report = CaseReport("ch4", "Gears: film-coated tube shrunk to 70 % (Efi/Es = 12.5, Efo/Es = 7.23, plane strain)",
                        f"n_theta = {res.n_theta}, order {res.order}, gel h = {res.maxh}, {res.film_layers} cell(s) "
                        f"per film ({summary['ndof']} unknowns); onset also at n_theta = {coarser.n_theta}", figures=[out / "gears" / "gear.png"])
    docs = "docs/gears.md#thesis-numbers-against-ours"
    teeth = [film for film in ("inner", "outer") if final[film]["teeth"]]
    report.rows += [
        Row("teeth at Efo/Es = 7.23", "inner and outer", " and ".join(teeth) or "none",
            verdict="agrees" if teeth == ["inner", "outer"] else "differs",
            explanation="our type switch lies at Efo/Es ~ 3.3, far below 7.23; see the next row", docs=docs),
        Row("analysis: Efo/Es where inner and outer onsets cross", "6.5", f"{switch:.3g} (Michell stiffness)",
            relative_difference(switch, 6.5), "differs",
            explanation="the thesis's printed formula gives 9.4, its 6.5 needs a mode-dependent stiffness (ours "
                        "6.51 with Es); the swollen gel's modulus 3Nv/lam0 and the exact pre-buckling state move it "
                        "to 3.33 (explained)", docs="docs/gears.md#type-map-against-the-thesis-where-the-switch-comes-from"),
        Row("outer tooth count (FE) against n_cr = R (K/(Ef I))^(1/4)", "FE agrees with eq. 4-1",
            f"FE {final['outer']['tooth_count']}, Michell {summary['analysis']['michell_outer']['n']}",
            relative_difference(final["outer"]["tooth_count"], summary["analysis"]["michell_outer"]["n"]),
            "agrees" if abs(final["outer"]["tooth_count"] / summary["analysis"]["michell_outer"]["n"] - 1) < 0.1
            else "differs", explanation="against the exact (Michell) foundation stiffness; the Lamé one of eq. 4-1 "
                                        "gives ~2x fewer teeth", docs=docs),
        Row("onset mu_cr (not in the thesis)", "-", f"{onset['mu_cr']:.5g}", converged=change_between(coarse, fine),
            docs="docs/gears.md#onset-mesh-convergence---sweep-convergence"),
        Row("amplitude at the end / film thickness", "grows like sqrt(eps/eps_cr - 1)",
            f"{final['outer']['amplitude_over_t']:.3g}", verdict="documented",
            explanation="consistent with sqrt near the onset (coarse mesh)", docs=docs),
    ]
    return report


# --- chapter 5 -------------------------------------------------------------------------------

THESIS_PLATE_K = {0.25: 2, 0.75: 4, 2.0: 5, 10.0: 8}


def graded_plate_case(out: Path, quick: bool) -> CaseReport:
    from .scenes import graded_plate

    ps = (10.0,) if quick else (0.25, 0.75, 2.0, 10.0)
    maxh, order = (0.05, 2) if quick else (0.02, 3)
    report = CaseReport("ch5", "Graded plate, softer edge (n0 = 1e-2, nR = 1e-3, t/R = 0.01): onset (axisymmetric "
                        "section + wave-number scan)", f"section h = {maxh}, 2 layers, order {order} (and order "
                        f"{order + 1} for the convergence check)")
    docs = "docs/graded.md#not-done-issue-7-done-when"
    for p in ps:
        summary = graded_plate.run(str(out / f"plate_p{p:g}"), p=p, maxh=maxh, order=order, kmax=15)
        finer = graded_plate.run(str(out / f"plate_p{p:g}_finer"), p=p, maxh=maxh, order=order + 1, kmax=15)
        report.rows.append(Row(f"p = {p:g}: wave number at the onset", f"k = {THESIS_PLATE_K[p]}",
                               f"k = {summary['k_critical']} at mu = {summary['mu_critical']:.5f}",
                               verdict="agrees" if summary["k_critical"] == THESIS_PLATE_K[p] else "differs",
                               converged=change_between(summary["mu_critical"], finer["mu_critical"]),
                               explanation="the onset is k = 2 at every p (converged); at p = 10 the shell's "
                                           "post-buckled path ends in k = 8 on the two finer meshes (documented)",
                               docs=docs))
        if p == 10.0:
            report.rows.append(Row("p = 10: hoop stress compressive from r/R", "~0.67",
                                   f"{summary['hoop_compressive_from_r']:.3g}",
                                   relative_difference(summary["hoop_compressive_from_r"], 0.67),
                                   converged=f"{finer['hoop_compressive_from_r']:.3g} at order {order + 1}",
                                   explanation="read on the sampling radii of the section (step 0.05 R)",
                                   docs="docs/graded.md#softer-edge-n0--1e-2-nr--1e-3-tr--001-onset"))
        report.seconds += summary["wall_s"] + finer["wall_s"]
    return report


GRADED_DOCUMENTED = [
    Row("softer edge, end pattern at mu = 0 (shell path through the snaps)", "k = 2, 4, 5, 8 (p = 0.25, 0.75, 2, 10)",
        "k = 2, 2, 2, 6 at h = 0.2; p = 10: k = 8 at h = 0.15 and 0.1", verdict="documented",
        converged="p = 0.25, 0.75, 2: two meshes; p = 10: not (6 -> 8 -> 8)",
        docs="docs/graded.md#softer-edge-through-the-snaps-to-mu--0-shell-half-disk-added-2026-12-02"),
    Row("softer edge, p = 10, h = 0.2: end state near mu = 0", "k = 8",
        "k = 6 with purity 0.408, 6 crests, stable (default run, with PARDISO and with UMFPACK); the "
        "purity-0.631 state of earlier runs came from a branch jump in the first step after the second snap",
        verdict="documented", converged="the branch followed in steps of 1e-4 ends there too (to 3e-9)",
        explanation="the legs after a snap now start at the snap overshoot (1e-3); started at 0.01 the last "
                    "leg's 25-iteration solve landed on another equilibrium, which lost stability at -0.00082",
        docs="docs/graded.md#not-done-issue-7-done-when"),
    Row("softer centre: axisymmetric bowl for all p", "cone, cone, lens, bowl", "axisymmetric for every p, cone -> lens -> bowl",
        verdict="documented", docs="docs/graded.md#softer-centre-n0--1e-3-nr--1e-2-tr--001"),
    Row("tube, axially graded: petals", "k = 3, 4, 6 for p = 5, 7.5, 10; none for p <= 3",
        "none for p <= 3; k = 11, 11, 12 for p = 5, 7.5, 10", verdict="documented",
        explanation="the thesis gives no tube dimensions (ours: Ri = 1, t = 0.02, L = 2)",
        docs="docs/graded.md#tube-ngsgelscenesgraded_tubepy-nv-1e-2-at-the-base-to-1e-3-at-the-free-head"),
]


# --- future work: creases --------------------------------------------------------------------

def creases_case(out: Path, quick: bool) -> CaseReport:
    from .scenes import creases

    summary = creases.main(["--out", str(out / "creases")] + (["--quick"] if quick else []))
    onset, spacing = summary["onset"], summary["spacing_against_depth"]
    report = CaseReport("future", "Creases on a thick layer during transient swelling (plane strain, self-contact)",
                        f"{summary['ndof']} unknowns" + (" (--quick)" if quick else ""),
                        figures=sorted((out / "creases").glob("*.png")))
    docs = "docs/creases.md#transient-runs"
    report.rows += [
        Row("surface compression lam2/lam1 at the crease onset", f"{creases.CREASE_RATIO} (Hong, Zhao & Suo "
            f"2009; Biot's wrinkling {creases.BIOT_RATIO})", f"{onset['surface_ratio']:.3f} at t = {onset['time']:.4g}",
            relative_difference(onset["surface_ratio"], creases.CREASE_RATIO),
            explanation=f"onset by {onset['onset_kind']}; a transient skin is not a homogeneous half-space", docs=docs),
        Row("crease spacing grows with the swollen depth (Tanaka)", "grows",
            f"rank correlation {spacing['rank_correlation']:.2f}, {len(spacing['coarsening'])} coarsening events",
            verdict="agrees" if spacing["rank_correlation"] > 0 else "differs", docs=docs),
        Row("solvent balance per step (relative)", "round-off", f"{summary['max_relative_balance_error']:.1e}",
            docs="docs/creases.md"),
    ]
    return report


# --- independent checks ----------------------------------------------------------------------

def closed_form_case(out: Path, quick: bool) -> CaseReport:
    from .scenes import free_swelling, transient_layer

    rows = free_swelling.run(str(out / "free_swelling"), quick=quick)
    layer = transient_layer.run(str(out / "transient_layer"), quick=quick)
    worst = max(row["rel_error"] for row in rows)
    report = CaseReport("checks", "Free swelling against the closed form; transient layer: solvent balance and "
                        "the equilibrium limit", "scene defaults" + (" (--quick)" if quick else ""),
                        figures=[out / "free_swelling" / "stretch.png", out / "transient_layer" / "transient_layer.png"])
    report.rows += [
        Row("free swelling, 3D / axisymmetric / plane strain: stretch vs closed form", "round-off",
            f"max relative error {worst:.1e}",
            verdict="agrees" if worst < 1e-9 else "differs", docs="README.md"),
        Row("transient layer: solvent balance per step", "round-off",
            f"{layer['max_relative_balance_error']:.1e}",
            verdict="agrees" if layer["max_relative_balance_error"] < 1e-9 else "differs", docs="docs/transient.md"),
    ]
    return report


@dataclass(frozen=True)
class Case:
    name: str
    chapter: str
    run: Callable[[Path, bool], CaseReport]


CASES = (Case("microlens", "ch3", microlens_case), Case("gears", "ch4", gears_case),
         Case("graded-plate", "ch5", graded_plate_case), Case("creases", "future", creases_case),
         Case("fitch", "checks", fitch_case), Case("closed-forms", "checks", closed_form_case))
DOCUMENTED = {"ch3": MICROLENS_DOCUMENTED, "ch5": GRADED_DOCUMENTED}


def run_cases(out: Path, *, quick: bool, chapters: list[str], progress=None) -> list[CaseReport]:
    """Every case of ``chapters`` into its own folder under ``out``; the report grows case by case
    (rewritten after each), so a stopped run keeps what it computed."""
    reports = []
    for case in (c for c in CASES if c.chapter in chapters):
        start = time.perf_counter()
        if progress is not None:
            progress(f"{case.name} ({case.chapter})")
        report = case.run(out / case.name, quick)
        report.seconds = time.perf_counter() - start
        reports.append(report)
        write_report(out, reports, quick=quick, chapters=chapters)
    return reports


def summary(reports: list[CaseReport], chapters: list[str]) -> dict[str, dict]:
    """Per chapter: how many computed rows agree with the thesis, differ, or carry no verdict
    (numbers the thesis does not give), how many are documented only, and the wall time."""
    table = {}
    for chapter in chapters:
        rows = [row for r in reports if r.chapter == chapter for row in r.rows]
        table[chapter] = {"agrees": sum(row.verdict == "agrees" for row in rows),
                          "differs": sum(row.verdict == "differs" for row in rows),
                          "other": sum(row.verdict not in ("agrees", "differs") for row in rows),
                          "documented": len(DOCUMENTED.get(chapter, [])),
                          "seconds": sum(r.seconds for r in reports if r.chapter == chapter)}
    return table


COLUMNS = ("quantity", "thesis", "ours", "difference", "verdict", "converged", "explanation")


def _markdown_row(row: Row, root: str) -> str:
    cells = [getattr(row, name).replace("|", "\\|").replace("\n", " ") for name in COLUMNS]
    if row.docs:
        cells[-1] = (cells[-1] + " " if cells[-1] else "") + f"[docs]({root}{row.docs})"
    return "| " + " | ".join(cells) + " |"


def markdown(reports: list[CaseReport], *, quick: bool, chapters: list[str], root: str) -> str:
    lines = [f"# ngsgel: the thesis reproduced{' (--quick)' if quick else ''}", "",
             "Each row: the thesis's number, ours from this run, the difference, whether ours is converged "
             "and why they differ. Rows marked `documented` are not recomputed by this command: their numbers "
             "and commands are on the linked page.", ""]
    header = "| " + " | ".join(COLUMNS) + " |\n|" + "---|" * len(COLUMNS)
    lines += ["| chapter | agrees | differs | other | documented | wall time |", "|---|---|---|---|---|---|"]
    for chapter, counts in summary(reports, chapters).items():
        lines.append(f"| {chapter} | {counts['agrees']} | {counts['differs']} | {counts['other']} | "
                     f"{counts['documented']} | {counts['seconds']:.0f} s |")
    lines.append("")
    for chapter in chapters:
        lines += [f"## {CHAPTERS[chapter]}", ""]
        for report in (r for r in reports if r.chapter == chapter):
            lines += [f"### {report.title}", "", f"Resolution: {report.resolution}. Wall time: "
                      f"{report.seconds:.1f} s.", "", header, *(_markdown_row(r, root) for r in report.rows), ""]
            lines += [f"![{figure.name}]({figure.name})" for figure in report.figures if figure.exists()] + [""]
        if DOCUMENTED.get(chapter):
            lines += ["### Documented results (not recomputed here)", "", header,
                      *(_markdown_row(r, root) for r in DOCUMENTED[chapter]), ""]
    return "\n".join(lines)


def _html_cell(row: Row, name: str, root: str) -> str:
    text = html.escape(getattr(row, name))
    if name == "explanation" and row.docs:
        text += f' <a href="{html.escape(root + row.docs)}">docs</a>'
    return f"<td>{text}</td>"


def html_report(reports: list[CaseReport], *, quick: bool, chapters: list[str], root: str) -> str:
    def table(rows: list[Row]) -> str:
        head = "".join(f"<th>{name}</th>" for name in COLUMNS)
        body = "".join(f'<tr class="{html.escape(r.verdict)}">' + "".join(_html_cell(r, n, root) for n in COLUMNS)
                       + "</tr>" for r in rows)
        return f"<table><tr>{head}</tr>{body}</table>"

    parts = [f"<h1>ngsgel: the thesis reproduced{' (--quick)' if quick else ''}</h1>"]
    for chapter in chapters:
        parts.append(f"<h2>{html.escape(CHAPTERS[chapter])}</h2>")
        for report in (r for r in reports if r.chapter == chapter):
            parts += [f"<h3>{html.escape(report.title)}</h3>",
                      f"<p>Resolution: {html.escape(report.resolution)}. Wall time: {report.seconds:.1f} s.</p>",
                      table(report.rows)]
            for figure in (f for f in report.figures if f.exists()):
                data = base64.b64encode(figure.read_bytes()).decode("ascii")
                parts.append(f'<figure><img src="data:image/png;base64,{data}" alt="{html.escape(figure.name)}">'
                             f"<figcaption>{html.escape(figure.name)}</figcaption></figure>")
        if DOCUMENTED.get(chapter):
            parts += ["<h3>Documented results (not recomputed here)</h3>", table(DOCUMENTED[chapter])]
    style = ("body{font-family:sans-serif;max-width:1400px;margin:auto}table{border-collapse:collapse;width:100%}"
             "td,th{border:1px solid #ccc;padding:4px;vertical-align:top;font-size:90%}"
             "tr.agrees{background:#eef8ee}tr.differs{background:#fbeeee}tr.documented{color:#555}"
             "img{max-width:640px}")
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>ngsgel reproduce</title>"
            f"<style>{style}</style></head><body>{''.join(parts)}</body></html>")


def docs_root() -> str:
    """Where the links to the validation pages point: the source tree's docs when ngsgel runs from
    a checkout, else paths relative to the repository root (docs/ is not installed)."""
    source = Path(__file__).resolve().parent.parent
    return source.as_uri() + "/" if (source / "docs").is_dir() else ""


def write_report(out: Path, reports: list[CaseReport], *, quick: bool, chapters: list[str]) -> None:
    root = docs_root()
    for report in reports:  # figures next to the report, so the Markdown's links resolve
        for i, figure in enumerate(report.figures):
            if figure.exists() and figure.parent != out:
                copy = out / f"{report.chapter}_{figure.parent.name}_{figure.name}"
                copy.write_bytes(figure.read_bytes())
                report.figures[i] = copy
    (out / "report.md").write_text(markdown(reports, quick=quick, chapters=chapters, root=root))
    (out / "report.html").write_text(html_report(reports, quick=quick, chapters=chapters, root=root))
    (out / "report.json").write_text(json.dumps(
        [{**asdict(r), "figures": [str(f) for f in r.figures]} for r in reports], indent=1, default=str))


def main(argv: list[str] | None = None) -> list[CaseReport]:
    from .output import Progress

    parser = argparse.ArgumentParser(prog="ngsgel reproduce", description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--out", default="results/reproduce", help="output folder (report.md, report.html)")
    parser.add_argument("--quick", action="store_true", help="coarse resolutions (a few minutes on 2 cores)")
    parser.add_argument("--only", default=",".join(CHAPTERS),
                        help=f"comma-separated chapters, of: {', '.join(CHAPTERS)}")
    args = parser.parse_args(argv)
    chapters = [c.strip() for c in args.only.split(",") if c.strip()]
    unknown = [c for c in chapters if c not in CHAPTERS]
    if unknown or not chapters:
        parser.error(f"--only: unknown chapter(s) {unknown}; allowed: {', '.join(CHAPTERS)}")
    out = Path(args.out)
    RunDirectory(out, params={"quick": args.quick, "chapters": chapters})
    reports = run_cases(out, quick=args.quick, chapters=chapters, progress=Progress("reproduce"))
    print(f"report: {out / 'report.md'} and {out / 'report.html'}")
    return reports
