"""The launch inside the kernel (docs/model.md §16; the settings and the rules in words are
``core.launch``): before the net leaves, the chaser watches the target turn and a launch
policy says, at each measurement, whether to fire now (``decide_launch``: once the
attitude has been favourable for the confirmation time).

While a lane waits, only its target moves: the kernel's own step of an untouched target
(``rigid.integrate_target`` under no force), so a wait of n steps leaves the target exactly
where n steps of flight would have turned it.  The sensor measures on its own period as
it will in flight (``measure.sense``, the same generator and buffer), and the lane's clock
keeps the waiting steps in ``E_LAUNCH_STEP``: the mission's time is the launch step plus
the flight's step.

Units: SI (s, rad).
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .data import E_FAVOURABLE_SINCE, E_LAUNCH_STEP, E_LAUNCHED
from .geometry import quat_to_matrix_lane
from .rigid import integrate_target, sub_rotation
from .measure import sense
from .policy_table import policies, policy_index
from .sensing import C_OMEGA, C_QUAT

#: the launch policies (LaunchModel.policy is the index; ``policy_table``); 'external': a
#: controller outside the kernel fires (``fire``)
LAUNCH_POLICIES = policies("launch")
LAUNCH_IMMEDIATE = policy_index("launch", "immediate")
LAUNCH_PREDICTIVE = policy_index("launch", "predictive")
LAUNCH_EXTERNAL = policy_index("launch", "external")

#: torque-free sub-steps of the prediction from the measurement to the window's start, and
#: over the window (docs/model.md §16 measures their error)
FLIGHT_STEPS = 64
WINDOW_STEPS = 8

#: The launch's constants: policy (index into LAUNCH_POLICIES); max_wait: steps after
#: which the chaser fires anyway (at its next measurement); cos_limit: the largest |a_z|
#: (the cosine between the long axis and the line of sight) the predictive policy
#: accepts over its window; confirm: steps for which every decision must have found the
#: attitude favourable before the chaser fires (a noisy measurement dips below the limit
#: before the truth does); window_start, window_end (s after the launch): when the net is
#: predicted to reach the target's centre and to finish closing; inertia (3,): the
#: principal moments the chaser believes the target has (kg m^2), its shape's.
LaunchModel = namedtuple("LaunchModel", "policy max_wait cos_limit confirm window_start "
                                        "window_end inertia")


def immediate_launch() -> LaunchModel:
    """The launch of every episode before launch policies: fire at once."""
    return LaunchModel(policy=LAUNCH_IMMEDIATE, max_wait=0, cos_limit=1.0, confirm=0,
                       window_start=0.0, window_end=0.0, inertia=np.ones(3))


@njit(cache=True, inline='always', error_model='numpy')
def _long_axis_z(q, l) -> float:
    """The z component of the body x (long) axis of attitude q[:, l] in the world frame."""
    return 2.0 * (q[1, l] * q[3, l] - q[0, l] * q[2, l])


@njit(cache=True, error_model='numpy')
def predicted_largest_az(meas, age, inertia, t0, t1):
    """The largest |a_z| of the target's long axis over [t0, t1] s from now, predicted from
    a measurement taken ``age`` s ago (its attitude and world angular velocity) by
    torque-free rotation with principal moments ``inertia``: FLIGHT_STEPS steps of the
    kernel's splitting to t0, then WINDOW_STEPS steps to t1, |a_z| read at each."""
    q = np.empty((4, 1))
    for c in range(4):
        q[c, 0] = meas[C_QUAT + c]
    R = np.empty((3, 3, 1))
    quat_to_matrix_lane(q, R, 0)
    # body angular momentum L = I R^T omega
    L = np.empty((3, 1))
    inert = np.empty((3, 1))
    for c in range(3):
        inert[c, 0] = inertia[c]
        L[c, 0] = inertia[c] * (R[0, c, 0] * meas[C_OMEGA] + R[1, c, 0] * meas[C_OMEGA + 1]
                                + R[2, c, 0] * meas[C_OMEGA + 2])
    h = (age + t0) / FLIGHT_STEPS
    for _ in range(FLIGHT_STEPS):
        _drift(q, L, inert, h)
    best = abs(_long_axis_z(q, 0))
    h = (t1 - t0) / WINDOW_STEPS
    for _ in range(WINDOW_STEPS):
        _drift(q, L, inert, h)
        a = abs(_long_axis_z(q, 0))
        if a > best:
            best = a
    return best


@njit(cache=True, inline='always', error_model='numpy')
def _drift(q, L, inertia, h):
    """One torque-free step of h (s) of attitude q and body angular momentum L (the
    kernel's symmetric splitting, ``rigid``)."""
    if h == 0.0:
        return
    half = 0.5 * h
    sub_rotation(q, L, inertia, 0, half, 0)
    sub_rotation(q, L, inertia, 1, half, 0)
    sub_rotation(q, L, inertia, 2, h, 0)
    sub_rotation(q, L, inertia, 1, half, 0)
    sub_rotation(q, L, inertia, 0, half, 0)


@njit(cache=True, inline='always', error_model='numpy')
def favourable(model, meas, age) -> bool:
    """Whether the policy finds the attitude favourable now, from its newest measurement
    (taken ``age`` s ago).  immediate: always; predictive: when the long axis is predicted
    to stay within the accepted tilt of the plane across the line of sight while the net
    wraps."""
    lm = model.launch
    if lm.policy == LAUNCH_IMMEDIATE:
        return True
    if lm.policy != LAUNCH_PREDICTIVE:
        return False
    return predicted_largest_az(meas, age, lm.inertia, lm.window_start,
                                lm.window_end) <= lm.cos_limit


@njit(cache=True, inline='always', error_model='numpy')
def decide_launch(model, since, l, valid, meas, age, step) -> bool:
    """Whether lane l fires at ``step`` (the mission's clock): once every decision since
    ``since[l]`` (its memory: the step from which the attitude has been favourable, -1:
    not now) found it favourable for at least ``confirm`` steps.  ``valid``: whether a
    measurement has arrived (none: not favourable)."""
    if valid and favourable(model, meas, age):
        if since[l] < 0:
            since[l] = step
        return step - since[l] >= model.launch.confirm
    since[l] = -1
    return False


@njit(cache=True, error_model='numpy')
def decide_launch_one(model, since, valid, meas, age, step) -> bool:
    return decide_launch(model, since, 0, valid, meas, age, step)


@njit(cache=True, inline='always', error_model='numpy')
def _drift_untouched(model, data, scr, l):
    """One step of lane l's target alone, as the flight's step moves an untouched target."""
    quat_to_matrix_lane(data.target.quat, scr.R, l)
    integrate_target(model, data, scr, l, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, model.params.dt)


@njit(cache=True, error_model='numpy')
def wait_step(model, data, scr, l) -> int:
    """One step of lane l's wait: at a control step (every sensing period), a measurement
    (buffered with its noise and latency), then the policy's decision (or, from max_wait
    on, the launch).  Returns 1 if the lane launches now (the target is then left as it
    is), else moves its target one step and returns 0; -1 when a decision needs a controller outside the kernel (policy
    'external', before the wait's end: the caller asks it, then calls :func:`fire` or
    :func:`hold`)."""
    ev = data.events
    if ev[E_LAUNCHED, l] == 1:
        return 1
    lm = model.launch
    k = ev[E_LAUNCH_STEP, l]
    if k % model.control.period == 0:
        slot = sense(model, data, scr, l)
        if k >= lm.max_wait:
            ev[E_LAUNCHED, l] = 1
            return 1
        if lm.policy == LAUNCH_EXTERNAL:
            return -1
        age = 0.0 if slot < 0 else (k - data.sensor.taken[slot, l]) * model.params.dt
        if decide_launch(model, ev[E_FAVOURABLE_SINCE], l, slot >= 0,
                         data.sensor.buf[max(slot, 0), :, l], age, k):
            ev[E_LAUNCHED, l] = 1
            return 1
    hold(model, data, scr, l)
    return 0


@njit(cache=True, error_model='numpy')
def hold(model, data, scr, l):
    """Lane l does not launch at this step: its target moves one step on."""
    _drift_untouched(model, data, scr, l)
    data.events[E_LAUNCH_STEP, l] += 1


@njit(cache=True, error_model='numpy')
def fire(data, l):
    """Lane l launches at its current step."""
    data.events[E_LAUNCHED, l] = 1


@njit(cache=True, nogil=True, error_model='numpy')
def wait_for_launch(model, data, scr):
    """Every lane waits, under its in-kernel policy, until it launches (at most the
    model's max_wait steps).  Returns the number of lanes left waiting for a controller
    outside the kernel (policy 'external')."""
    K = data.events.shape[1]
    left = 0
    for l in range(K):
        while True:
            r = wait_step(model, data, scr, l)
            if r != 0:
                break
        if r < 0:
            left += 1
    return left
