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

from collections import namedtuple

import numpy as np
from numba import njit

from .drawstring import closing_forces
from .explicit import closing_events
from .geometry import local_sdf, quat_to_matrix_into
from .rigid import integrate_target
from .state import CONTACT_FREQUENCY, E_CLOSING_ACTIVE, E_TETHER_LOCKED, E_STEP, LOCK_RATCHET
from .tether import pay_out_tether
from .threads import gather_thread_forces
from .work import make_work, store_work

#: Contact rows are made for bodies within h |v_rel| + SPECULATIVE_MARGIN (m) of the target:
#: the threads and the drawstring can whip a light node to more than 20 m/s within a step,
#: faster than its velocity at the step's start announces.
SPECULATIVE_MARGIN = 0.05

#: Per-step rows.  Grid x-threads (n, n - 1) and y-threads (n - 1, n): unit direction
#: (hnx, hny, hnz / vnx..), bias b (m/s), compliance gamma (1/kg) and 1 / (w_a + w_b +
#: gamma) (kg).  Links (M,): the same plus their ends' rows.  Contacts, one per body at
#: most (N,): normal (cnx..), the target's material velocity at the body (cvx..), bias,
#: compliance, 1 / (w + gamma), and ``crow`` the bodies with a row (first ``n_rows[0]``).
#: Locks (P,): direction, bias, 1 / (w_a + w_b).  Constant over a call, per grid thread:
#: k / (h k + c) (1/s), 1 / (h (h k + c)) (1/kg) and 1 / (w_a + w_b + gamma) when taut,
#: 1 / (w_a + w_b) when slack (hkd, hgd, hikt, hiks; vkd.. for y-threads).
Rows = namedtuple("Rows", "hnx hny hnz hb hg hik vnx vny vnz vb vg vik "
                          "hkd hgd hikt hiks vkd vgd vikt viks "
                          "lnx lny lnz lb lg lik "
                          "cnx cny cnz cvx cvy cvz cb cg cik crow n_rows "
                          "qnx qny qnz qb qik")


@njit(cache=True, inline='always')
def _thread_constants(k, c, wsum, h):
    """k / (h k + c), 1 / (h (h k + c)), and the inverse effective masses taut and slack."""
    denom = h * k + c
    if denom <= 0.0:
        return 0.0, 0.0, (1.0 / wsum if wsum > 0.0 else 0.0), (1.0 / wsum if wsum > 0.0 else 0.0)
    g = 1.0 / (h * denom)
    return k / denom, g, 1.0 / (wsum + g), (1.0 / wsum if wsum > 0.0 else 0.0)


@njit(cache=True)
def make_rows(grid, n_links, n_bodies, n_pairs, w, h):
    """Row storage of one call, with the grid threads' constants for the step h (s)."""
    ng = grid.n
    nh = (ng, max(ng - 1, 0))
    nv = (max(ng - 1, 0), ng)
    rows = Rows(np.zeros(nh), np.zeros(nh), np.zeros(nh), np.zeros(nh), np.zeros(nh), np.zeros(nh),
                np.zeros(nv), np.zeros(nv), np.zeros(nv), np.zeros(nv), np.zeros(nv), np.zeros(nv),
                np.zeros(nh), np.zeros(nh), np.zeros(nh), np.zeros(nh),
                np.zeros(nv), np.zeros(nv), np.zeros(nv), np.zeros(nv),
                np.zeros(n_links), np.zeros(n_links), np.zeros(n_links), np.zeros(n_links),
                np.zeros(n_links), np.zeros(n_links),
                np.zeros(n_bodies), np.zeros(n_bodies), np.zeros(n_bodies), np.zeros(n_bodies),
                np.zeros(n_bodies), np.zeros(n_bodies), np.zeros(n_bodies), np.zeros(n_bodies),
                np.zeros(n_bodies), np.zeros(n_bodies, dtype=np.int64), np.zeros(1, dtype=np.int64),
                np.zeros(n_pairs), np.zeros(n_pairs), np.zeros(n_pairs), np.zeros(n_pairs),
                np.zeros(n_pairs))
    for i in range(ng):
        for j in range(ng - 1):
            a = i * ng + j
            kd, gd, ikt, iks = _thread_constants(grid.kh[i, j], grid.ch[i, j], w[a] + w[a + 1], h)
            rows.hkd[i, j] = kd
            rows.hgd[i, j] = gd
            rows.hikt[i, j] = ikt
            rows.hiks[i, j] = iks
    for i in range(ng - 1):
        for j in range(ng):
            a = i * ng + j
            kd, gd, ikt, iks = _thread_constants(grid.kv[i, j], grid.cv[i, j], w[a] + w[a + ng], h)
            rows.vkd[i, j] = kd
            rows.vgd[i, j] = gd
            rows.vikt[i, j] = ikt
            rows.viks[i, j] = iks
    return rows


@njit(cache=True, inline='always')
def _thread_row(dx, dy, dz, rest, k, c, wsum, h):
    """Direction, bias, compliance and inverse effective mass of one thread row
    (branch-free, so that the grid loops vectorise)."""
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    inv = 1.0 / max(length, 1e-12)
    C = length - rest
    denom = h * k + c
    taut = C > 0.0 and denom > 0.0
    safe = denom if denom > 0.0 else 1.0
    b = k * C / safe if taut else C / h
    g = 1.0 / (h * safe) if taut else 0.0
    s = wsum + g
    ik = 1.0 / s if s > 0.0 else 0.0
    return dx * inv, dy * inv, dz * inv, b, g, ik


@njit(cache=True, inline='always')
def _grid_row(dx, dy, dz, rest, kd, gd, ikt, iks, inv_h):
    """A grid thread's row from its per-call constants: direction, bias, compliance and
    inverse effective mass (branch-free)."""
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    inv = 1.0 / max(length, 1e-12)
    C = length - rest
    taut = C > 0.0
    b = kd * C if taut else C * inv_h
    g = gd if taut else 0.0
    ik = ikt if taut else iks
    return dx * inv, dy * inv, dz * inv, b, g, ik


@njit(cache=True, inline='always', error_model='numpy')
def prepare_thread_rows(wk, rows, grid, links, w, h, sol):
    """Rows of every grid thread and active other thread at the start of the step, and the
    last step's impulses along this step's directions, in the explicit method's force
    layout (wk.HX.., UX.., EF as impulses): ``gather_thread_forces`` then sums them."""
    ng = grid.n
    inv_h = 1.0 / h
    X, Y, Z = wk.X, wk.Y, wk.Z
    for i in range(ng):
        r0 = i * ng
        xr = X[r0:r0 + ng]
        yr = Y[r0:r0 + ng]
        zr = Z[r0:r0 + ng]
        nxr = rows.hnx[i]
        nyr = rows.hny[i]
        nzr = rows.hnz[i]
        br = rows.hb[i]
        gr = rows.hg[i]
        ikr = rows.hik[i]
        pr = sol.grid_ph[i]
        h0 = i * (ng + 1)
        hx = wk.HX[h0:h0 + ng + 1]
        hy = wk.HY[h0:h0 + ng + 1]
        hz = wk.HZ[h0:h0 + ng + 1]
        kd = rows.hkd[i]
        gd = rows.hgd[i]
        ikt = rows.hikt[i]
        iks = rows.hiks[i]
        for j in range(ng - 1):
            nx, ny, nz, b, g, ik = _grid_row(xr[j + 1] - xr[j], yr[j + 1] - yr[j],
                                             zr[j + 1] - zr[j], grid.rest, kd[j], gd[j], ikt[j],
                                             iks[j], inv_h)
            nxr[j] = nx
            nyr[j] = ny
            nzr[j] = nz
            br[j] = b
            gr[j] = g
            ikr[j] = ik
            # the impulse P n on the second end (P < 0: tension), -P n on the first
            hx[j + 1] = -pr[j] * nx
            hy[j + 1] = -pr[j] * ny
            hz[j + 1] = -pr[j] * nz
    for i in range(ng - 1):
        r0 = i * ng
        r1 = r0 + ng
        nxr = rows.vnx[i]
        nyr = rows.vny[i]
        nzr = rows.vnz[i]
        br = rows.vb[i]
        gr = rows.vg[i]
        ikr = rows.vik[i]
        pr = sol.grid_pv[i]
        ux = wk.UX[r1:r1 + ng]
        uy = wk.UY[r1:r1 + ng]
        uz = wk.UZ[r1:r1 + ng]
        xa = X[r0:r0 + ng]
        ya = Y[r0:r0 + ng]
        za = Z[r0:r0 + ng]
        xb = X[r1:r1 + ng]
        yb = Y[r1:r1 + ng]
        zb = Z[r1:r1 + ng]
        kd = rows.vkd[i]
        gd = rows.vgd[i]
        ikt = rows.vikt[i]
        iks = rows.viks[i]
        for j in range(ng):
            nx, ny, nz, b, g, ik = _grid_row(xb[j] - xa[j], yb[j] - ya[j], zb[j] - za[j],
                                             grid.rest, kd[j], gd[j], ikt[j], iks[j], inv_h)
            nxr[j] = nx
            nyr[j] = ny
            nzr[j] = nz
            br[j] = b
            gr[j] = g
            ikr[j] = ik
            ux[j] = -pr[j] * nx
            uy[j] = -pr[j] * ny
            uz[j] = -pr[j] * nz
    for m in range(links.pairs.shape[0]):
        wk.EF[m, 0] = 0.0
        wk.EF[m, 1] = 0.0
        wk.EF[m, 2] = 0.0
        a = links.pairs[m, 0]
        b_ = links.pairs[m, 1]
        if links.active[m] == 0:
            rows.lik[m] = 0.0
            sol.link_p[m] = 0.0
            continue
        nx, ny, nz, b, g, ik = _thread_row(X[b_] - X[a], Y[b_] - Y[a], Z[b_] - Z[a],
                                           links.rest[m], links.k[m], links.c[m], w[a] + w[b_], h)
        rows.lnx[m] = nx
        rows.lny[m] = ny
        rows.lnz[m] = nz
        rows.lb[m] = b
        rows.lg[m] = g
        rows.lik[m] = ik
        wk.EF[m, 0] = -sol.link_p[m] * nx
        wk.EF[m, 1] = -sol.link_p[m] * ny
        wk.EF[m, 2] = -sol.link_p[m] * nz


@njit(cache=True, inline='always', error_model='numpy')
def apply_gathered(wk, w):
    """v += w P for the per-body impulse sums in wk.FX.. (N s)."""
    for i in range(wk.VX.shape[0]):
        wk.VX[i] += w[i] * wk.FX[i]
        wk.VY[i] += w[i] * wk.FY[i]
        wk.VZ[i] += w[i] * wk.FZ[i]


@njit(cache=True, inline='always')
def _apply(wk, w, a, b, nx, ny, nz, dP):
    """Impulse dP along n on b and -dP on a (velocities, m/s)."""
    wk.VX[a] -= w[a] * nx * dP
    wk.VY[a] -= w[a] * ny * dP
    wk.VZ[a] -= w[a] * nz * dP
    wk.VX[b] += w[b] * nx * dP
    wk.VY[b] += w[b] * ny * dP
    wk.VZ[b] += w[b] * nz * dP


@njit(cache=True, inline='always')
def _solve_row(va_x, va_y, va_z, vb_x, vb_y, vb_z, wa, wb, nx, ny, nz, b, g, ik, pr, j, ja, jb):
    """One tension-only thread row between va[ja] and vb[jb] with impulse pr[j] (N s):
    the projected Gauss-Seidel update."""
    jv = nx * (vb_x[jb] - va_x[ja]) + ny * (vb_y[jb] - va_y[ja]) + nz * (vb_z[jb] - va_z[ja])
    P = pr[j]
    Pn = min(P - (jv + b + g * P) * ik, 0.0)
    pr[j] = Pn
    dP = Pn - P
    va_x[ja] -= wa[ja] * nx * dP
    va_y[ja] -= wa[ja] * ny * dP
    va_z[ja] -= wa[ja] * nz * dP
    vb_x[jb] += wb[jb] * nx * dP
    vb_y[jb] += wb[jb] * ny * dP
    vb_z[jb] += wb[jb] * nz * dP


@njit(cache=True, inline='always', error_model='numpy')
def sweep_grid(wk, rows, grid, w, sol):
    """One Gauss-Seidel sweep over the grid threads, colour by colour: x-threads of even,
    then odd columns; y-threads of even, then odd rows (threads of one colour share no
    node)."""
    ng = grid.n
    VX, VY, VZ = wk.VX, wk.VY, wk.VZ
    for colour in range(2):
        for i in range(ng):
            r0 = i * ng
            vx = VX[r0:r0 + ng]
            vy = VY[r0:r0 + ng]
            vz = VZ[r0:r0 + ng]
            wr = w[r0:r0 + ng]
            nxr = rows.hnx[i]
            nyr = rows.hny[i]
            nzr = rows.hnz[i]
            br = rows.hb[i]
            gr = rows.hg[i]
            ikr = rows.hik[i]
            pr = sol.grid_ph[i]
            for j in range(colour, ng - 1, 2):
                _solve_row(vx, vy, vz, vx, vy, vz, wr, wr, nxr[j], nyr[j], nzr[j], br[j], gr[j],
                           ikr[j], pr, j, j, j + 1)
    for colour in range(2):
        for i in range(colour, ng - 1, 2):
            r0 = i * ng
            r1 = r0 + ng
            va_x = VX[r0:r0 + ng]
            va_y = VY[r0:r0 + ng]
            va_z = VZ[r0:r0 + ng]
            vb_x = VX[r1:r1 + ng]
            vb_y = VY[r1:r1 + ng]
            vb_z = VZ[r1:r1 + ng]
            wa = w[r0:r0 + ng]
            wb = w[r1:r1 + ng]
            nxr = rows.vnx[i]
            nyr = rows.vny[i]
            nzr = rows.vnz[i]
            br = rows.vb[i]
            gr = rows.vg[i]
            ikr = rows.vik[i]
            pr = sol.grid_pv[i]
            for j in range(ng):
                _solve_row(va_x, va_y, va_z, vb_x, vb_y, vb_z, wa, wb, nxr[j], nyr[j], nzr[j],
                           br[j], gr[j], ikr[j], pr, j, j, j)


@njit(cache=True, inline='always', error_model='numpy')
def sweep_links(wk, rows, links, w, sol):
    """One Gauss-Seidel sweep over the other threads (corner threads, tether)."""
    VX, VY, VZ = wk.VX, wk.VY, wk.VZ
    for m in range(links.pairs.shape[0]):
        if rows.lik[m] == 0.0:
            continue
        _solve_row(VX, VY, VZ, VX, VY, VZ, w, w, rows.lnx[m], rows.lny[m], rows.lnz[m],
                   rows.lb[m], rows.lg[m], rows.lik[m], sol.link_p, m, links.pairs[m, 0],
                   links.pairs[m, 1])


@njit(cache=True, inline='always', error_model='numpy')
def prepare_contact_rows(wk, rows, bodies, target, prm, sol, diag):
    """A contact row for every body touching the target or close enough to touch it
    within the step (speculative); warm-start impulses applied.  wk.R must hold the
    target's rotation matrix."""
    X, Y, Z, VX, VY, VZ = wk.X, wk.Y, wk.Z, wk.VX, wk.VY, wk.VZ
    R = wk.R
    h = prm.dt
    w = bodies.w
    tp = target.pos
    tv = target.vel
    ox, oy, oz = target.omega[0], target.omega[1], target.omega[2]
    n_rows = 0
    for i in range(X.shape[0]):
        if bodies.contact_mask[i] == 0 or w[i] == 0.0:
            sol.contact_pn[i] = 0.0
            continue
        rx = X[i] - tp[0]
        ry = Y[i] - tp[1]
        rz = Z[i] - tp[2]
        # material velocity of the target at the body and the body's speed relative to it
        cvx = tv[0] + oy * rz - oz * ry
        cvy = tv[1] + oz * rx - ox * rz
        cvz = tv[2] + ox * ry - oy * rx
        vrel = np.sqrt((VX[i] - cvx) ** 2 + (VY[i] - cvy) ** 2 + (VZ[i] - cvz) ** 2)
        reach = bodies.radius[i] + h * vrel + SPECULATIVE_MARGIN
        rb = prm.tgt_bound + reach
        if rx * rx + ry * ry + rz * rz > rb * rb:
            sol.contact_pn[i] = 0.0
            continue
        bx = R[0, 0] * rx + R[1, 0] * ry + R[2, 0] * rz
        by = R[0, 1] * rx + R[1, 1] * ry + R[2, 1] * rz
        bz = R[0, 2] * rx + R[1, 2] * ry + R[2, 2] * rz
        sd, nbx, nby, nbz = local_sdf(bx, by, bz, target.cyl, target.verts, target.offsets)
        C = sd - bodies.radius[i]                  # gap (m), negative: penetration
        if C > h * vrel + SPECULATIVE_MARGIN:
            sol.contact_pn[i] = 0.0
            continue
        if -C > diag.max_penetration[0]:
            diag.max_penetration[0] = -C
        nx = R[0, 0] * nbx + R[0, 1] * nby + R[0, 2] * nbz
        ny = R[1, 0] * nbx + R[1, 1] * nby + R[1, 2] * nbz
        nz = R[2, 0] * nbx + R[2, 1] * nby + R[2, 2] * nbz
        if prm.contact_model == CONTACT_FREQUENCY:
            om = prm.omega_contact
            k = bodies.mass[i] * om * om
            c = 2.0 * prm.zeta_contact * bodies.mass[i] * om
        else:
            k = bodies.k_contact[i]
            c = bodies.c_contact[i]
        denom = h * k + c
        if C < 0.0 and denom > 0.0:
            b = k * C / denom
            g = 1.0 / (h * denom)
        else:
            b = C / h
            g = 0.0
        # a new impact (no contact impulse last step) rebounds with the contact law's
        # restitution: the normal velocity after the step is -e times the one before
        vn0 = (VX[i] - cvx) * nx + (VY[i] - cvy) * ny + (VZ[i] - cvz) * nz
        if prm.restitution > 0.0 and vn0 < 0.0 and sol.contact_pn[i] == 0.0 and C < -h * vn0:
            b = prm.restitution * vn0
            g = 0.0
        rows.crow[n_rows] = i
        n_rows += 1
        rows.cnx[i] = nx
        rows.cny[i] = ny
        rows.cnz[i] = nz
        rows.cvx[i] = cvx
        rows.cvy[i] = cvy
        rows.cvz[i] = cvz
        rows.cb[i] = b
        rows.cg[i] = g
        rows.cik[i] = 1.0 / (w[i] + g)
        # warm start: last step's normal impulse, and its friction in this tangent plane
        pt = sol.contact_pt[i]
        pn_dot = pt[0] * nx + pt[1] * ny + pt[2] * nz
        pt[0] -= pn_dot * nx
        pt[1] -= pn_dot * ny
        pt[2] -= pn_dot * nz
        pn = sol.contact_pn[i]
        VX[i] += w[i] * (pn * nx + pt[0])
        VY[i] += w[i] * (pn * ny + pt[1])
        VZ[i] += w[i] * (pn * nz + pt[2])
    rows.n_rows[0] = n_rows


@njit(cache=True, inline='always', error_model='numpy')
def sweep_contacts(wk, rows, bodies, prm, sol):
    """One Gauss-Seidel sweep over the contact rows: the normal impulse (pushing only),
    then the friction impulse that stops the slip, kept if within mu_static P_n, else
    mu P_n against the slip."""
    VX, VY, VZ = wk.VX, wk.VY, wk.VZ
    w = bodies.w
    for r in range(rows.n_rows[0]):
        i = rows.crow[r]
        nx = rows.cnx[i]
        ny = rows.cny[i]
        nz = rows.cnz[i]
        ux = VX[i] - rows.cvx[i]
        uy = VY[i] - rows.cvy[i]
        uz = VZ[i] - rows.cvz[i]
        vn = ux * nx + uy * ny + uz * nz
        P = sol.contact_pn[i]
        Pn = max(P - (vn + rows.cb[i] + rows.cg[i] * P) * rows.cik[i], 0.0)
        sol.contact_pn[i] = Pn
        dP = Pn - P
        VX[i] += w[i] * dP * nx
        VY[i] += w[i] * dP * ny
        VZ[i] += w[i] * dP * nz
        # friction
        pt = sol.contact_pt[i]
        if prm.mu <= 0.0 or Pn <= 0.0:
            VX[i] -= w[i] * pt[0]
            VY[i] -= w[i] * pt[1]
            VZ[i] -= w[i] * pt[2]
            pt[0] = 0.0
            pt[1] = 0.0
            pt[2] = 0.0
            continue
        ux = VX[i] - rows.cvx[i]
        uy = VY[i] - rows.cvy[i]
        uz = VZ[i] - rows.cvz[i]
        vn = ux * nx + uy * ny + uz * nz
        tx = ux - vn * nx
        ty = uy - vn * ny
        tz = uz - vn * nz
        qx = pt[0] - tx / w[i]
        qy = pt[1] - ty / w[i]
        qz = pt[2] - tz / w[i]
        mag = np.sqrt(qx * qx + qy * qy + qz * qz)
        if mag > prm.mu_static * Pn:
            s = prm.mu * Pn / mag
            qx *= s
            qy *= s
            qz *= s
        VX[i] += w[i] * (qx - pt[0])
        VY[i] += w[i] * (qy - pt[1])
        VZ[i] += w[i] * (qz - pt[2])
        pt[0] = qx
        pt[1] = qy
        pt[2] = qz


@njit(cache=True, inline='always', error_model='numpy')
def prepare_lock_rows(wk, rows, ring, w, h, sol):
    """Rigid one-sided rows of the ratchet locks (C = d - maxdist <= 0 at the step's end);
    warm-start impulses applied."""
    X, Y, Z = wk.X, wk.Y, wk.Z
    for p in range(ring.pairs.shape[0]):
        if ring.locked[p] == 0:
            rows.qik[p] = 0.0
            sol.lock_p[p] = 0.0
            continue
        a = ring.pairs[p, 0]
        b = ring.pairs[p, 1]
        dx = X[b] - X[a]
        dy = Y[b] - Y[a]
        dz = Z[b] - Z[a]
        d = np.sqrt(dx * dx + dy * dy + dz * dz)
        wsum = w[a] + w[b]
        if d < 1e-12 or wsum == 0.0:
            rows.qik[p] = 0.0
            sol.lock_p[p] = 0.0
            continue
        rows.qnx[p] = dx / d
        rows.qny[p] = dy / d
        rows.qnz[p] = dz / d
        rows.qb[p] = (d - ring.maxdist[p]) / h
        rows.qik[p] = 1.0 / wsum
        _apply(wk, w, a, b, rows.qnx[p], rows.qny[p], rows.qnz[p], sol.lock_p[p])


@njit(cache=True, inline='always', error_model='numpy')
def sweep_locks(wk, rows, ring, w, sol):
    """One Gauss-Seidel sweep over the ratchet locks (rigid rows: no compliance)."""
    VX, VY, VZ = wk.VX, wk.VY, wk.VZ
    for p in range(ring.pairs.shape[0]):
        if rows.qik[p] == 0.0:
            continue
        _solve_row(VX, VY, VZ, VX, VY, VZ, w, w, rows.qnx[p], rows.qny[p], rows.qnz[p],
                   rows.qb[p], 0.0, rows.qik[p], sol.lock_p, p, ring.pairs[p, 0], ring.pairs[p, 1])


@njit(cache=True, inline='always', error_model='numpy')
def contact_reaction(wk, rows, target, sol, diag):
    """Total impulse (N s) of the contacts on the target and its moment about the target's
    CoM (N m s), world frame: minus the impulses on the bodies, acting at their centres."""
    px = 0.0
    py = 0.0
    pz = 0.0
    lx = 0.0
    ly = 0.0
    lz = 0.0
    n_contacts = 0
    for r in range(rows.n_rows[0]):
        i = rows.crow[r]
        pn = sol.contact_pn[i]
        if pn > 0.0:
            n_contacts += 1
        fx = -(pn * rows.cnx[i] + sol.contact_pt[i, 0])
        fy = -(pn * rows.cny[i] + sol.contact_pt[i, 1])
        fz = -(pn * rows.cnz[i] + sol.contact_pt[i, 2])
        rx = wk.X[i] - target.pos[0]
        ry = wk.Y[i] - target.pos[1]
        rz = wk.Z[i] - target.pos[2]
        px += fx
        py += fy
        pz += fz
        lx += ry * fz - rz * fy
        ly += rz * fx - rx * fz
        lz += rx * fy - ry * fx
    diag.contact_count[0] += n_contacts
    return px, py, pz, lx, ly, lz


@njit(cache=True, inline='always', error_model='numpy')
def clear_inactive_contacts(rows, sol):
    """Forget the friction of bodies without a contact row this step."""
    n = sol.contact_pn.shape[0]
    for i in range(n):
        if sol.contact_pn[i] == 0.0:
            sol.contact_pt[i, 0] = 0.0
            sol.contact_pt[i, 1] = 0.0
            sol.contact_pt[i, 2] = 0.0


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
                         prm.tgt_inv_mass)
        ev[E_STEP] += 1
        closing_events(wk, bodies, links, ring, tether, target, prm, ev, trigger_mass)
    store_work(wk, bodies)
    return 0
