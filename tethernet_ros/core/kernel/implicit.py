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
Ratchet locks of the drawstring are rigid limits.  The closing force and the tug test's
thrust (``tug``) are external forces.

The impulses are found by projected Gauss-Seidel sweeps (``Model.iterations``),
warm-started from the last step's impulses (``Data.warm``).  The grid threads
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
from .data import E_CLOSING_ACTIVE, E_STEP, E_TETHER_LOCKED
from .drawstring import closing_forces
from .events import closing_events
from .geometry import quat_to_matrix_lane
from .lock_rows import prepare_lock_rows, sweep_locks
from .model import LOCK_RATCHET
from .rigid import integrate_target
from .tether import pay_out_tether
from .thread_rows import (apply_gathered, prepare_grid_rows, prepare_link_rows, sweep_grid,
                          sweep_links)
from .threads import gather_thread_forces
from .tug import record_tether_tension, tug_thrust


@njit(cache=True, nogil=True, error_model='numpy')
def advance_implicit(model, data, scr, n_steps):
    """Advance every lane ``n_steps`` steps of h = model.params.dt in place (see the
    module's docstring); ``model.iterations`` Gauss-Seidel sweeps per step.  The grid's
    rows and sweeps run over all lanes at once (the lane loop innermost); what differs
    between lanes (contacts, closing, locks, the tether, the target) runs lane by lane.
    Releases the GIL."""
    prm = model.params
    h = prm.dt
    K = data.bodies.x.shape[2]
    N = data.bodies.x.shape[0]
    x = data.bodies.x
    v = data.bodies.v
    w = data.bodies.w
    ev = data.events
    F = scr.F
    ratchet_model = prm.lock_model == LOCK_RATCHET
    for _ in range(n_steps):
        for l in range(K):
            quat_to_matrix_lane(data.target.quat, scr.R, l)
            # external forces: the drawstring's pull
            if ev[E_CLOSING_ACTIVE, l] == 1:
                for i in range(N):
                    F[i, 0, l] = 0.0
                    F[i, 1, l] = 0.0
                    F[i, 2, l] = 0.0
                closing_forces(model, data, scr, l)
                for i in range(N):
                    hw = h * w[i, l]
                    v[i, 0, l] += hw * F[i, 0, l]
                    v[i, 1, l] += hw * F[i, 1, l]
                    v[i, 2, l] += hw * F[i, 2, l]
            # the tug test's thrust on the chaser (once the host has started it)
            tug_thrust(model, data, l, h)
            # constraint rows, warm-started
            prepare_contact_rows(model, data, scr, l)
            clear_inactive_contacts(data, l)
            prepare_link_rows(model, data, scr, l)
        prepare_grid_rows(model, data, scr)
        gather_thread_forces(model, scr)
        apply_gathered(data, scr)
        for l in range(K):
            if ev[E_CLOSING_ACTIVE, l] == 1 and ratchet_model:
                prepare_lock_rows(model, data, scr, l)
        for _it in range(model.iterations):
            sweep_grid(model, data, scr)
            for l in range(K):
                sweep_links(model, data, scr, l)
                sweep_contacts(model, data, scr, l)
                if ev[E_CLOSING_ACTIVE, l] == 1 and ratchet_model:
                    sweep_locks(model, data, scr, l)
        for l in range(K):
            record_tether_tension(model, data, l, h)
            # the contacts' impulses and moments on the target, at the step's contact points
            px, py, pz, lx, ly, lz = contact_reaction(data, scr, l)
            # positions; the paid-out tether follows the winch and net centre
            for i in range(N):
                if w[i, l] != 0.0:
                    x[i, 0, l] += h * v[i, 0, l]
                    x[i, 1, l] += h * v[i, 1, l]
                    x[i, 2, l] += h * v[i, 2, l]
            if ev[E_TETHER_LOCKED, l] == 0:
                pay_out_tether(model, data, l)
            # the target moves under them
            integrate_target(model, data, scr, l, px / h, py / h, pz / h, lx / h, ly / h,
                             lz / h, h)
            ev[E_STEP, l] += 1
            closing_events(model, data, scr, l)
    return 0
