"""The implicit method: compliant constraints at a fixed step (about 1 ms), the kind of
step the reference implementation's solver takes.

Every thread is a tension-only constraint on its length C = |x_b - x_a| - l0 made
compliant by its own stiffness k and damping c: implicit Euler of F = -k C - c dC/dt over
the step h, linearised, gives for the impulse P (N s, negative: tension) of the step

    J v+ + b + gamma P = 0,   b = k C / (h k + c),   gamma = 1 / (h (h k + c)),

with J v+ = dC/dt at the end of the step.  A slack thread (C <= 0) is a speculative limit
instead (b = C / h, gamma = 0): it may become exactly taut within the step but not more,
and is soft from the next step on.  Contacts with the target are the same kind of
constraint on the gap C = sd - r (pushing only, P >= 0) with the body's contact stiffness
and damping, and Coulomb friction bounded by mu_static P_n (sticking) or mu P_n (sliding).
The contact's period (0.2-0.5 ms for the reference's stiffness) is shorter than the step:
the step alone would make every impact inelastic, where the contact law rebounds with a
restitution e(zeta) (0.73 at zeta = 0.106; ``materials.kelvin_voigt_restitution``).  With
``Params.restitution`` = e > 0, a new impact (a body without contact impulse in the last
step, approaching at v_n) leaves the step at -e v_n, as the explicit method resolves it.
Ratchet locks of the drawstring are rigid limits.  The closing force is an external force.

The impulses are found by projected Gauss-Seidel sweeps (``Params``-independent count,
``iterations``), warm-started from the last step's impulses (``Solver``).  The grid threads
are swept by colour (even and odd columns of x-threads, even and odd rows of y-threads):
threads of one colour share no node, so each colour's loop has no dependence between its
iterations.  The target is held at its velocity during the step's sweeps; the sum of the
contact impulses and their moments then moves it (equal and opposite impulses: momentum is
conserved to round-off).  Then x += h v.

Units: SI (m, s, kg, N, N s).
"""
from __future__ import annotations

from numba import njit

from .contact_rows import (clear_inactive_contacts, contact_reaction, prepare_contact_rows,
                           sweep_contacts)
from .drawstring import closing_forces
from .explicit import closing_events
from .geometry import quat_to_matrix_into
from .lock_rows import prepare_lock_rows, sweep_locks
from .rigid import integrate_target
from .rows import make_rows
from .state import E_CLOSING_ACTIVE, E_TETHER_LOCKED, E_STEP, LOCK_RATCHET
from .tether import pay_out_tether
from .thread_rows import apply_gathered, prepare_thread_rows, sweep_grid, sweep_links
from .threads import gather_thread_forces
from .work import make_work, store_work


@njit(cache=True, nogil=True, error_model='numpy')
def advance_implicit(n_steps, bodies, grid, links, ring, tether, target, prm, ev, diag, sol,
                     iterations):
    """Advance the state ``n_steps`` steps of h = prm.dt in place (see the module's
    docstring); ``iterations`` Gauss-Seidel sweeps per step.  Releases the GIL."""
    h = prm.dt
    w = bodies.w
    wk = make_work(bodies, grid, links, ring)
    rows = make_rows(grid, links.pairs.shape[0], bodies.x.shape[0], ring.pairs.shape[0], w, h)
    trigger_mass = 0.0
    for k in range(ring.trigger_nodes.shape[0]):
        trigger_mass += bodies.mass[ring.trigger_nodes[k]]
    N = bodies.x.shape[0]
    for _ in range(n_steps):
        quat_to_matrix_into(target.quat, wk.R)
        # external forces: the drawstring's pull
        if ev[E_CLOSING_ACTIVE] == 1:
            for i in range(N):
                wk.FX[i] = 0.0
                wk.FY[i] = 0.0
                wk.FZ[i] = 0.0
            closing_forces(wk, ring, prm.close_force, prm.lock_model, prm.lock_dist)
            for i in range(N):
                hw = h * w[i]
                wk.VX[i] += hw * wk.FX[i]
                wk.VY[i] += hw * wk.FY[i]
                wk.VZ[i] += hw * wk.FZ[i]
        # constraint rows, warm-started
        prepare_contact_rows(wk, rows, bodies, target, prm, sol, diag)
        clear_inactive_contacts(rows, sol)
        prepare_thread_rows(wk, rows, grid, links, w, h, sol)
        gather_thread_forces(wk, grid, links)
        apply_gathered(wk, w)
        ratchet = ev[E_CLOSING_ACTIVE] == 1 and prm.lock_model == LOCK_RATCHET
        if ratchet:
            prepare_lock_rows(wk, rows, ring, w, h, sol)
        for _it in range(iterations):
            sweep_grid(wk, rows, grid, w, sol)
            sweep_links(wk, rows, links, w, sol)
            sweep_contacts(wk, rows, bodies, prm, sol)
            if ratchet:
                sweep_locks(wk, rows, ring, w, sol)
        # the contacts' impulses and moments on the target, at the step's contact points
        px, py, pz, lx, ly, lz = contact_reaction(wk, rows, target, sol, diag)
        # positions; the paid-out tether follows the winch and net centre
        for i in range(N):
            if w[i] != 0.0:
                wk.X[i] += h * wk.VX[i]
                wk.Y[i] += h * wk.VY[i]
                wk.Z[i] += h * wk.VZ[i]
        if ev[E_TETHER_LOCKED] == 0:
            pay_out_tether(wk, tether)
        # the target moves under them
        integrate_target(target, wk.R, px / h, py / h, pz / h, lx / h, ly / h, lz / h, h,
                         prm.tgt_inv_mass, wk.Lb)
        ev[E_STEP] += 1
        closing_events(wk, bodies, links, ring, tether, target, prm, ev, trigger_mass)
    store_work(wk, bodies)
    return 0
