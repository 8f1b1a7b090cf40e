"""Contact of the lumped bodies (spheres) with the target.

Normal: Kelvin-Voigt penalty that never pulls, F_n = k_i delta - c_i v_n > 0.  Contact
model "frequency": k_i = m_i omega_c^2, c_i = 2 zeta_c m_i omega_c per body (a contact
natural frequency: an impact at v sinks about v / omega_c whatever the body's mass);
"hertz": the body's own k_i, c_i (Bodies.k_contact, c_contact, set at build from its
sphere's radius and materials).  Friction: regularised Coulomb against the tangential
slip: the force that stops the slip within the step, m |v_t| / dt, while it is at most
mu_static F_n (sticking), else mu F_n (sliding).  Equal and opposite forces, and their
torques, act on the target.  Forces in N, torques in N m.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .broadphase import BROAD_OFF, BROAD_ON, proven_clear, remember
from .geometry import lane_sdf
from .data import CONTACT_ON, CONTACT_ONCE_OUTSIDE
from .model import CONTACT_FREQUENCY


@njit(cache=True, inline='always', error_model='numpy')
def contact_forces(model, data, scr, l):
    """Add lane l's contact forces to scr.F; return the force (fx, fy, fz) and torque about
    its CoM (tx, ty, tz) on the target, in the world frame.  scr.R[:, :, l] must hold the
    target's rotation matrix.  Bodies that the broad phase proves apart from the target
    are not tested (``broadphase``)."""
    b_ = data.bodies
    x = b_.x
    v = b_.v
    F = scr.F
    R = scr.R
    mass = b_.mass
    radius = model.bodies.radius
    tg = data.target
    prm = model.params
    ox, oy, oz = tg.omega[0, l], tg.omega[1, l], tg.omega[2, l]
    tpx, tpy, tpz = tg.pos[0, l], tg.pos[1, l], tg.pos[2, l]
    tvx, tvy, tvz = tg.vel[0, l], tg.vel[1, l], tg.vel[2, l]
    dt = prm.dt
    mu = prm.mu
    om_c = prm.omega_contact
    k_c_unit = om_c * om_c                      # contact stiffness per kg
    c_c_unit = 2.0 * prm.zeta_contact * om_c    # contact damping per kg
    bound = tg.bound[l]
    bp = data.broad
    mode = model.broadphase
    n_contacts = 0
    fx_t = 0.0
    fy_t = 0.0
    fz_t = 0.0
    tx_t = 0.0
    ty_t = 0.0
    tz_t = 0.0
    for i in range(x.shape[0]):
        if b_.contact_mask[i, l] == 0 or b_.w[i, l] == 0.0:
            continue
        rx = x[i, 0, l] - tpx
        ry = x[i, 1, l] - tpy
        rz = x[i, 2, l] - tpz
        rb = bound + radius[i]
        if rx * rx + ry * ry + rz * rz > rb * rb:
            if b_.contact_mask[i, l] == CONTACT_ONCE_OUTSIDE:
                b_.contact_mask[i, l] = CONTACT_ON
            continue
        bx = R[0, 0, l] * rx + R[1, 0, l] * ry + R[2, 0, l] * rz
        by = R[0, 1, l] * rx + R[1, 1, l] * ry + R[2, 1, l] * rz
        bz = R[0, 2, l] * rx + R[1, 2, l] * ry + R[2, 2, l] * rz
        # broad phase: a body provably apart from the surface feels no force (module
        # broadphase); the exact test below would only have switched its mask on
        proven = mode != BROAD_OFF and proven_clear(bp, i, l, bx, by, bz, radius[i])
        if proven and mode == BROAD_ON:
            bp.skips[l] += 1
            if b_.contact_mask[i, l] == CONTACT_ONCE_OUTSIDE:
                b_.contact_mask[i, l] = CONTACT_ON
            continue
        sd, nbx, nby, nbz = lane_sdf(bx, by, bz, tg, l, model.target.geometry)
        bp.tests[l] += 1
        delta = radius[i] - sd
        if proven:                                 # mode check: was it apart after all?
            bp.skips[l] += 1
            if delta > 0.0:
                bp.misses[l] += 1
        elif mode != BROAD_OFF:
            remember(bp, i, l, bx, by, bz, sd)
        if b_.contact_mask[i, l] == CONTACT_ONCE_OUTSIDE:
            if delta > 0.0:
                continue
            b_.contact_mask[i, l] = CONTACT_ON
        if delta <= 0.0:
            continue
        if delta > data.max_penetration[l]:
            data.max_penetration[l] = delta
        nx = R[0, 0, l] * nbx + R[0, 1, l] * nby + R[0, 2, l] * nbz
        ny = R[1, 0, l] * nbx + R[1, 1, l] * nby + R[1, 2, l] * nbz
        nz = R[2, 0, l] * nbx + R[2, 1, l] * nby + R[2, 2, l] * nbz
        # velocity relative to the target's material point at the body
        vrx = v[i, 0, l] - (tvx + oy * rz - oz * ry)
        vry = v[i, 1, l] - (tvy + oz * rx - ox * rz)
        vrz = v[i, 2, l] - (tvz + ox * ry - oy * rx)
        vn = vrx * nx + vry * ny + vrz * nz
        if prm.contact_model == CONTACT_FREQUENCY:
            Fn = mass[i, l] * (k_c_unit * delta - c_c_unit * vn)
        else:
            Fn = model.bodies.k_contact[i] * delta - b_.c_contact[i, l] * vn
        if Fn <= 0.0:  # a contact never pulls
            continue
        n_contacts += 1
        fx = Fn * nx
        fy = Fn * ny
        fz = Fn * nz
        ttx = vrx - vn * nx
        tty = vry - vn * ny
        ttz = vrz - vn * nz
        vt = np.sqrt(ttx * ttx + tty * tty + ttz * ttz)
        if vt > 1e-12 and mu > 0.0:
            stop = mass[i, l] * vt / dt
            Ft = stop if stop < prm.mu_static * Fn else mu * Fn
            fx -= Ft * ttx / vt
            fy -= Ft * tty / vt
            fz -= Ft * ttz / vt
        F[i, 0, l] += fx
        F[i, 1, l] += fy
        F[i, 2, l] += fz
        # equal and opposite on the target, acting at the body's centre
        fx_t -= fx
        fy_t -= fy
        fz_t -= fz
        tx_t -= ry * fz - rz * fy
        ty_t -= rz * fx - rx * fz
        tz_t -= rx * fy - ry * fx
    data.contact_count[l] += n_contacts
    return fx_t, fy_t, fz_t, tx_t, ty_t, tz_t
