"""The closing policy inside the kernel (docs/model.md §14; the policies' settings, their
rules in words and the policy outside the kernel are ``core.policies``): :func:`decide`,
run at each measurement, says from the newest measurement (``sensing``) whether closing
starts now.  Units: SI.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .policy_table import policies, policy_index
from .sensing import C_NET, C_OMEGA, C_QUAT, C_TGT

#: the closing policies (ControlModel.policy is the index; ``policy_table``); 'external': a
#: controller outside the kernel decides (``events.command_closing``)
POLICIES = policies("closing")
POLICY_THRESHOLD = policy_index("closing", "threshold")
POLICY_ADAPTIVE = policy_index("closing", "adaptive")
POLICY_EXTERNAL = policy_index("closing", "external")
#: sub-steps of the adaptive policy's prediction of the stage's turn
PREDICTION_STEPS = 8

#: The policy's per-lane memory (``data.Data.policy``): prev_zrel (K,) the last sensed
#: z_rel (m), has_prev (K,) uint8.
PolicyData = namedtuple("PolicyData", "prev_zrel has_prev")


def new_policy_data() -> PolicyData:
    """A one-lane policy memory: nothing sensed yet."""
    return PolicyData(prev_zrel=np.zeros(1), has_prev=np.zeros(1, dtype=np.uint8))


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
    radius = model.target.geometry.extent[1]
    extent = largest_half_depth(meas, model.target.geometry.extent[0], radius, ct.closing_time)
    if zrel >= threshold + (extent - radius):
        return True
    pd = data.policy
    at_apex = (ct.apex and pd.has_prev[l] == 1 and zrel > 0.0 and zrel <= pd.prev_zrel[l])
    pd.prev_zrel[l] = zrel
    pd.has_prev[l] = 1
    return at_apex


@njit(cache=True, error_model='numpy')
def decide_one(model, data, meas):
    return decide(model, data, 0, meas)
