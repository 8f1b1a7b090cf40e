"""The explicit method: symplectic (semi-implicit) Euler, forces at the start of the step,
then v += dt F / m and x += dt v.

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
from .drawstring import closing_forces, project_locks, update_locks
from .geometry import quat_to_matrix_into
from .rigid import integrate_target
from .state import (E_CLOSING_ACTIVE, E_CLOSING_ARMED, E_CLOSING_STEP, E_STEP, E_TETHER_LOCKED,
                    LOCK_RATCHET)
from .tether import lock_tether, pay_out_tether
from .threads import gather_thread_forces, grid_thread_forces, link_forces
from .work import make_work, store_work


@njit(cache=True, inline='always', error_model='numpy')
def integrate_bodies(wk, w, dt):
    """Symplectic Euler on every body: v += dt w F, then x += dt v (vectorised)."""
    X, Y, Z, VX, VY, VZ, FX, FY, FZ = wk.X, wk.Y, wk.Z, wk.VX, wk.VY, wk.VZ, wk.FX, wk.FY, wk.FZ
    for i in range(X.shape[0]):
        hw = dt * w[i]
        VX[i] += hw * FX[i]
        VY[i] += hw * FY[i]
        VZ[i] += hw * FZ[i]
        X[i] += dt * VX[i]
        Y[i] += dt * VY[i]
        Z[i] += dt * VZ[i]


@njit(cache=True, inline='always', error_model='numpy')
def net_centre_z(wk, mass, nodes, total_mass):
    """z of the centre of mass of ``nodes`` (m)."""
    zc = 0.0
    for k in range(nodes.shape[0]):
        zc += mass[nodes[k]] * wk.Z[nodes[k]]
    return zc / total_mass


@njit(cache=True, inline='always', error_model='numpy')
def closing_events(wk, bodies, links, ring, tether, target, prm, ev, trigger_mass):
    """After a step: start closing when z(net CoM) - z(target CoM) reaches the threshold
    (and lock the winch), then update the drawstring locks."""
    if ev[E_CLOSING_ARMED] == 1 and ev[E_CLOSING_ACTIVE] == 0:
        zc = net_centre_z(wk, bodies.mass, ring.trigger_nodes, trigger_mass)
        if zc - target.pos[2] >= prm.close_threshold:
            ev[E_CLOSING_ACTIVE] = 1
            ev[E_CLOSING_STEP] = ev[E_STEP]
            if ev[E_TETHER_LOCKED] == 0:
                lock_tether(wk, bodies, links, tether, prm)
                ev[E_TETHER_LOCKED] = 1
    if ev[E_CLOSING_ACTIVE] == 1:
        update_locks(wk, ring, prm.lock_dist, ev[E_STEP])


@njit(cache=True, nogil=True, error_model='numpy')
def advance(n_steps, bodies, grid, links, ring, tether, target, prm, ev, diag):
    """Advance the state ``n_steps`` steps of dt = prm.dt in place.

    The state is copied to structure-of-arrays form for the step loop (so the grid loops
    vectorise) and back at the end; the result does not depend on how steps are chunked.
    The kernel releases the GIL: other Python threads of the process (the ROS node's
    publisher, a Dask worker's event loop) run beside it.
    """
    dt = prm.dt
    wk = make_work(bodies, grid, links, ring)
    trigger_mass = 0.0
    for k in range(ring.trigger_nodes.shape[0]):
        trigger_mass += bodies.mass[ring.trigger_nodes[k]]
    for _ in range(n_steps):
        quat_to_matrix_into(target.quat, wk.R)
        # 1. threads (grid, then corner threads and tether), gathered per body
        grid_thread_forces(wk, grid)
        link_forces(wk, links)
        gather_thread_forces(wk, grid, links)
        # 2. drawstring closing force
        if ev[E_CLOSING_ACTIVE] == 1:
            closing_forces(wk, ring, prm.close_force, prm.lock_model, prm.lock_dist)
        # 3. contact with the target
        fx_t, fy_t, fz_t, tx_t, ty_t, tz_t = contact_forces(wk, bodies, target, prm, diag)
        # 4. integrate the bodies; the paid-out tether follows the winch and net centre
        integrate_bodies(wk, bodies.w, dt)
        if ev[E_TETHER_LOCKED] == 0:
            pay_out_tether(wk, tether)
        # 5. integrate the target (free rigid body)
        integrate_target(target, wk.R, fx_t, fy_t, fz_t, tx_t, ty_t, tz_t, dt, prm.tgt_inv_mass,
                         wk.Lb)
        # 6. drawstring locks: one-sided distance joints
        if ev[E_CLOSING_ACTIVE] == 1 and prm.lock_model == LOCK_RATCHET:
            project_locks(wk, bodies.w, ring)
        ev[E_STEP] += 1
        # 7. events: closing trigger, winch lock, drawstring locks
        closing_events(wk, bodies, links, ring, tether, target, prm, ev, trigger_mass)
    store_work(wk, bodies)
    return 0
