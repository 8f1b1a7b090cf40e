"""Net design and launch actions: the 8 variables of docs/model.md §8, their bounds,
validation at the edge, the reference designs of docs/model.md §9 and the system mass m_a.

Units: kg, m, m/s.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, asdict
from pathlib import Path
from collections.abc import Mapping, Sequence

import numpy as np

from .checks import declared_floats

#: Order of the optimisation vector X (docs/model.md §8).
VARIABLE_NAMES: tuple[str, ...] = ("m_c", "L_n", "r_n", "d_L", "V_x", "V_y", "V_z", "d_c")

#: Search bounds of the optimiser (lower, upper), same order as VARIABLE_NAMES.
DESIGN_BOUNDS: dict[str, tuple[float, float]] = {
    "m_c": (1.0, 4.0),
    "L_n": (13.0, 22.0),
    "r_n": (0.001, 0.010),
    "d_L": (15.0, 35.0),
    "V_x": (1.0, 6.0),
    "V_y": (1.0, 6.0),
    "V_z": (2.0, 10.0),
    "d_c": (-2.5, 2.5),
}

#: Default thread density (kg/m^3), the value implied by the reference masses.
THREAD_DENSITY = 1390.0

#: Physical ranges accepted for *evaluation* (reference designs may lie outside the
#: optimiser's bounds).  (lower, upper, lower-inclusive?)
_PHYSICAL_LIMITS: dict[str, tuple[float, float, bool, str]] = {
    "m_c": (0.0, 1000.0, False, "a corner mass in (0, 1000] kg"),
    "L_n": (0.0, 200.0, False, "a net side in (0, 200] m"),
    "r_n": (0.0, 0.1, False, "a thread radius in (0, 0.1] m"),
    "d_L": (0.0, 1000.0, False, "a distance to target in (0, 1000] m"),
    "V_x": (0.0, 100.0, True, "a speed magnitude in [0, 100] m/s"),
    "V_y": (0.0, 100.0, True, "a speed magnitude in [0, 100] m/s"),
    "V_z": (0.0, 100.0, False, "a speed magnitude in (0, 100] m/s"),
    "d_c": (-100.0, 100.0, True, "a closing displacement in [-100, 100] m"),
}


class DesignError(ValueError):
    """A design value is missing, non-finite or outside its allowed range.

    The message is one line naming the field and what is allowed.
    """

    def __init__(self, field: str, message: str):
        super().__init__(f"design field '{field}': {message}")
        self.field = field


@dataclass(frozen=True)
class Design:
    """A tether-net design and its launch/closing actions.

    m_c: corner mass, each (kg); L_n: net side length (m); r_n: thread radius (m);
    d_L: distance from launch point to target centre along +z (m);
    V_e: corner launch velocity magnitudes [V_x, V_y, V_z] (m/s);
    d_c: closing displacement, z(net CoM) - z(target CoM) at which closing starts (m).
    """

    m_c: float
    L_n: float
    r_n: float
    d_L: float
    V_e: tuple[float, float, float]
    d_c: float

    def __post_init__(self):
        declared_floats(self)
        object.__setattr__(self, "V_e", tuple(float(v) for v in self.V_e))
        validate_design(self)

    # --- conversions -------------------------------------------------------------
    def to_vector(self) -> np.ndarray:
        """X = [m_c, L_n, r_n, d_L, V_x, V_y, V_z, d_c]."""
        return np.array([self.m_c, self.L_n, self.r_n, self.d_L, *self.V_e, self.d_c], dtype=float)

    @classmethod
    def from_vector(cls, x: Sequence[float]) -> Design:
        x = [float(v) for v in x]
        if len(x) != 8:
            raise DesignError("X", f"expected 8 values {list(VARIABLE_NAMES)}, got {len(x)}")
        return cls(m_c=x[0], L_n=x[1], r_n=x[2], d_L=x[3], V_e=(x[4], x[5], x[6]), d_c=x[7])

    def to_dict(self) -> dict:
        d = asdict(self)
        d["V_e"] = list(self.V_e)
        return d

    @classmethod
    def from_dict(cls, data: Mapping) -> Design:
        if not isinstance(data, Mapping):
            raise DesignError("design", "expected a mapping with keys m_c, L_n, r_n, d_L, V_e, d_c")
        allowed = {"m_c", "L_n", "r_n", "d_L", "V_e", "d_c"}
        for key in data:
            if key not in allowed:
                raise DesignError(str(key), f"unknown field; allowed fields are {sorted(allowed)}")
        values = {}
        for key in ("m_c", "L_n", "r_n", "d_L", "d_c"):
            if key not in data:
                raise DesignError(key, "missing; " + _allowed_text(key))
            values[key] = _as_float(key, data[key])
        if "V_e" not in data:
            raise DesignError("V_e", "missing; a list of three speed magnitudes [V_x, V_y, V_z] in m/s")
        ve = data["V_e"]
        if isinstance(ve, (str, bytes)) or not isinstance(ve, Sequence) or len(ve) != 3:
            raise DesignError("V_e", "must be a list of three speed magnitudes [V_x, V_y, V_z] in m/s")
        values["V_e"] = tuple(_as_float(f"V_e[{i}]", v) for i, v in enumerate(ve))
        return cls(**values)

    def mass(self, density: float = THREAD_DENSITY) -> float:
        """System mass m_a (kg), tether excluded."""
        return system_mass(self.m_c, self.L_n, self.r_n, density)

    def within_bounds(self) -> bool:
        """True if the design lies inside the optimiser's search bounds."""
        return all(lo <= v <= hi for v, (lo, hi) in zip(self.to_vector(), DESIGN_BOUNDS.values()))


def system_mass(m_c: float, L_n: float, r_n: float, density: float = THREAD_DENSITY) -> float:
    """m_a = 38 L_n pi r_n^2 rho + 4 m_c (kg): 17 + 17 grid threads of length L_n plus an
    allowance for the closing thread, and four corner masses (docs/model.md §8)."""
    return 38.0 * L_n * math.pi * (r_n * r_n) * density + 4.0 * m_c


def _allowed_text(field: str) -> str:
    return "must be " + _PHYSICAL_LIMITS[field][3]


def _as_float(field: str, value) -> float:
    if isinstance(value, bool):
        raise DesignError(field, f"got {value!r}; expected a number")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise DesignError(field, f"got {value!r}; expected a number") from None


def validate_design(design: Design) -> None:
    """Raise DesignError naming the first field that is non-finite or unphysical."""
    values = dict(zip(VARIABLE_NAMES, [design.m_c, design.L_n, design.r_n, design.d_L,
                                       *design.V_e, design.d_c]))
    for name, value in values.items():
        field = {"V_x": "V_e[0]", "V_y": "V_e[1]", "V_z": "V_e[2]"}.get(name, name)
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            raise DesignError(field, f"got {value!r}; expected a number")
        if not math.isfinite(value):
            raise DesignError(field, f"got {value}; {_allowed_text(name)}")
        lo, hi, lo_incl, text = _PHYSICAL_LIMITS[name]
        if value > hi or value < lo or (value == lo and not lo_incl):
            raise DesignError(field, f"got {value}; must be {text}")


#: Reference designs of docs/model.md §9.
REFERENCE_DESIGNS: dict[str, Design] = {
    "baseline": Design(m_c=0.5, L_n=20.0, r_n=0.001, d_L=20.0, V_e=(0.40, 0.40, 2.00), d_c=0.50),
    "suboptimal": Design(m_c=3.83, L_n=21.4, r_n=0.002, d_L=17.87, V_e=(2.30, 4.95, 6.54), d_c=1.57),
    "mass-min": Design(m_c=1.00, L_n=21.26, r_n=0.001, d_L=34.15, V_e=(2.26, 2.43, 8.55), d_c=2.11),
    "time-min": Design(m_c=2.05, L_n=19.84, r_n=0.001, d_L=16.14, V_e=(4.02, 2.60, 8.88), d_c=2.26),
}


@dataclass(frozen=True)
class PublishedOutcome:
    """What the source study published for a reference design (its Table 4, docs/model.md
    §11): m_a (kg), mean T (s), P*_s during optimisation (N = 100; None where not given)
    and validated P*_s (N = 1000)."""

    mass: float
    mean_completion_time: float
    p_success_optimisation: float | None
    p_success_validated: float


#: The source's published outcomes of the reference designs.  (Its mass formula gives
#: 11.49 kg for time-min; the table prints 11.89.)
PUBLISHED_OUTCOMES: dict[str, PublishedOutcome] = {
    "baseline": PublishedOutcome(5.31, 57.2, None, 0.752),
    "suboptimal": PublishedOutcome(29.52, 25.9, 0.97, 0.965),
    "mass-min": PublishedOutcome(7.53, 27.4, 0.98, 0.983),
    "time-min": PublishedOutcome(11.89, 24.2, 1.00, 0.982),
}


#: the scenario mappings a design file may carry beside its design keys (at the top level
#: or under ``design:``): group -> the fields it holds.  ``launch:`` states the launch
#: settings the design was chosen or checked with (e.g. Case 2's tilt limit,
#: docs/studies/launch-tilt.md); the commands layer them under their flags.
DESIGN_FILE_SCENARIO: dict[str, str] = {
    "tumble": "rate_deg_s (deg/s), axis and phase_deg (deg)",
    "target": "target fields (name, mesh, mass, units, com, inertia, attitude_deg)",
    "launch": "launch fields (kind, max_wait, max_tilt_deg, confirm_time, aim_offset)",
}


def load_design(name_or_path: str) -> Design:
    """A reference design by name, or a YAML file with keys m_c, L_n, r_n, d_L, V_e, d_c
    (its scenario mappings, read_design_file, are left aside)."""
    return read_design_file(name_or_path)[0]


def read_design_file(name_or_path: str) -> tuple[Design, dict]:
    """A reference design by name, or a design YAML file (keys m_c, L_n, r_n, d_L, V_e, d_c
    at the top level or under ``design:``), and the file's scenario mappings (group of
    DESIGN_FILE_SCENARIO -> its fields; a relative target ``mesh`` is made relative to the
    file's folder; {} for a reference design or a file with none)."""
    if name_or_path in REFERENCE_DESIGNS:
        return REFERENCE_DESIGNS[name_or_path], {}
    path = Path(name_or_path)
    if path.suffix.lower() not in (".yaml", ".yml", ".json") and not path.exists():
        raise DesignError("design", f"unknown design {name_or_path!r}; allowed names are "
                          f"{sorted(REFERENCE_DESIGNS)} or a path to a .yaml file")
    if not path.is_file():
        raise DesignError("design", f"file {str(path)!r} does not exist")
    import yaml

    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        raise DesignError("design", f"file {str(path)!r} is not valid YAML{where}") from None
    if not isinstance(data, Mapping):
        return Design.from_dict(data), {}                   # (its error names the type)
    data = dict(data)
    scenario = {g: data.pop(g) for g in DESIGN_FILE_SCENARIO if g in data}
    if isinstance(data.get("design"), Mapping):
        data = dict(data["design"])
        scenario.update({g: data.pop(g) for g in DESIGN_FILE_SCENARIO if g in data})
    scenario = {g: v for g, v in scenario.items() if v is not None}
    for group, value in scenario.items():
        if not isinstance(value, Mapping):
            raise DesignError(group, f"in {str(path)!r}: got {value!r}; must be a mapping of "
                              + DESIGN_FILE_SCENARIO[group])
    scenario = {g: dict(v) for g, v in scenario.items()}
    mesh = scenario.get("target", {}).get("mesh")
    if mesh and not Path(str(mesh)).expanduser().is_absolute():
        scenario["target"]["mesh"] = str(path.parent / str(mesh))
    return Design.from_dict(data), scenario
