"""Simulation configuration: every model constant and modelling choice with its default,
its source and its allowed range.

Where the source study's text (docs/model.md §1-5) and its reference implementation (Botta
et al.'s Vortex model, docs/model.md §10) differ, both are selectable; ``MODEL_PRESETS``
names the two complete models ("spec-text", "reference").  docs/model.md lists every
value with its source.

Units: SI (m, s, kg, N, Pa).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace, asdict

from .checks import declared_floats
from .launch import LaunchConfig
from .policies import PolicyConfig
from .sensing import SensingConfig
from .target import TargetConfig
from .tug import TugConfig
from .tumble import TumbleConfig

#: nested settings: field -> its dataclass (a mapping in YAML / JSON)
_NESTED = {"target": TargetConfig, "tumble": TumbleConfig, "sensing": SensingConfig,
           "policy": PolicyConfig, "launch": LaunchConfig, "tug": TugConfig}


class ConfigError(ValueError):
    """A configuration value is outside its allowed range (message names the field)."""


# field -> (lower, upper, what) ; bounds inclusive, checked for finiteness too
_LIMITS = {
    "dt": (0.0, 0.01, "a time step in (0, 0.01] s, or 0 for the automatic stable step"),
    "dt_safety": (0.01, 1.0, "a fraction of the stable step in [0.01, 1]"),
    "horizon": (1.0, 3600.0, "a horizon in [1, 3600] s"),
    "settle_time": (0.0, 600.0, "a settling time in [0, 600] s"),
    "young_modulus": (1e6, 1e13, "an effective Young's modulus in [1e6, 1e13] Pa"),
    "damping_ratio": (0.0, 10.0, "a damping ratio in [0, 10]"),
    "density": (1.0, 1e5, "a density in [1, 1e5] kg/m^3"),
    "stowed_fraction": (1e-4, 0.5, "a stowed side fraction in [1e-4, 0.5]"),
    "corner_thread_meshes": (0.01, 100.0, "a corner-thread length in [0.01, 100] mesh sides"),
    "tether_segments": (1, 1000, "a segment count in [1, 1000]"),
    "lock_distance": (0.0, 100.0, "a lock distance in [0, 100] m"),
    "closing_force_factor": (0.0, 1e3, "a factor in [0, 1e3] (F_c = factor m_c L_n)"),
    "friction": (0.0, 10.0, "a friction coefficient in [0, 10]"),
    "contact_frequency": (1.0, 1e5, "a contact natural frequency in [1, 1e5] rad/s"),
    "contact_damping_ratio": (0.0, 10.0, "a damping ratio in [0, 10]"),
    "node_contact_radius": (1e-4, 1.0, "a radius in [1e-4, 1] m"),
    "corner_mass_radius": (1e-4, 1.0, "a radius in [1e-4, 1] m"),
    "chaser_mass": (1.0, 1e6, "a mass in [1, 1e6] kg"),
    "chaser_side": (0.01, 100.0, "a side in [0.01, 100] m"),
    "metric_rate": (0.1, 1000.0, "a rate in [0.1, 1000] Hz"),
    "state_rate": (0.0, 1000.0, "a rate in [0, 1000] Hz (0: no node-position trace)"),
    "max_speed": (1.0, 1e6, "a speed in [1, 1e6] m/s"),
    "success_cqi": (0.0, 1e6, "a CQI threshold >= 0"),
    "success_locked_pairs": (0, 12, "a pair count in [0, 12]"),
    "static_friction_scale": (1.0, 10.0, "a static / kinetic friction ratio in [1, 10]"),
    "poisson_ratio": (0.0, 0.5, "a Poisson ratio in [0, 0.5]"),
    "target_young_modulus": (1e6, 1e13, "a Young's modulus in [1e6, 1e13] Pa"),
    "target_poisson_ratio": (0.0, 0.5, "a Poisson ratio in [0, 0.5]"),
    "corner_mass_density": (100.0, 1e5, "a density in [100, 1e5] kg/m^3"),
    "hertz_penetration": (1e-7, 1e-2, "a penetration in [1e-7, 1e-2] m"),
    "hertz_divisor": (1.0, 1e3, "a divisor in [1, 1000]"),
    "tether_radius": (0.0, 0.05, "a radius in [0, 0.05] m (0: the net's thread radius r_n)"),
    "implicit_iterations": (1, 1000, "an iteration count in [1, 1000]"),
    "implicit_dt": (1e-5, 0.01, "a time step in [1e-5, 0.01] s"),
}

# field -> allowed values of the modelling choices
_CHOICES = {
    "thread_damping": ("element", "stiffness"),
    "contact_model": ("frequency", "hertz"),
    "contact_radius": ("fixed", "density"),
    "lock_model": ("ratchet", "latch", "cinch"),
    "drawstring_corners": ("net", "corner_mass"),
    "integrator": ("explicit", "implicit"),
    "implicit_impacts": ("rebound", "inelastic"),
    "tether_order": ("reversed", "chain"),
    "criterion": ("source", "held"),
}
#: the success criteria (``SimConfig.criterion``)
CRITERIA = _CHOICES["criterion"]


@dataclass(frozen=True)
class SimConfig:
    """Model and integration settings.

    dt: integration step (s); 0 picks dt_safety times the explicit method's stable step
    (kernel.stable_step), rounded down to divide the metric interval, or implicit_dt for the
    implicit method; horizon: simulated time by which closing must trigger (s);
    settle_time: delay after closing activation at which settled CQI and n_L are read (s).
    early_call: at half the settle time, call a success that is already clear (CQI at most
    half of success_cqi and every drawstring pair locked: metrics.clear_success) and end the
    episode there, reading that state as the settled one; T still counts the whole settle
    time.  An approximation measured in docs/studies/fidelity.md ("A clear success called
    early"); off by default.
    Threads: young_modulus E (Pa), damping_ratio zeta, density rho (kg/m^3).
    Net: grid of 17 x 17 nodes, stowed square of side stowed_fraction * L_n; corner threads
    of corner_thread_meshes mesh sides; main tether of tether_segments segments.
    Closing: F_c = closing_force_factor * m_c * L_n (N) per adjacent pair, lock below
    lock_distance (m); the drawstring runs through grid indices closing_indices on each side.
    Contact: Coulomb friction coefficient; Kelvin-Voigt penalty given per body by a natural
    frequency omega_c (rad/s; stiffness m omega_c^2, so an impact at v sinks about
    v / omega_c) and damping ratio; sphere radii of net/tether nodes and corner masses (m).
    Chaser: free-floating cube of chaser_mass (kg) and chaser_side (m); the winch sits at the
    launch point.
    Tug test (``tug``, off by default): after the settle time the chaser pulls the
    tether and the capture holds or not (core/tug.py, docs/model.md §17).
    criterion: what ``success`` means: 'source' (default), the source's settled CQI at most
    success_cqi and at least success_locked_pairs locked; 'held', that and the tug test
    holding the required pull (it turns the tug test on; ``with_criterion``).
    Output: metric_rate (Hz) of the CQI / n_L trace, state_rate (Hz) of node positions.
    max_speed (m/s): any body faster than this marks the episode as diverged.
    Success: settled CQI <= success_cqi and n_L >= success_locked_pairs.

    Modelling choices (text = docs/model.md §1-5, code = the reference implementation,
    docs/model.md §10):
    thread_damping: "element" (text: c = 2 zeta sqrt(k m_eff) per thread) or "stiffness"
    (code: c = 2 zeta k / omega_1, omega_1 the net's first axial natural frequency);
    friction: kinetic Coulomb coefficient (text 0.3; code net-aluminium 0.19 / 1.25 =
    0.152), static_friction_scale: static / kinetic ratio (text 1; code 1.25);
    contact_model: "frequency" (per-body natural frequency contact_frequency) or "hertz"
    (code: Hertz stiffness 4/3 E* sqrt(R) sqrt(2 hertz_penetration / 3) / hertz_divisor,
    E* from young_modulus / poisson_ratio of the net and target_young_modulus /
    target_poisson_ratio of the stage; damping 2 contact_damping_ratio sqrt(k m));
    contact_radius: "fixed" (node_contact_radius, corner_mass_radius) or "density" (code:
    a sphere of the body's mass at thread density, corner masses at corner_mass_density);
    corner_thread_meshes: corner-thread length in mesh sides (text 1, code sqrt 2);
    closing_force_factor: F_c = factor m_c L_n (text 2/25, code 2/1^2 for the perimeter);
    lock_model: "ratchet" (text as implemented: the force acts on every pair, a locked pair
    is held by a one-sided joint that only shortens) or "latch" (code: the force acts only
    while a pair is >= lock_distance apart; a lock is a latch that holds nothing) or
    "cinch" (neither's: the force acts on every pair always, as a winch that keeps reeling
    the drawstring in, and a lock only counts the pair; docs/studies/tug-checks.md);
    drawstring_corners: the ring's corners are the net's corner nodes ("net", text) or the
    corner masses ("corner_mass", code); tether_radius: main tether thread radius (m; 0:
    r_n as in the text; code 2 mm).
    integrator: "explicit" (symplectic Euler at a fraction of the stable step) or
    "implicit" (compliant constraints at implicit_dt (s) unless dt is set,
    implicit_iterations solver sweeps per step); implicit_impacts: "rebound" (a new impact
    leaves with the restitution of the Kelvin-Voigt contact law, as the continuous model
    and the explicit method have it) or "inelastic" (none: what a step longer than the
    contact's period gives by itself).
    tether_order: where the paid-out main tether's lumped masses lie on the line from the
    winch to the net's centre: "reversed" (each mass at the place of its mirror image in
    the chain, so the tether locked at closing zigzags, its first and last segments each
    spanning most of the line: the model of every result before 2026-12-06, kept so that
    they reproduce) or "chain" (in the chain's order: the locked tether is straight, its
    rest length the winch-to-centre distance).  docs/model.md §5.
    """

    dt: float = 0.0
    dt_safety: float = 0.5
    horizon: float = 120.0
    settle_time: float = 20.0
    early_call: bool = False
    young_modulus: float = 70e9
    damping_ratio: float = 0.106
    density: float = 1390.0
    grid_nodes: int = 17
    stowed_fraction: float = 0.05
    corner_thread_meshes: float = math.sqrt(2.0)
    tether_segments: int = 10
    closing_indices: tuple[int, ...] = (0, 5, 11, 16)
    lock_distance: float = 1.0
    closing_force_factor: float = 2.0
    friction: float = 0.152
    contact_frequency: float = 1000.0
    contact_damping_ratio: float = 0.106
    node_contact_radius: float = 0.02
    corner_mass_radius: float = 0.05
    chaser_mass: float = 1000.0
    chaser_side: float = 1.5
    metric_rate: float = 10.0
    state_rate: float = 0.0
    max_speed: float = 500.0
    success_cqi: float = 2.0
    success_locked_pairs: int = 10
    thread_damping: str = "stiffness"
    static_friction_scale: float = 1.25
    contact_model: str = "hertz"
    poisson_ratio: float = 0.36
    target_young_modulus: float = 69e9
    target_poisson_ratio: float = 0.33
    hertz_penetration: float = 1e-4
    hertz_divisor: float = 10.0
    contact_radius: str = "density"
    corner_mass_density: float = 2700.0
    lock_model: str = "latch"
    drawstring_corners: str = "corner_mass"
    tether_radius: float = 0.002
    integrator: str = "implicit"
    implicit_iterations: int = 4
    implicit_dt: float = 1e-3
    implicit_impacts: str = "rebound"
    tether_order: str = "reversed"
    target: TargetConfig = field(default_factory=TargetConfig)
    tumble: TumbleConfig = field(default_factory=TumbleConfig)
    sensing: SensingConfig = field(default_factory=SensingConfig)
    policy: PolicyConfig = field(default_factory=PolicyConfig)
    launch: LaunchConfig = field(default_factory=LaunchConfig)
    tug: TugConfig = field(default_factory=TugConfig)
    criterion: str = "source"

    def __post_init__(self):
        declared_floats(self)
        for name, (lo, hi, what) in _LIMITS.items():
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                    or not (lo <= v <= hi):
                raise ConfigError(f"config field '{name}': got {v!r}; must be {what}")
        for name, allowed in _CHOICES.items():
            v = getattr(self, name)
            if v not in allowed:
                raise ConfigError(f"config field '{name}': got {v!r}; must be one of "
                                  f"{', '.join(repr(a) for a in allowed)}")
        for name in ("tether_segments", "success_locked_pairs", "grid_nodes", "implicit_iterations"):
            if int(getattr(self, name)) != getattr(self, name):
                raise ConfigError(f"config field '{name}': must be an integer")
        if self.grid_nodes != 17:
            raise ConfigError("config field 'grid_nodes': only the 17 x 17 grid of docs/model.md §1 is supported")
        idx = tuple(self.closing_indices)
        if len(idx) < 2 or idx[0] != 0 or idx[-1] != self.grid_nodes - 1 or list(idx) != sorted(set(idx)):
            raise ConfigError("config field 'closing_indices': must be increasing grid indices "
                              f"from 0 to {self.grid_nodes - 1}")
        object.__setattr__(self, "closing_indices", idx)
        for name, cls in _NESTED.items():
            v = getattr(self, name)
            if isinstance(v, dict):
                object.__setattr__(self, name, _nested(name, cls, v))
            elif not isinstance(v, cls):
                raise ConfigError(f"config field '{name}': got {v!r}; must be a mapping of "
                                  f"{cls.__name__} fields")
        if not isinstance(self.early_call, bool):
            raise ConfigError(f"config field 'early_call': got {self.early_call!r}; must be "
                              "true or false")
        if self.criterion == "held" and not self.tug.enabled:
            raise ConfigError("config field 'criterion': 'held' needs the tug test on "
                              "(tug.enabled true; a config file's or a flag's criterion: held "
                              "turns it on, docs/model.md §17)")
        if self.tug.enabled:
            self._check_tug()
        for name in ("dt", "implicit_dt"):
            step = getattr(self, name)
            if step > 0:
                steps_per_metric = 1.0 / (self.metric_rate * step)
                if abs(steps_per_metric - round(steps_per_metric)) > 1e-6:
                    raise ConfigError(f"config field '{name}': 1/(metric_rate*{name}) must be a "
                                      "whole number of steps")

    def _check_tug(self) -> None:
        """What the tug test needs of the rest of the configuration (ConfigError naming
        the field)."""
        if self.early_call:
            raise ConfigError("config field 'early_call': the tug test starts from the "
                              "settled state at the end of the settle time; leave early_call "
                              "off when the tug test is on")
        if self.tether_order != "chain":
            raise ConfigError("config field 'tug.enabled': the tug test needs tether_order "
                              f"'chain'; got {self.tether_order!r} (the 'reversed' tether is "
                              "locked with about 2.6 times its straight length, docs/model.md §5)")

    def step_for(self, stable_step: float) -> float:
        """The integration step (s): ``dt`` if set, else dt_safety * stable_step rounded
        down so that a whole number of steps fills the metric interval."""
        if self.dt > 0:
            return self.dt
        if self.integrator == "implicit":
            return self.implicit_dt
        interval = 1.0 / self.metric_rate
        return interval / math.ceil(interval / (self.dt_safety * stable_step))

    @classmethod
    def preset(cls, name: str, **overrides) -> SimConfig:
        """A named model (``MODEL_PRESETS``) with optional field overrides."""
        if name not in MODEL_PRESETS:
            raise ConfigError(f"config field 'preset': got {name!r}; must be one of "
                              f"{sorted(MODEL_PRESETS)}")
        return cls(**{**MODEL_PRESETS[name], **overrides})

    def replace(self, **changes) -> SimConfig:
        return replace(self, **changes)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["closing_indices"] = list(self.closing_indices)
        d["tumble"] = self.tumble.to_dict()
        d["target"] = self.target.to_dict()
        d["launch"] = self.launch.to_dict()
        return d

    @classmethod
    def from_dict(cls, data: dict) -> SimConfig:
        """From a mapping of field values; a ``preset`` key names the model the other
        fields override (default: the project's default model)."""
        data = dict(data)
        preset = data.pop("preset", None)
        names = {f.name for f in fields(cls)}
        for k in data:
            if k not in names:
                raise ConfigError(f"config field '{k}': unknown; allowed fields are {sorted(names)}")
        data = with_criterion(data)
        for name, ncls in _NESTED.items():
            if name in data and isinstance(data[name], dict):
                data[name] = _nested(name, ncls, data[name])
        if "closing_indices" in data:
            data["closing_indices"] = tuple(data["closing_indices"])
        if preset is not None:
            return cls.preset(preset, **data)
        return cls(**data)


def with_criterion(data: dict) -> dict:
    """A configuration mapping with what its ``criterion`` needs: 'held' turns the tug test
    on (``tug.enabled``) and, unless the mapping sets it, the straight tether
    (``tether_order: chain``), as ``--tug`` does.  The one home of this rule (config files,
    flags, ROS requests)."""
    data = dict(data)
    if data.get("criterion") != "held":
        return data
    tug = data.get("tug", {})
    if isinstance(tug, TugConfig):
        tug = tug.to_dict()
    if isinstance(tug, dict):
        data["tug"] = {**tug, "enabled": True}
    data.setdefault("tether_order", "chain")
    return data


def _nested(name: str, cls, values: dict):
    """A nested settings object from a mapping; unknown keys named in the error."""
    allowed = {f.name for f in fields(cls)}
    for k in values:
        if k not in allowed:
            raise ConfigError(f"config field '{name}.{k}': unknown; allowed fields are "
                              f"{sorted(allowed)}")
    try:
        return cls(**values)
    except ValueError as exc:
        raise ConfigError(str(exc)) from exc


#: Named models: field values that differ from the defaults.  The defaults are the
#: reference implementation's model (docs/model.md §10) on the implicit method at its 1 ms
#: step ("reference" changes nothing).  "spec-text": the model as the source's text words it
#: (docs/model.md §1-5),
#: on the explicit method: the project's model up to the reference study, kept so that its
#: results are reproduced bit for bit (tests/test_kernel_golden.py).
MODEL_PRESETS: dict[str, dict] = {
    "reference": {},
    "spec-text": dict(
        thread_damping="element", friction=0.3, static_friction_scale=1.0,
        contact_model="frequency", contact_damping_ratio=0.3, contact_radius="fixed",
        corner_thread_meshes=1.0, closing_force_factor=2.0 / 25.0, lock_model="ratchet",
        drawstring_corners="net", tether_radius=0.0, integrator="explicit"),
}
