"""Contact rows of the implicit method (``implicit``): a pushing-only compliant row per
body touching the target (or close enough to touch it within the step), Coulomb friction
in its tangent plane, and the contacts' total impulse and moment on the target.
Units: SI (m, s, kg, N s).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .geometry import local_sdf
from .state import CONTACT_FREQUENCY, CONTACT_ON, CONTACT_ONCE_OUTSIDE

#: Contact rows are made for bodies within h |v_rel| + SPECULATIVE_MARGIN (m) of the target:
#: the threads and the drawstring can whip a light node to more than 20 m/s within a step,
#: faster than its velocity at the step's start announces.
SPECULATIVE_MARGIN = 0.05


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
            if bodies.contact_mask[i] == CONTACT_ONCE_OUTSIDE:
                bodies.contact_mask[i] = CONTACT_ON
            continue
        bx = R[0, 0] * rx + R[1, 0] * ry + R[2, 0] * rz
        by = R[0, 1] * rx + R[1, 1] * ry + R[2, 1] * rz
        bz = R[0, 2] * rx + R[1, 2] * ry + R[2, 2] * rz
        sd, nbx, nby, nbz = local_sdf(bx, by, bz, target.cyl, target.verts, target.offsets)
        C = sd - bodies.radius[i]                  # gap (m), negative: penetration
        if bodies.contact_mask[i] == CONTACT_ONCE_OUTSIDE:
            if C < 0.0:
                sol.contact_pn[i] = 0.0
                continue
            bodies.contact_mask[i] = CONTACT_ON
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
