"""The uncertainty model of docs/noise.md: one seeded draw of every noise per sample.

World noises (belong to the scenario): distance offset D_rnd (m) and target rotation
alpha_rnd (rad) about the configured axis.  Actuator noises: per corner mass a launch speed
offset v_rnd (m/s), a polar tilt theta_rnd (rad) and an azimuth phi_rnd (rad); and a
closing-displacement offset d_rnd (m).

This module is the single noise sampler of the project: library, workers and ROS nodes all
call :meth:`NoiseModel.sample`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, asdict, replace

import numpy as np

from . import detmath
from .checks import declared_floats

#: Noise sources whose spread can be scaled (sensitivity study).
NOISE_SOURCES: tuple[str, ...] = ("distance", "orientation", "speed", "polar", "azimuth", "closing",
                                  "spin", "target")

#: The NoiseModel fields that hold a spread (the actuator node takes them as parameters).
SPREAD_FIELDS: tuple[str, ...] = ("sigma_distance", "sigma_orientation_deg", "sigma_speed",
                                  "sigma_polar_deg", "azimuth_range_deg", "sigma_closing",
                                  "sigma_spin_rate", "sigma_spin_axis_deg",
                                  "spin_phase_range_deg", "sigma_target_mass",
                                  "sigma_target_inertia", "sigma_target_com")

#: Axes the target's orientation noise may turn it about: the line of sight z (default) or
#: y (across it); the one home of this rule (docs/noise.md §2).
ORIENTATION_AXES: tuple[str, ...] = ("z", "y")

#: Allowed range of a noise source's scale factor (sensitivity study, docs/noise.md §6).
SCALE_RANGE: tuple[float, float] = (0.0, 100.0)


def check_orientation_axis(axis, field_name: str = "noise field 'orientation_axis'") -> str:
    """The axis if allowed, else a NoiseError naming ``field_name`` and the choices."""
    if axis not in ORIENTATION_AXES:
        raise NoiseError(f"{field_name}: got {axis!r}; must be "
                         + " or ".join(repr(a) for a in ORIENTATION_AXES))
    return axis


def check_scale(value, field_name: str) -> float:
    """A scale factor if finite and within SCALE_RANGE, else a NoiseError naming it."""
    lo, hi = SCALE_RANGE
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not math.isfinite(value) or not lo <= value <= hi:
        raise NoiseError(f"{field_name}: got {value!r}; must be a finite factor in "
                         f"[{lo:g}, {hi:g}]")
    return float(value)


#: Corner order used everywhere: signs (s_x, s_y) of each corner's launch velocity.
CORNER_SIGNS = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])


class NoiseError(ValueError):
    """A noise setting is outside its allowed range (message names the field)."""


@dataclass(frozen=True)
class NoiseSample:
    """One Monte Carlo draw.  Angles in rad, lengths in m, speeds in m/s."""

    seed: int | None
    distance_offset: float = 0.0
    orientation_angle: float = 0.0
    speed_offsets: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    polar_angles: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    azimuth_angles: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    closing_offset: float = 0.0
    orientation_axis: str = "z"
    spin_rate_offset: float = 0.0
    spin_axis_tilt: float = 0.0
    spin_axis_azimuth: float = 0.0
    spin_phase: float = 0.0
    spin_transverse_angle: float = 0.0
    target_mass_offset: float = 0.0
    target_inertia_offsets: tuple[float, float, float] = (0.0, 0.0, 0.0)
    target_com_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @classmethod
    def nominal(cls, orientation_axis: str = "z") -> NoiseSample:
        """No noise at all (the nominal, symmetric episode)."""
        return cls(seed=None, orientation_axis=orientation_axis)

    @property
    def is_nominal(self) -> bool:
        return self.seed is None

    def to_dict(self) -> dict:
        d = asdict(self)
        for k in ("speed_offsets", "polar_angles", "azimuth_angles", "target_inertia_offsets",
                  "target_com_offset"):
            d[k] = list(d[k])
        return d


@dataclass(frozen=True)
class NoiseModel:
    """Spreads of docs/noise.md §1 (standard deviations unless stated) and per-source scale
    factors that multiply them.

    sigma_distance (m), sigma_orientation_deg (deg), sigma_speed (m/s),
    sigma_polar_deg (deg), azimuth_range_deg (deg, uniform on [0, range)),
    sigma_closing (m); orientation_axis 'z' (line of sight, default) or 'y'.  The tumble's
    (``core.tumble``, acting only when its rate is > 0): sigma_spin_rate (relative, of the
    rate), sigma_spin_axis_deg (tilt of the axis, deg, in a uniform direction),
    spin_phase_range_deg (initial phase uniform on [0, range) deg).  The target's mass
    properties (off by default): sigma_target_mass (relative, of the mass),
    sigma_target_inertia (relative, of each principal moment), sigma_target_com (m, of the
    centre of mass along each body axis).
    """

    sigma_distance: float = 0.25
    sigma_orientation_deg: float = 45.0
    sigma_speed: float = 0.25
    sigma_polar_deg: float = 2.0
    azimuth_range_deg: float = 360.0
    sigma_closing: float = 0.1
    sigma_spin_rate: float = 0.1
    sigma_spin_axis_deg: float = 5.0
    spin_phase_range_deg: float = 360.0
    sigma_target_mass: float = 0.0
    sigma_target_inertia: float = 0.0
    sigma_target_com: float = 0.0
    orientation_axis: str = "z"
    scales: dict = field(default_factory=lambda: {s: 1.0 for s in NOISE_SOURCES})

    def __post_init__(self):
        declared_floats(self)
        for name in SPREAD_FIELDS:
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise NoiseError(f"noise field '{name}': got {v!r}; must be a finite number >= 0")
        check_orientation_axis(self.orientation_axis)
        scales = {s: 1.0 for s in NOISE_SOURCES}
        for k, v in dict(self.scales).items():
            if k not in NOISE_SOURCES:
                raise NoiseError(f"noise field 'scales.{k}': unknown source; allowed {list(NOISE_SOURCES)}")
            scales[k] = check_scale(v, f"noise field 'scales.{k}'")
        object.__setattr__(self, "scales", scales)

    def spreads(self) -> dict:
        """The spreads by field name (:data:`SPREAD_FIELDS`), unscaled."""
        return {k: getattr(self, k) for k in SPREAD_FIELDS}

    def with_scales(self, **scales: float) -> NoiseModel:
        merged = dict(self.scales)
        merged.update(scales)
        return replace(self, scales=merged)

    def sample(self, seed: int) -> NoiseSample:
        """Draw every noise of one sample from ``numpy.random.default_rng(seed)``.

        The draw order is fixed (distance, orientation, then per corner speed, polar,
        azimuth, then closing, then the tumble's rate, axis tilt and its direction, phase
        and transverse angle, then, for a target whose mass properties are uncertain, its
        mass, its three moments and its centre of mass along x, y, z), and every quantity
        is drawn whatever its scale, so sample i
        gets the same underlying random numbers under every design and scale (common random
        numbers); the tumble's draws, then the target's, come after the others, so every
        earlier draw is what it was before they existed.
        """
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise NoiseError(f"noise field 'seed': got {seed!r}; must be an integer >= 0")
        rng = np.random.default_rng(int(seed))
        normal = detmath.standard_normal
        z_dist = normal(rng)
        z_orient = normal(rng)
        z_speed = np.empty(4)
        z_polar = np.empty(4)
        u_azim = np.empty(4)
        for i in range(4):
            z_speed[i] = normal(rng)
            z_polar[i] = normal(rng)
            u_azim[i] = rng.random()
        z_close = normal(rng)
        z_spin_rate = normal(rng)
        z_spin_tilt = normal(rng)
        u_spin_dir = rng.random()
        u_spin_phase = rng.random()
        u_transverse = rng.random()
        # the target's draws, last, only when it is uncertain (a known target's offsets are
        # 0 whatever they would draw; every earlier draw is the same either way)
        known = (self.sigma_target_mass == 0.0 and self.sigma_target_inertia == 0.0
                 and self.sigma_target_com == 0.0)
        z_mass = 0.0 if known else normal(rng)
        z_inertia = [0.0] * 3 if known else [normal(rng) for _ in range(3)]
        z_com = [0.0] * 3 if known else [normal(rng) for _ in range(3)]
        st = self.scales["target"]
        s = self.scales
        deg = math.pi / 180.0
        turn = 2.0 * math.pi
        return NoiseSample(
            seed=int(seed),
            distance_offset=float(z_dist * self.sigma_distance * s["distance"]),
            orientation_angle=float(z_orient * self.sigma_orientation_deg * deg * s["orientation"]),
            speed_offsets=tuple(float(v) for v in z_speed * self.sigma_speed * s["speed"]),
            polar_angles=tuple(float(v) for v in z_polar * self.sigma_polar_deg * deg * s["polar"]),
            azimuth_angles=tuple(float(v) for v in u_azim * self.azimuth_range_deg * deg * s["azimuth"]),
            closing_offset=float(z_close * self.sigma_closing * s["closing"]),
            orientation_axis=self.orientation_axis,
            spin_rate_offset=float(z_spin_rate * self.sigma_spin_rate * s["spin"]),
            spin_axis_tilt=float(z_spin_tilt * self.sigma_spin_axis_deg * deg * s["spin"]),
            spin_axis_azimuth=float(u_spin_dir * turn),
            spin_phase=float(u_spin_phase * self.spin_phase_range_deg * deg * s["spin"]),
            spin_transverse_angle=float(u_transverse * turn),
            target_mass_offset=float(z_mass * self.sigma_target_mass * st),
            target_inertia_offsets=tuple(float(z * self.sigma_target_inertia * st)
                                         for z in z_inertia),
            target_com_offset=tuple(float(z * self.sigma_target_com * st) for z in z_com),
        )


def nominal_corner_velocities(V_e) -> np.ndarray:
    """(4, 3) nominal launch velocities (m/s): corner k gets [s_x V_x, s_y V_y, V_z]."""
    vx, vy, vz = (float(v) for v in V_e)
    out = np.empty((4, 3))
    out[:, 0] = CORNER_SIGNS[:, 0] * vx
    out[:, 1] = CORNER_SIGNS[:, 1] * vy
    out[:, 2] = vz
    return out


def perturb_velocity(v: np.ndarray, speed_offset: float, polar: float, azimuth: float) -> np.ndarray:
    """Apply the spherical perturbation of docs/noise.md §3 to one velocity (m/s).

    The speed |v| changes by ``speed_offset``; the direction is tilted away from the
    nominal direction u by ``polar`` (rad) in the plane spanned by u and
    e(azimuth) = cos(azimuth) e1 + sin(azimuth) e2, where (e1, e2, u) is right-handed and
    e1 is the unit vector of z_hat x u (x_hat if u is along z).
    """
    v = np.asarray(v, dtype=float)
    speed = detmath.norm3(v)
    if speed == 0.0:
        return v.copy()
    u = v / speed
    e1 = np.cross([0.0, 0.0, 1.0], u)
    n1 = detmath.norm3(e1)
    e1 = e1 / n1 if n1 > 1e-12 else np.array([1.0, 0.0, 0.0])
    e2 = np.cross(u, e1)
    d = (detmath.cos(polar) * u
         + detmath.sin(polar) * (detmath.cos(azimuth) * e1 + detmath.sin(azimuth) * e2))
    return (speed + speed_offset) * d


def corner_velocities(V_e, sample: NoiseSample | None) -> np.ndarray:
    """(4, 3) launch velocities of the corner masses (m/s) with actuator noise applied."""
    nominal = nominal_corner_velocities(V_e)
    if sample is None or sample.is_nominal:
        return nominal
    return np.array([perturb_velocity(nominal[k], sample.speed_offsets[k], sample.polar_angles[k],
                                      sample.azimuth_angles[k]) for k in range(4)])
