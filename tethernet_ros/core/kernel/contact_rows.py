"""Contact rows of the implicit method (``implicit``): a pushing-only compliant row per
body touching the target (or close enough to touch it within the step), Coulomb friction
in its tangent plane, and the contacts' total impulse and moment on the target.
Units: SI (m, s, kg, N s).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .broadphase import BROAD_OFF, BROAD_ON, proven_clear, remember
from .geometry import lane_sdf
from .data import CONTACT_ON, CONTACT_ONCE_OUTSIDE
from .model import CONTACT_FREQUENCY

#: Contact rows are made for bodies within h |v_rel| + SPECULATIVE_MARGIN (m) of the target:
#: the threads and the drawstring can whip a light node to more than 20 m/s within a step,
#: faster than its velocity at the step's start announces.
SPECULATIVE_MARGIN = 0.05


@njit(cache=True, inline='always', error_model='numpy')
def prepare_contact_rows(model, data, scr, l):
    """Lane l: a contact row for every body touching the target or close enough to touch
    it within the step (speculative); warm-start impulses applied.  scr.R[:, :, l] must
    hold the target's rotation matrix.  Bodies that the broad phase proves farther from
    the target than a row's reach are not tested (``broadphase``)."""
    b_ = data.bodies
    x = b_.x
    v = b_.v
    R = scr.R
    cr = scr.contacts
    ws = data.warm
    prm = model.params
    h = prm.dt
    w = b_.w
    tg = data.target
    tpx, tpy, tpz = tg.pos[0, l], tg.pos[1, l], tg.pos[2, l]
    tvx, tvy, tvz = tg.vel[0, l], tg.vel[1, l], tg.vel[2, l]
    ox, oy, oz = tg.omega[0, l], tg.omega[1, l], tg.omega[2, l]
    radius = model.bodies.radius
    bp = data.broad
    mode = model.broadphase
    n_rows = 0
    for i in range(x.shape[0]):
        if b_.contact_mask[i, l] == 0 or w[i, l] == 0.0:
            ws.contact_pn[i, l] = 0.0
            continue
        rx = x[i, 0, l] - tpx
        ry = x[i, 1, l] - tpy
        rz = x[i, 2, l] - tpz
        # material velocity of the target at the body and the body's speed relative to it
        cvx = tvx + oy * rz - oz * ry
        cvy = tvy + oz * rx - ox * rz
        cvz = tvz + ox * ry - oy * rx
        vrel = np.sqrt((v[i, 0, l] - cvx) ** 2 + (v[i, 1, l] - cvy) ** 2 + (v[i, 2, l] - cvz) ** 2)
        reach = radius[i] + h * vrel + SPECULATIVE_MARGIN
        rb = tg.bound[l] + reach
        if rx * rx + ry * ry + rz * rz > rb * rb:
            ws.contact_pn[i, l] = 0.0
            if b_.contact_mask[i, l] == CONTACT_ONCE_OUTSIDE:
                b_.contact_mask[i, l] = CONTACT_ON
            continue
        bx = R[0, 0, l] * rx + R[1, 0, l] * ry + R[2, 0, l] * rz
        by = R[0, 1, l] * rx + R[1, 1, l] * ry + R[2, 1, l] * rz
        bz = R[0, 2, l] * rx + R[1, 2, l] * ry + R[2, 2, l] * rz
        # broad phase: a gap provably beyond the row's reach makes no row and changes
        # nothing but what the exact test below would (module broadphase)
        proven = mode != BROAD_OFF and proven_clear(bp, i, l, bx, by, bz,
                                                    radius[i] + h * vrel + SPECULATIVE_MARGIN)
        if proven and mode == BROAD_ON:
            bp.skips[l] += 1
            ws.contact_pn[i, l] = 0.0
            if b_.contact_mask[i, l] == CONTACT_ONCE_OUTSIDE:
                b_.contact_mask[i, l] = CONTACT_ON
            continue
        sd, nbx, nby, nbz = lane_sdf(bx, by, bz, tg, l, model.target.geometry)
        bp.tests[l] += 1
        C = sd - radius[i]                         # gap (m), negative: penetration
        if proven:                                 # mode check: would it have been clear?
            bp.skips[l] += 1
            if not (C >= 0.0 and C > h * vrel + SPECULATIVE_MARGIN):
                bp.misses[l] += 1
        elif mode != BROAD_OFF:
            remember(bp, i, l, bx, by, bz, sd)
        if b_.contact_mask[i, l] == CONTACT_ONCE_OUTSIDE:
            if C < 0.0:
                ws.contact_pn[i, l] = 0.0
                continue
            b_.contact_mask[i, l] = CONTACT_ON
        if C > h * vrel + SPECULATIVE_MARGIN:
            ws.contact_pn[i, l] = 0.0
            continue
        if -C > data.max_penetration[l]:
            data.max_penetration[l] = -C
        nx = R[0, 0, l] * nbx + R[0, 1, l] * nby + R[0, 2, l] * nbz
        ny = R[1, 0, l] * nbx + R[1, 1, l] * nby + R[1, 2, l] * nbz
        nz = R[2, 0, l] * nbx + R[2, 1, l] * nby + R[2, 2, l] * nbz
        if prm.contact_model == CONTACT_FREQUENCY:
            om = prm.omega_contact
            k = b_.mass[i, l] * om * om
            c = 2.0 * prm.zeta_contact * b_.mass[i, l] * om
        else:
            k = model.bodies.k_contact[i]
            c = b_.c_contact[i, l]
        denom = h * k + c
        if C < 0.0 and denom > 0.0:
            b = k * C / denom
            g = 1.0 / (h * denom)
        else:
            b = C / h
            g = 0.0
        # a new impact (no contact impulse last step) rebounds with the contact law's
        # restitution: the normal velocity after the step is -e times the one before
        vn0 = (v[i, 0, l] - cvx) * nx + (v[i, 1, l] - cvy) * ny + (v[i, 2, l] - cvz) * nz
        if (prm.restitution > 0.0 and vn0 < 0.0 and ws.contact_pn[i, l] == 0.0
                and C < -h * vn0):
            b = prm.restitution * vn0
            g = 0.0
        cr.bodies[n_rows, l] = i
        n_rows += 1
        cr.normal[i, 0, l] = nx
        cr.normal[i, 1, l] = ny
        cr.normal[i, 2, l] = nz
        cr.vel[i, 0, l] = cvx
        cr.vel[i, 1, l] = cvy
        cr.vel[i, 2, l] = cvz
        cr.b[i, l] = b
        cr.g[i, l] = g
        cr.ik[i, l] = 1.0 / (w[i, l] + g)
        # warm start: last step's normal impulse, and its friction in this tangent plane
        pt = ws.contact_pt
        pn_dot = pt[i, 0, l] * nx + pt[i, 1, l] * ny + pt[i, 2, l] * nz
        pt[i, 0, l] -= pn_dot * nx
        pt[i, 1, l] -= pn_dot * ny
        pt[i, 2, l] -= pn_dot * nz
        pn = ws.contact_pn[i, l]
        v[i, 0, l] += w[i, l] * (pn * nx + pt[i, 0, l])
        v[i, 1, l] += w[i, l] * (pn * ny + pt[i, 1, l])
        v[i, 2, l] += w[i, l] * (pn * nz + pt[i, 2, l])
    cr.count[l] = n_rows


@njit(cache=True, inline='always', error_model='numpy')
def sweep_contacts(model, data, scr, l):
    """One Gauss-Seidel sweep over lane l's contact rows: the normal impulse (pushing
    only), then the friction impulse that stops the slip, kept if within mu_static P_n,
    else mu P_n against the slip."""
    v = data.bodies.v
    w = data.bodies.w
    cr = scr.contacts
    ws = data.warm
    pt = ws.contact_pt
    prm = model.params
    for r in range(cr.count[l]):
        i = cr.bodies[r, l]
        nx = cr.normal[i, 0, l]
        ny = cr.normal[i, 1, l]
        nz = cr.normal[i, 2, l]
        ux = v[i, 0, l] - cr.vel[i, 0, l]
        uy = v[i, 1, l] - cr.vel[i, 1, l]
        uz = v[i, 2, l] - cr.vel[i, 2, l]
        vn = ux * nx + uy * ny + uz * nz
        P = ws.contact_pn[i, l]
        Pn = max(P - (vn + cr.b[i, l] + cr.g[i, l] * P) * cr.ik[i, l], 0.0)
        ws.contact_pn[i, l] = Pn
        dP = Pn - P
        wi = w[i, l]
        v[i, 0, l] += wi * dP * nx
        v[i, 1, l] += wi * dP * ny
        v[i, 2, l] += wi * dP * nz
        # friction
        if prm.mu <= 0.0 or Pn <= 0.0:
            v[i, 0, l] -= wi * pt[i, 0, l]
            v[i, 1, l] -= wi * pt[i, 1, l]
            v[i, 2, l] -= wi * pt[i, 2, l]
            pt[i, 0, l] = 0.0
            pt[i, 1, l] = 0.0
            pt[i, 2, l] = 0.0
            continue
        ux = v[i, 0, l] - cr.vel[i, 0, l]
        uy = v[i, 1, l] - cr.vel[i, 1, l]
        uz = v[i, 2, l] - cr.vel[i, 2, l]
        vn = ux * nx + uy * ny + uz * nz
        tx = ux - vn * nx
        ty = uy - vn * ny
        tz = uz - vn * nz
        qx = pt[i, 0, l] - tx / wi
        qy = pt[i, 1, l] - ty / wi
        qz = pt[i, 2, l] - tz / wi
        mag = np.sqrt(qx * qx + qy * qy + qz * qz)
        if mag > prm.mu_static * Pn:
            s = prm.mu * Pn / mag
            qx *= s
            qy *= s
            qz *= s
        v[i, 0, l] += wi * (qx - pt[i, 0, l])
        v[i, 1, l] += wi * (qy - pt[i, 1, l])
        v[i, 2, l] += wi * (qz - pt[i, 2, l])
        pt[i, 0, l] = qx
        pt[i, 1, l] = qy
        pt[i, 2, l] = qz


@njit(cache=True, inline='always', error_model='numpy')
def contact_reaction(data, scr, l):
    """Lane l: total impulse (N s) of the contacts on the target and its moment about the
    target's CoM (N m s), world frame: minus the impulses on the bodies, acting at their
    centres."""
    x = data.bodies.x
    cr = scr.contacts
    ws = data.warm
    tp = data.target.pos
    px = 0.0
    py = 0.0
    pz = 0.0
    lx = 0.0
    ly = 0.0
    lz = 0.0
    n_contacts = 0
    for r in range(cr.count[l]):
        i = cr.bodies[r, l]
        pn = ws.contact_pn[i, l]
        if pn > 0.0:
            n_contacts += 1
        fx = -(pn * cr.normal[i, 0, l] + ws.contact_pt[i, 0, l])
        fy = -(pn * cr.normal[i, 1, l] + ws.contact_pt[i, 1, l])
        fz = -(pn * cr.normal[i, 2, l] + ws.contact_pt[i, 2, l])
        rx = x[i, 0, l] - tp[0, l]
        ry = x[i, 1, l] - tp[1, l]
        rz = x[i, 2, l] - tp[2, l]
        px += fx
        py += fy
        pz += fz
        lx += ry * fz - rz * fy
        ly += rz * fx - rx * fz
        lz += rx * fy - ry * fx
    data.contact_count[l] += n_contacts
    return px, py, pz, lx, ly, lz


@njit(cache=True, inline='always', error_model='numpy')
def clear_inactive_contacts(data, l):
    """Lane l: forget the friction of bodies without a contact row this step."""
    ws = data.warm
    for i in range(ws.contact_pn.shape[0]):
        if ws.contact_pn[i, l] == 0.0:
            ws.contact_pt[i, 0, l] = 0.0
            ws.contact_pt[i, 1, l] = 0.0
            ws.contact_pt[i, 2, l] = 0.0
