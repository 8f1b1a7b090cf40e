"""The target's tumble: its initial spin (rate, axis, phase), a scenario setting with noise
on each part (docs/model.md §1, docs/noise.md §1).

Real targets tumble: Envisat's spin period was measured at 226 s, about 1.6 deg/s, with a
nutation cone of about 80 deg (Sommer et al., JBIS 70, 2017, from TIRA radar images), and
spent rocket bodies drift toward a flat spin about a transverse axis.  The Zenit-2 stage
is a symmetric top about its long (body x) axis.

The axis is given in the target's body frame, named or as a vector:
``flat``: body y, a transverse axis perpendicular to the line of sight at the nominal
attitude (the stage turns end over end toward the chaser); ``los``: body z, the line of
sight at the nominal attitude (a transverse spin seen face-on); ``long``: body x (a roll
about the long axis); ``transverse``: a transverse axis at a random angle about the long
axis (drawn per sample).  The phase turns the initial attitude about the spin axis.
The default, a rate of 0, is a target at rest: its attitude and every result are those of
a build without this module.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import detmath
from .checks import declared_floats, finite_numbers

#: named axes in the target's body frame (x: the long axis)
AXES = {"flat": (0.0, 1.0, 0.0), "los": (0.0, 0.0, 1.0), "long": (1.0, 0.0, 0.0)}
#: a transverse axis at a random angle about the long axis, drawn per sample
TRANSVERSE = "transverse"
#: the largest spin rate accepted (deg/s): beyond it the net's 20-60 s capture would see the
#: stage turn several times, far outside any measured tumble (Envisat: 1.6 deg/s)
MAX_RATE_DEG_S = 60.0


class TumbleError(ValueError):
    """A tumble setting is outside its allowed range (message names the field)."""


@dataclass(frozen=True)
class TumbleConfig:
    """rate_deg_s: spin rate in [0, 60] deg/s (0: at rest); axis: a name of ``AXES``,
    'transverse', or a body-frame vector (x, y, z), normalised; phase_deg: initial turn
    about the spin axis (deg)."""

    rate_deg_s: float = 0.0
    axis: object = "flat"
    phase_deg: float = 0.0

    def __post_init__(self):
        declared_floats(self)
        r = self.rate_deg_s
        if isinstance(r, bool) or not isinstance(r, (int, float)) or not math.isfinite(r) \
                or not 0.0 <= r <= MAX_RATE_DEG_S:
            raise TumbleError(f"tumble field 'rate_deg_s': got {r!r}; must be a rate in "
                              f"[0, {MAX_RATE_DEG_S:g}] deg/s")
        p = self.phase_deg
        if isinstance(p, bool) or not isinstance(p, (int, float)) or not math.isfinite(p):
            raise TumbleError(f"tumble field 'phase_deg': got {p!r}; must be a finite angle (deg)")
        a = self.axis
        if isinstance(a, str):
            if a not in AXES and a != TRANSVERSE:
                raise TumbleError(f"tumble field 'axis': got {a!r}; must be one of "
                                  f"{sorted(AXES) + [TRANSVERSE]} or a vector [x, y, z]")
        else:
            v = finite_numbers(a)
            if v is None or len(v) != 3:
                raise TumbleError(f"tumble field 'axis': got {a!r}; must be a name or three "
                                  "finite numbers")
            if v[0] * v[0] + v[1] * v[1] + v[2] * v[2] == 0.0:
                raise TumbleError("tumble field 'axis': got the zero vector; must have a "
                                  "direction")
            object.__setattr__(self, "axis", v)

    @property
    def at_rest(self) -> bool:
        return self.rate_deg_s == 0.0

    def to_dict(self) -> dict:
        return {"rate_deg_s": self.rate_deg_s,
                "axis": self.axis if isinstance(self.axis, str) else list(self.axis),
                "phase_deg": self.phase_deg}


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / detmath.norm3(v)


def spin_of(tumble: TumbleConfig, sample=None) -> tuple[np.ndarray, float, float]:
    """(unit axis in the body frame, rate (rad/s), phase (rad)) of one episode: the
    configured tumble with the sample's noise (docs/noise.md §1): the rate times
    (1 + relative noise, at least 0), the axis tilted by the tilt noise toward the drawn
    azimuth, the phase plus the drawn phase, a 'transverse' axis at the drawn angle."""
    deg = math.pi / 180.0
    if tumble.axis == TRANSVERSE:
        ang = 0.0 if sample is None else sample.spin_transverse_angle
        axis = np.array([0.0, detmath.cos(ang), detmath.sin(ang)])
    elif isinstance(tumble.axis, str):
        axis = np.array(AXES[tumble.axis])
    else:
        axis = _unit(tumble.axis)
    rate = tumble.rate_deg_s * deg
    phase = tumble.phase_deg * deg
    if sample is not None and not sample.is_nominal:
        rate = rate * max(0.0, 1.0 + sample.spin_rate_offset)
        axis = tilt(axis, sample.spin_axis_tilt, sample.spin_axis_azimuth)
        phase = phase + sample.spin_phase
    return axis, rate, phase


def tilt(u: np.ndarray, angle: float, azimuth: float) -> np.ndarray:
    """The unit vector u tilted by ``angle`` (rad) toward the direction ``azimuth`` (rad)
    about it, in the plane of e1 = (u x a) normalised (a the body axis least aligned with
    u) and e2 = u x e1."""
    if angle == 0.0:
        return u
    a = np.zeros(3)
    a[int(np.argmin(np.abs(u)))] = 1.0
    e1 = _unit(np.cross(u, a))
    e2 = np.cross(u, e1)
    d = (detmath.cos(angle) * u
         + detmath.sin(angle) * (detmath.cos(azimuth) * e1 + detmath.sin(azimuth) * e2))
    return _unit(d)


def axis_quaternion(axis: np.ndarray, angle: float) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a turn by ``angle`` (rad) about the unit ``axis``."""
    s = detmath.sin(angle / 2)
    return np.array([detmath.cos(angle / 2), s * axis[0], s * axis[1], s * axis[2]])


def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a (x) b of quaternions (w, x, y, z)."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                     w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def symmetric_top_axis(axis, ang_mom, inertia, t: float) -> np.ndarray:
    """The symmetry axis (world unit vector) of a torque-free symmetric top (I_y = I_z)
    ``t`` s after it was ``axis``: it precesses about the fixed world angular momentum L
    at |L| / I_t (Landau and Lifshitz, Mechanics, section 33; the kernel keeps to this
    closed form, tests/test_core_tumble.py).  ``inertia``: principal moments (kg m^2)."""
    e = np.asarray(axis, dtype=float)
    big_l = float(np.linalg.norm(ang_mom))
    if not t or big_l == 0.0:
        return e
    lhat = np.asarray(ang_mom, dtype=float) / big_l
    a = big_l / float(inertia[1]) * float(t)
    return (e * math.cos(a) + np.cross(lhat, e) * math.sin(a)
            + lhat * float(np.dot(lhat, e)) * (1.0 - math.cos(a)))


def free_rotation(quat, ang_mom, inertia, t: float, dt: float = 1e-3) -> np.ndarray:
    """The attitude (w, x, y, z) of a torque-free rigid body of any shape ``t`` s after
    ``quat``, under world angular momentum ``ang_mom`` (kg m^2/s) and principal moments
    ``inertia`` (kg m^2): the kernel's own drift (kernel/rigid.py) in steps of ``dt`` s
    (the last one shorter), the attitude an untouched target would have."""
    from .kernel.rigid import free_attitude

    n = int(math.floor(t / dt + 1e-9))          # whole steps (t a multiple of dt: exactly)
    q = free_attitude(np.asarray(quat, dtype=np.float64), np.asarray(ang_mom, dtype=np.float64),
                      np.asarray(inertia, dtype=np.float64), float(dt), n)
    rest = float(t) - n * dt
    if rest > 1e-9 * dt:
        q = free_attitude(q, np.asarray(ang_mom, dtype=np.float64),
                          np.asarray(inertia, dtype=np.float64), rest, 1)
    return q
