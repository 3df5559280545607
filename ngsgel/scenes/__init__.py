"""The scenes of the thesis (MODEL.md section 5) and the studies around them, as importable modules.

Every scene module has a ``main(argv)`` (its command line, the same as ``ngsgel run NAME``), a
``run``-style function with keyword-only, documented parameters, and measurements that return
plain dicts or result objects. Scene-only physics lives next to its scene (``film_tube`` and
``ring_foundation`` with the gears, ``shell_cases`` with the shell benchmarks and the graded disk).

``SCENES`` maps a scene's command-line name to its module and the thesis chapter it belongs to.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from types import ModuleType


@dataclass(frozen=True)
class SceneEntry:
    name: str
    module: str
    chapter: str  # "ch3", "ch4", "ch5", "future" (thesis's future work) or "checks"

    def load(self) -> ModuleType:
        return importlib.import_module(f"{__name__}.{self.module}")

    def summary(self) -> str:
        doc = self.load().__doc__ or ""
        return doc.strip().split("\n\n")[0].replace("\n", " ")


SCENES: dict[str, SceneEntry] = {entry.name: entry for entry in (
    SceneEntry("free-swelling", "free_swelling", "checks"),
    SceneEntry("transient-layer", "transient_layer", "checks"),
    SceneEntry("transient-sphere", "transient_sphere", "checks"),
    SceneEntry("buckling-demo", "buckling_demo", "checks"),
    SceneEntry("microlens", "microlens", "ch3"),
    SceneEntry("microlens-onset", "microlens_onset", "ch3"),
    SceneEntry("gears", "gears", "ch4"),
    SceneEntry("graded-plate", "graded_plate", "ch5"),
    SceneEntry("graded-plate-shell", "graded_plate_shell", "ch5"),
    SceneEntry("graded-plate-growth", "graded_plate_growth", "ch5"),
    SceneEntry("graded-tube", "graded_tube", "ch5"),
    SceneEntry("plate-wedges", "plate_wedges", "ch5"),
    SceneEntry("cap-sector", "cap_sector", "ch3"),
    SceneEntry("creases", "creases", "future"),
    SceneEntry("crease-tip-convergence", "crease_tip_convergence", "future"),
)}


def scene(name: str) -> SceneEntry:
    """The scene called ``name`` (dashes or underscores); ValueError listing the scenes otherwise."""
    key = name.replace("_", "-")
    if key not in SCENES:
        raise ValueError(f"unknown scene {name!r}; scenes: {', '.join(SCENES)}")
    return SCENES[key]
