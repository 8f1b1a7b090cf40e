"""The explicit method: symplectic (semi-implicit) Euler, forces at the start of the step,
then v += dt F / m and x += dt v, every lane of a batch.

It conserves linear momentum to round-off (every force has an equal and opposite one, on
the target too), has no secular energy drift for an undamped system, and converges to the
continuous Kelvin-Voigt model as dt -> 0: snap loads rebound with the restitution the
thread damping gives.  Its stable step is set by the stiffest thread (``stability``).

Forces on a body are gathered in a fixed, mirror-invariant order so that a symmetric state
stays symmetric to the last bit.
"""
from __future__ import annotations

from numba import njit

from .contact import contact_forces
from .data import E_CLOSING_ACTIVE, E_STEP, E_TETHER_LOCKED
from .drawstring import closing_forces, project_locks
from .events import closing_events
from .geometry import quat_to_matrix_lane
from .model import LOCK_RATCHET
from .rigid import integrate_target
from .tether import pay_out_tether
from .threads import gather_thread_forces, grid_thread_forces, link_forces
from .tug import record_tether_force, tug_thrust


@njit(cache=True, inline='always', error_model='numpy')
def integrate_bodies(data, scr, dt, l):
    """Lane l: symplectic Euler on every body: v += dt w F, then x += dt v."""
    x = data.bodies.x
    v = data.bodies.v
    w = data.bodies.w
    F = scr.F
    for i in range(x.shape[0]):
        hw = dt * w[i, l]
        for c in range(3):
            v[i, c, l] += hw * F[i, c, l]
        for c in range(3):
            x[i, c, l] += dt * v[i, c, l]


@njit(cache=True, nogil=True, error_model='numpy')
def advance_explicit(model, data, scr, n_steps):
    """Advance every lane ``n_steps`` steps of dt = model.params.dt in place.  Releases the
    GIL: other Python threads of the process (a ROS node's publisher, a Dask worker's
    event loop) run beside it."""
    prm = model.params
    dt = prm.dt
    K = data.bodies.x.shape[2]
    ev = data.events
    for _ in range(n_steps):
        # 1. threads (grid, then corner threads and tether), gathered per body
        grid_thread_forces(model, data, scr)
        for l in range(K):
            link_forces(model, data, scr, l)
        gather_thread_forces(model, scr)
        for l in range(K):
            quat_to_matrix_lane(data.target.quat, scr.R, l)
            # 2. drawstring closing force
            if ev[E_CLOSING_ACTIVE, l] == 1:
                closing_forces(model, data, scr, l)
            # 3. contact with the target
            fx, fy, fz, tx, ty, tz = contact_forces(model, data, scr, l)
            # the tug test (once the host has started it): the tether's tension of this
            # step's forces, and the thrust on the chaser
            record_tether_force(model, data, scr, l)
            tug_thrust(model, data, l, dt)
            # 4. integrate the bodies; the paid-out tether follows the winch and net centre
            integrate_bodies(data, scr, dt, l)
            if ev[E_TETHER_LOCKED, l] == 0:
                pay_out_tether(model, data, l)
            # 5. integrate the target (free rigid body)
            integrate_target(model, data, scr, l, fx, fy, fz, tx, ty, tz, dt)
            # 6. drawstring locks: one-sided distance joints
            if ev[E_CLOSING_ACTIVE, l] == 1 and prm.lock_model == LOCK_RATCHET:
                project_locks(model, data, scr, l)
            ev[E_STEP, l] += 1
            # 7. events: closing trigger, winch lock, drawstring locks
            closing_events(model, data, scr, l)
    return 0
