"""Closing policies: when to start closing the net, decided from what the chaser senses
(``core.sensing``) at each measurement (docs/model.md §14).  A policy is its settings (a
field of :class:`PolicyConfig`) and one numba function, :func:`decide`, which runs inside
the kernel at the kernel's speed, or is left to a controller outside it ('external': a
ROS node, a user's own).

- ``threshold`` (the source's rule): close when the sensed z_rel = z(net point) -
  z(target) reaches the closing displacement d_c (+ its noise).  With ideal sensing at
  every step it is the source's trigger, bit for bit.
- ``adaptive``: the same threshold measured from the target's far side instead of its
  centre.  From the sensed attitude and angular velocity it predicts, over the next
  ``closing_time`` seconds, the largest half-depth of the stage along the line of sight
  (e(a) = (L/2) |a_z| + R sqrt(1 - a_z^2) for its long axis a), and closes when z_rel
  reaches d_c + e_max - R: the margin by which the net passes beyond the stage is then the
  one d_c gives a stage lying across the line of sight (e = R).  It also closes at the
  net's apex (``apex``): when z_rel, already past the target's centre, stops growing
  between two measurements, since the net will not get any farther.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from .sensing import C_NET, C_OMEGA, C_QUAT, C_TGT

POLICIES = ("threshold", "adaptive", "external")
POLICY_THRESHOLD, POLICY_ADAPTIVE, POLICY_EXTERNAL = range(3)
#: sub-steps of the adaptive policy's prediction of the stage's turn
PREDICTION_STEPS = 8


class PolicyError(ValueError):
    """A policy setting is outside its allowed range (message names the field)."""


@dataclass(frozen=True)
class PolicyConfig:
    """kind: one of ``POLICIES``; closing_time (s): the adaptive policy's horizon, the
    time the drawstring takes to close the mouth (docs/model.md §14 gives its source);
    apex: the adaptive policy also closes at the net's apex."""

    kind: str = "threshold"
    closing_time: float = 0.6
    apex: bool = True

    def __post_init__(self):
        if self.kind not in POLICIES:
            raise PolicyError(f"policy field 'kind': got {self.kind!r}; must be one of "
                              f"{', '.join(POLICIES)}")
        t = self.closing_time
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t) \
                or not 0.0 <= t <= 60.0:
            raise PolicyError(f"policy field 'closing_time': got {t!r}; must be a time in "
                              "[0, 60] s")
        if not isinstance(self.apex, bool):
            raise PolicyError(f"policy field 'apex': got {self.apex!r}; must be true or false")

    @property
    def index(self) -> int:
        return POLICIES.index(self.kind)


@njit(cache=True, inline='always', error_model='numpy')
def _half_depth(az, half_length, radius):
    """Half-extent (m) along z of a cylinder whose unit axis has z component az."""
    s = 1.0 - az * az
    return half_length * abs(az) + radius * np.sqrt(s if s > 0.0 else 0.0)


@njit(cache=True, inline='always', error_model='numpy')
def largest_half_depth(meas, half_length, radius, horizon):
    """The largest half-depth along z of the stage over the next ``horizon`` s, its long
    axis turned by the measured angular velocity in PREDICTION_STEPS Cayley steps."""
    w, x, y, z = meas[C_QUAT], meas[C_QUAT + 1], meas[C_QUAT + 2], meas[C_QUAT + 3]
    ax = 1.0 - 2.0 * (y * y + z * z)       # the body x axis in the world frame
    ay = 2.0 * (x * y + w * z)
    az = 2.0 * (x * z - w * y)
    best = _half_depth(az, half_length, radius)
    h = horizon / PREDICTION_STEPS
    hx = 0.5 * h * meas[C_OMEGA]
    hy = 0.5 * h * meas[C_OMEGA + 1]
    hz = 0.5 * h * meas[C_OMEGA + 2]
    d = 1.0 + hx * hx + hy * hy + hz * hz
    for _ in range(PREDICTION_STEPS):
        # Cayley rotation a <- (I - H)^-1 (I + H) a, H = [h]x: a rotation (exactly
        # orthogonal in exact arithmetic) by about |omega| h
        cx = ax + (hy * az - hz * ay)
        cy = ay + (hz * ax - hx * az)
        cz = az + (hx * ay - hy * ax)
        dot = hx * cx + hy * cy + hz * cz
        ax = (cx + hx * dot + (hy * cz - hz * cy)) / d
        ay = (cy + hy * dot + (hz * cx - hx * cz)) / d
        az = (cz + hz * dot + (hx * cy - hy * cx)) / d
        e = _half_depth(az, half_length, radius)
        if e > best:
            best = e
    return best


@njit(cache=True, inline='always', error_model='numpy')
def decide(model, data, l, meas) -> bool:
    """Whether lane l's policy starts closing now, given its newest measurement."""
    ct = model.control
    zrel = meas[C_NET + 2] - meas[C_TGT + 2]
    threshold = data.close_threshold[l]
    if ct.policy == POLICY_THRESHOLD:
        return zrel >= threshold
    # adaptive
    radius = model.target.cyl[2]
    extent = largest_half_depth(meas, model.target.cyl[1], radius, ct.closing_time)
    if zrel >= threshold + (extent - radius):
        return True
    pd = data.policy
    at_apex = (ct.apex and pd.has_prev[l] == 1 and zrel > 0.0 and zrel <= pd.prev_zrel[l])
    pd.prev_zrel[l] = zrel
    pd.has_prev[l] = 1
    return at_apex


@njit(cache=True, error_model='numpy')
def _decide_one(model, data, meas):
    return decide(model, data, 0, meas)


class Policy:
    """The closing policy of one episode outside the kernel (the ROS actuator node): the
    kernel's :func:`decide` on its own memory, for the episode's model and closing
    displacement, so the same measurements give the same decision, bit for bit."""

    def __init__(self, model, close_threshold: float):
        from collections import namedtuple

        from .kernel.data import PolicyData

        self._model = namedtuple("PolicyModel", "control target")(model.control, model.target)
        self._data = namedtuple("PolicyLane", "close_threshold policy")(
            np.array([float(close_threshold)]),
            PolicyData(prev_zrel=np.zeros(1), has_prev=np.zeros(1, dtype=np.uint8)))

    def decide(self, meas: np.ndarray) -> bool:
        """Whether closing starts now, given the newest measurement."""
        return bool(_decide_one(self._model, self._data, np.asarray(meas, dtype=np.float64)))
