"""The episode's events after each step, per lane: at each measurement the closing policy
decides from what the chaser senses (``sensing``, ``policy``); closing starts
(and the winch locks) when it says so, or when a controller outside the kernel commands it
(:func:`command_closing`); then the drawstring's locks."""
from __future__ import annotations

from numba import njit

from .data import E_CLOSING_ACTIVE, E_CLOSING_ARMED, E_CLOSING_STEP, E_STEP, E_TETHER_LOCKED
from .drawstring import update_locks
from .measure import mission_step, sense
from .policy import POLICY_EXTERNAL, decide
from .tether import lock_tether


@njit(cache=True, inline='always', error_model='numpy')
def start_closing(model, data, l):
    """Closing starts in lane l at its current step; the winch locks."""
    ev = data.events
    ev[E_CLOSING_ACTIVE, l] = 1
    ev[E_CLOSING_STEP, l] = ev[E_STEP, l]
    if ev[E_TETHER_LOCKED, l] == 0:
        lock_tether(model, data, l)
        ev[E_TETHER_LOCKED, l] = 1


@njit(cache=True, inline='always', error_model='numpy')
def closing_events(model, data, scr, l):
    """After a step of lane l: at a measurement step, while closing is armed and not yet
    active, the policy decides whether closing starts now; then the drawstring locks."""
    ev = data.events
    ct = model.control
    if (ev[E_CLOSING_ARMED, l] == 1 and ev[E_CLOSING_ACTIVE, l] == 0
            and mission_step(data, l) % ct.period == 0):
        slot = sense(model, data, scr, l)
        if ct.policy != POLICY_EXTERNAL and slot >= 0 \
                and decide(model, data, l, data.sensor.buf[slot, :, l]):
            start_closing(model, data, l)
    if ev[E_CLOSING_ACTIVE, l] == 1:
        update_locks(model, data, l)


@njit(cache=True, error_model='numpy')
def command_closing(model, data, l):
    """A controller outside the kernel starts closing in lane l at its current step, as
    if the policy had decided at the end of that step (the winch locks, then the
    drawstring's locks as in :func:`closing_events`).  Returns 1 if closing started, 0 if
    it was already active or not armed."""
    ev = data.events
    if ev[E_CLOSING_ARMED, l] == 0 or ev[E_CLOSING_ACTIVE, l] == 1:
        return 0
    start_closing(model, data, l)
    update_locks(model, data, l)
    return 1
