"""The tug test inside a step (docs/model.md §17).  Once the host starts it
(``data.E_TUG_STEP``), the chaser thrusts with ``Data.tug_force`` (N) away from the
target's centre of mass:

- *taking up the slack*: until the tether first carries half the thrust
  (``data.E_TUG_TAUT``), the thrust acts only while the chaser moves away from the target
  slower than ``Params.tug_creep`` (m/s), so that the tether and the net tighten at that
  speed and do not snap taut;
- *the pull*: from then on it acts whatever the speed.

The largest tension of any main-tether segment in any step is kept in ``Data.tug_peak``
(N), the thrust's impulse in ``Data.tug_impulse`` (N s).  Before the host starts the test
nothing here acts, so an episode without it is unchanged bit for bit."""
from __future__ import annotations

import numpy as np
from numba import njit

from .data import E_STEP, E_TUG_STEP, E_TUG_TAUT


@njit(cache=True, inline='always', error_model='numpy')
def tug_thrust(model, data, l, h):
    """Lane l, while the tug test runs: the chaser's velocity gains h F w along the unit
    vector from the target's centre of mass to the chaser (F the thrust of the phase, N)."""
    ev = data.events
    if ev[E_TUG_STEP, l] < 0:
        return
    prm = model.params
    c = model.tether.winch
    x = data.bodies.x
    v = data.bodies.v
    tg = data.target
    dx = x[c, 0, l] - tg.pos[0, l]
    dy = x[c, 1, l] - tg.pos[1, l]
    dz = x[c, 2, l] - tg.pos[2, l]
    dist = np.sqrt(dx * dx + dy * dy + dz * dz)
    if dist <= 0.0:
        return
    ux = dx / dist
    uy = dy / dist
    uz = dz / dist
    if ev[E_TUG_TAUT, l] < 0:
        away = ((v[c, 0, l] - tg.vel[0, l]) * ux + (v[c, 1, l] - tg.vel[1, l]) * uy
                + (v[c, 2, l] - tg.vel[2, l]) * uz)
        if away >= prm.tug_creep:
            return
    p = h * data.tug_force[l]
    data.tug_impulse[0, l] += p * ux
    data.tug_impulse[1, l] += p * uy
    data.tug_impulse[2, l] += p * uz
    hw = p * data.bodies.w[c, l]
    v[c, 0, l] += hw * ux
    v[c, 1, l] += hw * uy
    v[c, 2, l] += hw * uz


@njit(cache=True, inline='always', error_model='numpy')
def record_tether_tension(model, data, l, h):
    """Lane l, while the tug test runs: ``Data.tug_peak`` keeps the largest tension (N) of
    a main-tether segment (its step impulse over the step, the implicit method's), and the
    first step with half the thrust is marked taut (``E_TUG_TAUT``).  The explicit
    method's is :func:`record_tether_force`."""
    ev = data.events
    if ev[E_TUG_STEP, l] < 0:
        return
    te = model.tether
    p = data.warm.link_p
    for k in range(te.links.shape[0]):
        tension = -p[te.links[k], l] / h
        if tension > data.tug_peak[l]:
            data.tug_peak[l] = tension
    if ev[E_TUG_TAUT, l] < 0 and data.tug_peak[l] >= 0.5 * data.tug_force[l]:
        ev[E_TUG_TAUT, l] = ev[E_STEP, l]


@njit(cache=True, inline='always', error_model='numpy')
def record_tether_force(model, data, scr, l):
    """The explicit method's :func:`record_tether_tension`: the tension (N) of a
    main-tether segment is its Kelvin-Voigt force of the step (``scr.EF``, tension only)."""
    ev = data.events
    if ev[E_TUG_STEP, l] < 0:
        return
    te = model.tether
    EF = scr.EF
    for k in range(te.links.shape[0]):
        m = te.links[k]
        tension = np.sqrt(EF[m, 0, l] * EF[m, 0, l] + EF[m, 1, l] * EF[m, 1, l]
                          + EF[m, 2, l] * EF[m, 2, l])
        if tension > data.tug_peak[l]:
            data.tug_peak[l] = tension
    if ev[E_TUG_TAUT, l] < 0 and data.tug_peak[l] >= 0.5 * data.tug_force[l]:
        ev[E_TUG_TAUT, l] = ev[E_STEP, l]
