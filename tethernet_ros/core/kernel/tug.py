"""The tug test inside a step (docs/model.md §16): once the host starts it
(``data.E_TUG_STEP``), the chaser thrusts away from the target's centre of mass with a
force that ramps linearly to ``Params.tug_force`` (N) over ``Params.tug_ramp`` steps
(1/tug_ramp of it in the first) and is then held; the largest tension of any main-tether segment in any step is
kept in ``Data.tug_peak`` (N).  Before the host starts it nothing here acts, so an episode
without the test is unchanged bit for bit."""
from __future__ import annotations

import numpy as np
from numba import njit

from .data import E_STEP, E_TUG_STEP


@njit(cache=True, inline='always', error_model='numpy')
def tug_thrust(model, data, l, h):
    """Lane l, while the tug test runs: the chaser's velocity gains h F w along the unit
    vector from the target's centre of mass to the chaser (F the ramped thrust, N)."""
    ev = data.events
    if ev[E_TUG_STEP, l] < 0:
        return
    prm = model.params
    ramp = (ev[E_STEP, l] - ev[E_TUG_STEP, l] + 1) / prm.tug_ramp
    if ramp > 1.0:
        ramp = 1.0
    c = model.tether.winch
    x = data.bodies.x
    pos = data.target.pos
    dx = x[c, 0, l] - pos[0, l]
    dy = x[c, 1, l] - pos[1, l]
    dz = x[c, 2, l] - pos[2, l]
    dist = np.sqrt(dx * dx + dy * dy + dz * dz)
    if dist <= 0.0:
        return
    hw = h * data.bodies.w[c, l] * prm.tug_force * ramp / dist
    v = data.bodies.v
    v[c, 0, l] += hw * dx
    v[c, 1, l] += hw * dy
    v[c, 2, l] += hw * dz


@njit(cache=True, inline='always', error_model='numpy')
def record_tether_tension(model, data, l, h):
    """Lane l, while the tug test runs: ``Data.tug_peak`` keeps the largest tension (N) of
    a main-tether segment, its step impulse over the step (the implicit method's)."""
    if data.events[E_TUG_STEP, l] < 0:
        return
    te = model.tether
    p = data.warm.link_p
    for k in range(te.links.shape[0]):
        tension = -p[te.links[k], l] / h
        if tension > data.tug_peak[l]:
            data.tug_peak[l] = tension
