"""The catalogue of real debris targets: mesh file, mass and the optimiser's design bounds.

Each entry names a closed triangle mesh under ``tethernet_ros/data/targets/`` (binary STL,
metres, built from cited dimensions by ``scripts/build_targets.py``), the target's mass
(kg) and, where a measured value was found, its inertia (kg m^2, 3x3 about the CoM in the
mesh frame) and CoM (m, mesh frame); ``None`` means uniform density over the mesh. Every
number, its source and the modelling assumptions are in docs/targets.md.

The analytic Zenit-2 of the source is not an entry: it is the default target 'zenit-2'
(``core/target.py``); the two Zenit-2 meshes here are the same shapes, for comparing the
mesh path with it.

Mesh frames (metres; the simulator moves a mesh to its own body frame, CoM and principal
axes, ``core/shapes/mesh.py``): rocket stages have their long axis along x, the origin at
the centre of the main cylinder (the Zenit-2 nozzle toward -x, as the analytic stage's);
Envisat has its origin at the centre of the body box, x along the body toward the solar
array, the array in the x-y plane; PROBA-1 is a box centred on the origin, its 0.8 m side
along x.
"""
from __future__ import annotations

import importlib.resources
import math
import pathlib
from dataclasses import dataclass, field

from ..design import DESIGN_BOUNDS, VARIABLE_NAMES, Design

#: Extents in m of the target the source's bounds (docs/model.md §8, Table 1) were set
#: for: the Zenit-2 stage body, 10.4 m long and 3.9 m in diameter, its long axis across the
#: line of sight and a 3.9 m depth along it at the nominal attitude.
REFERENCE_EXTENTS: tuple[float, float, float] = (10.4, 3.9, 3.9)

#: How each design variable's bounds follow the target (docs/targets.md, "Design bounds"):
#: "size": times s = largest extent / 10.4 m; "depth": times s_d = middle extent / 3.9 m;
#: "fixed": the source's own.
SCALING: dict[str, str] = {
    "m_c": "size", "L_n": "size", "r_n": "fixed", "d_L": "size",
    "V_x": "fixed", "V_y": "fixed", "V_z": "fixed", "d_c": "depth",
}


def _sig4(v: float) -> float:
    """v rounded to 4 significant digits (13.0, -2.5 and 0.001 stay exact)."""
    return float(f"{v:.4g}")


def design_bounds_for(extents_m: tuple[float, float, float]) -> dict[str, tuple[float, float]]:
    """The optimiser's bounds for a target whose bounding box has the three edge lengths
    ``extents_m`` (m, any order).

    Geometric similarity with the source's Zenit-2 case: lengths that the net must span
    (net side L_n, launch distance d_L) scale with the largest extent (s = largest /
    10.4 m); corner masses m_c scale with s too, which with the thread radius r_n and the
    launch speeds V kept keeps the net's free flight similar (net mass, corner-mass to
    net-mass ratio and thread forces as in the source, times scaled by s); the closing
    displacement d_c scales with the depth along the line of sight at the nominal attitude
    (the long axis across it), taken as the middle extent (s_d = middle / 3.9 m). Values
    are rounded to 4 significant digits; ``design_bounds_for(REFERENCE_EXTENTS)`` is
    Table 1 exactly.
    """
    factor = similarity_factors(extents_m)
    return {k: (_sig4(lo * factor[k]), _sig4(hi * factor[k])) for k, (lo, hi) in DESIGN_BOUNDS.items()}


def similarity_factors(extents_m: tuple[float, float, float]) -> dict[str, float]:
    """The factor each design variable takes from the source's Zenit-2 to a target whose
    bounding box has the edge lengths ``extents_m`` (m, any order): s = largest / 10.4 m
    for the "size" variables, s_d = middle / 3.9 m for the "depth" one, 1 for the others
    (:data:`SCALING`; the rule of :func:`design_bounds_for`)."""
    try:
        ext = sorted((float(e) for e in extents_m), reverse=True)
    except (TypeError, ValueError):
        ext = []
    if len(ext) != 3 or not all(math.isfinite(e) and e > 0 for e in ext):
        raise ValueError(f"extents: got {extents_m!r}; need three finite lengths > 0 (m)")
    by_rule = {"size": ext[0] / REFERENCE_EXTENTS[0], "depth": ext[1] / REFERENCE_EXTENTS[1],
               "fixed": 1.0}
    return {k: by_rule[rule] for k, rule in SCALING.items()}


def similar_design(design: Design, extents_m: tuple[float, float, float]) -> Design:
    """The design geometrically similar, by the rule of :func:`design_bounds_for`, to
    ``design`` (a design for the source's Zenit-2) for a target whose bounding box has the
    edge lengths ``extents_m`` (m): each variable times its :func:`similarity_factors`
    factor, rounded to 4 significant digits (the source's four reference designs on
    another target, for instance)."""
    factor = similarity_factors(extents_m)
    x = [_sig4(v * factor[k]) for k, v in zip(VARIABLE_NAMES, design.to_vector())]
    return Design.from_vector(x)


@dataclass(frozen=True)
class CatalogueEntry:
    """One debris target.

    name: catalogue key; mesh: file name under tethernet_ros/data/targets/; mass: kg;
    inertia: measured 3x3 about the CoM in the mesh frame (kg m^2) or None (uniform
    density over the mesh); com: measured CoM in the mesh frame (m) or None; sources:
    citations of every number; description: one line; design_bounds: the optimiser's
    (lower, upper) per design variable (kg, m, m/s), from :func:`design_bounds_for`.
    """

    name: str
    mesh: str
    mass: float
    inertia: tuple | None
    com: tuple | None
    sources: tuple[str, ...]
    description: str
    design_bounds: dict[str, tuple[float, float]] = field(hash=False)


_TEXT = ("Botta et al., tether-net capture study (the project's 'text', docs/model.md §1 and "
         "§8): Zenit-2 second stage, cylinder 3.9 m x 10.4 m, dry mass 8300 kg; Table-1 bounds")
_NOZZLE = ("tethernet_ros core/target.py TargetConfig(nozzle=True): nozzle frustum 2.0 m long, "
           "radius 0.5 m at the end cap, 1.0 m at the exit (project assumption, no public source)")
_ENVISAT = ("ESA Earth Online, Envisat Space Segment, https://earth.esa.int/web/guest/missions/"
            "esa-operational-eo-missions/envisat/satellite/space-segment: in orbit 26 m x 10 m x "
            "5 m, launch mass budget 8211 kg incl. 319 kg fuel")
_EDUSPACE = "ESA Eduspace, Introduction to Envisat, fast facts: 10 m x 4 m x 4 m stowed"
_ENVISAT_ARRAY = ("Space.com (2012), Pleiades view of Envisat, https://forcetoknow.com/space/"
                  "pleiades-snapped-detailed-view-envisat.html: solar array 5 m wide, 14 m long")
_ADRASJ = ("Astroscale/JAXA CRD2 target, https://summary-tech.com/en/2023/10/7/2582-Astroscale-"
           "ships-debris-removal-demonstration-satellite-ADRAS-J-to-launch-site: H-IIA F15 upper "
           "stage, about 11 m long, about 4 m in diameter, about 3 t")
_REGISTER = ("The Register (2024-02-19), https://www.theregister.com/2024/02/19/"
             "adrasj_mission_space_junk/: H-IIA upper stage about 11 m long, 4 m in diameter")
_PROBA = ("ESA, Proba-1 facts and figures, https://esa.int/Applications/Observing_the_Earth/"
          "Proba-1/Facts_and_figures: 94 kg, 60 x 60 x 80 cm box")

#: Extents in m to which :func:`design_bounds_for` is applied: the mesh's bounding box,
#: except that both Zenit-2 meshes use the stage body the source's Table 1 was set for (the
#: project optimises its nozzle variant in those bounds too; docs/targets.md).
RULE_EXTENTS: dict[str, tuple[float, float, float]] = {
    "zenit-2-nozzle": REFERENCE_EXTENTS,
    "zenit-2-cylinder": REFERENCE_EXTENTS,
    "envisat": (26.0, 5.0, 4.0),
    "h-iia-upper-stage": (11.0, 4.0, 4.0),
    "proba-1": (0.8, 0.6, 0.6),
}


def _entry(name, mesh, mass, sources, description) -> CatalogueEntry:
    return CatalogueEntry(name=name, mesh=mesh, mass=mass, inertia=None, com=None,
                          sources=sources, description=description,
                          design_bounds=design_bounds_for(RULE_EXTENTS[name]))


#: Every catalogued target by name.
CATALOGUE: dict[str, CatalogueEntry] = {e.name: e for e in (
    _entry("zenit-2-nozzle", "zenit-2-nozzle.stl", 8300.0, (_TEXT, _NOZZLE),
           "Zenit-2 second stage with engine-nozzle frustum, as core/target.py with nozzle=True"),
    _entry("zenit-2-cylinder", "zenit-2-cylinder.stl", 8300.0, (_TEXT,),
           "Zenit-2 second stage as the source's plain cylinder (core/target.py's default)"),
    _entry("envisat", "envisat.stl", 8211.0, (_ENVISAT, _EDUSPACE, _ENVISAT_ARRAY),
           "ESA's Envisat: body box, boom and one solar-array plate"),
    _entry("h-iia-upper-stage", "h-iia-upper-stage.stl", 3000.0, (_ADRASJ, _REGISTER),
           "H-IIA second stage left in orbit in 2009 (ADRAS-J's target), plain cylinder"),
    _entry("proba-1", "proba-1.stl", 94.0, (_PROBA,),
           "ESA's PROBA-1 microsatellite (ClearSpace-1's target), box"),
)}


def entry(name: str) -> CatalogueEntry:
    """The catalogue entry called ``name``; ValueError naming the known ones otherwise."""
    try:
        return CATALOGUE[name]
    except (KeyError, TypeError):
        raise ValueError(f"target {name!r}: unknown; the catalogue holds "
                         f"{', '.join(sorted(CATALOGUE))}") from None


def mesh_path(entry: CatalogueEntry) -> pathlib.Path:
    """Path of the entry's mesh file in the installed package's data/targets folder."""
    return pathlib.Path(str(importlib.resources.files("tethernet_ros") / "data" / "targets"
                            / entry.mesh))


def design_bounds_of(target) -> dict[str, tuple[float, float]]:
    """The optimiser's bounds for a target (``core.target.TargetConfig``): the source's
    Table 1 for the analytic Zenit-2, the entry's for a catalogue name, and for a mesh file
    :func:`design_bounds_for` of its box in the body frame (docs/targets.md, the rule)."""
    if target.kind == "revolution":
        return dict(DESIGN_BOUNDS)
    if not target.mesh and target.name in CATALOGUE:
        return dict(CATALOGUE[target.name].design_bounds)
    from . import target_shape

    v = target_shape(target).vertices
    return design_bounds_for(tuple(float(e) for e in v.max(axis=0) - v.min(axis=0)))
