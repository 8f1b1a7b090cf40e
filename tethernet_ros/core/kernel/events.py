"""The episode's events after each step, per lane: the closing trigger (and the winch lock
it brings), then the drawstring's locks."""
from __future__ import annotations

from numba import njit

from .drawstring import update_locks
from .state import E_CLOSING_ACTIVE, E_CLOSING_ARMED, E_CLOSING_STEP, E_STEP, E_TETHER_LOCKED
from .tether import lock_tether


@njit(cache=True, inline='always', error_model='numpy')
def trigger_z(model, data, l):
    """z (m) of the centre of mass of the trigger nodes in lane l."""
    x = data.bodies.x
    mass = data.bodies.mass
    nodes = model.ring.trigger_nodes
    zc = 0.0
    for k in range(nodes.shape[0]):
        zc += mass[nodes[k], l] * x[nodes[k], 2, l]
    return zc / model.ring.trigger_mass


@njit(cache=True, inline='always', error_model='numpy')
def closing_events(model, data, l):
    """After a step of lane l: start closing when z(net CoM) - z(target CoM) reaches the
    lane's threshold (and lock the winch), then update the drawstring locks."""
    ev = data.events
    if ev[E_CLOSING_ARMED, l] == 1 and ev[E_CLOSING_ACTIVE, l] == 0:
        zc = trigger_z(model, data, l)
        if zc - data.target.pos[2, l] >= data.close_threshold[l]:
            ev[E_CLOSING_ACTIVE, l] = 1
            ev[E_CLOSING_STEP, l] = ev[E_STEP, l]
            if ev[E_TETHER_LOCKED, l] == 0:
                lock_tether(model, data, l)
                ev[E_TETHER_LOCKED, l] = 1
    if ev[E_CLOSING_ACTIVE, l] == 1:
        update_locks(model, data, l)
