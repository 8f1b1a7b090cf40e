"""A lane's clock and its measurement, shared by the wait before launch (``launch``) and
the flight (``events``): the mission's step (the steps waited before the launch plus the
flight's) and the measurement the sensor takes at it (``sensing``)."""
from __future__ import annotations

from numba import njit

from .data import E_LAUNCH_STEP, E_STEP
from .sensing import buffer_measurement, truth_into


@njit(cache=True, inline='always', error_model='numpy')
def mission_step(data, l) -> int:
    """Lane l's step on the mission's clock: the waiting steps plus the flight's."""
    return data.events[E_LAUNCH_STEP, l] + data.events[E_STEP, l]


@njit(cache=True, inline='always', error_model='numpy')
def sense(model, data, scr, l) -> int:
    """Take lane l's measurement of this step (:func:`truth_into`,
    :func:`buffer_measurement`) on the mission's clock; the slot of the newest one the
    controller has, or -1."""
    out = scr.meas
    truth_into(model, data, l, out)
    return buffer_measurement(model.control, data.sensor, l, out, mission_step(data, l))
