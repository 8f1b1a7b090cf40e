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

from .geometry import local_sdf
from .state import CONTACT_FREQUENCY, CONTACT_ON, CONTACT_ONCE_OUTSIDE


@njit(cache=True, inline='always', error_model='numpy')
def contact_forces(wk, bodies, target, prm, diag):
    """Add the contact forces to wk.FX..; return the force (fx, fy, fz) and torque about
    its CoM (tx, ty, tz) on the target, in the world frame.  wk.R must hold the target's
    rotation matrix."""
    X, Y, Z, VX, VY, VZ = wk.X, wk.Y, wk.Z, wk.VX, wk.VY, wk.VZ
    R = wk.R
    mass = bodies.mass
    radius = bodies.radius
    tgt_pos = target.pos
    tgt_vel = target.vel
    ox, oy, oz = target.omega[0], target.omega[1], target.omega[2]
    dt = prm.dt
    mu = prm.mu
    om_c = prm.omega_contact
    k_c_unit = om_c * om_c                      # contact stiffness per kg
    c_c_unit = 2.0 * prm.zeta_contact * om_c    # contact damping per kg
    bound = prm.tgt_bound
    n_contacts = 0
    fx_t = 0.0
    fy_t = 0.0
    fz_t = 0.0
    tx_t = 0.0
    ty_t = 0.0
    tz_t = 0.0
    for i in range(X.shape[0]):
        if bodies.contact_mask[i] == 0 or bodies.w[i] == 0.0:
            continue
        rx = X[i] - tgt_pos[0]
        ry = Y[i] - tgt_pos[1]
        rz = Z[i] - tgt_pos[2]
        rb = bound + radius[i]
        if rx * rx + ry * ry + rz * rz > rb * rb:
            if bodies.contact_mask[i] == CONTACT_ONCE_OUTSIDE:
                bodies.contact_mask[i] = CONTACT_ON
            continue
        bx = R[0, 0] * rx + R[1, 0] * ry + R[2, 0] * rz
        by = R[0, 1] * rx + R[1, 1] * ry + R[2, 1] * rz
        bz = R[0, 2] * rx + R[1, 2] * ry + R[2, 2] * rz
        sd, nbx, nby, nbz = local_sdf(bx, by, bz, target.cyl, target.verts, target.offsets)
        delta = radius[i] - sd
        if bodies.contact_mask[i] == CONTACT_ONCE_OUTSIDE:
            if delta > 0.0:
                continue
            bodies.contact_mask[i] = CONTACT_ON
        if delta <= 0.0:
            continue
        if delta > diag.max_penetration[0]:
            diag.max_penetration[0] = delta
        nx = R[0, 0] * nbx + R[0, 1] * nby + R[0, 2] * nbz
        ny = R[1, 0] * nbx + R[1, 1] * nby + R[1, 2] * nbz
        nz = R[2, 0] * nbx + R[2, 1] * nby + R[2, 2] * nbz
        # velocity relative to the target's material point at the body
        vrx = VX[i] - (tgt_vel[0] + oy * rz - oz * ry)
        vry = VY[i] - (tgt_vel[1] + oz * rx - ox * rz)
        vrz = VZ[i] - (tgt_vel[2] + ox * ry - oy * rx)
        vn = vrx * nx + vry * ny + vrz * nz
        if prm.contact_model == CONTACT_FREQUENCY:
            Fn = mass[i] * (k_c_unit * delta - c_c_unit * vn)
        else:
            Fn = bodies.k_contact[i] * delta - bodies.c_contact[i] * vn
        if Fn <= 0.0:  # a contact never pulls
            continue
        n_contacts += 1
        fx = Fn * nx
        fy = Fn * ny
        fz = Fn * nz
        tvx = vrx - vn * nx
        tvy = vry - vn * ny
        tvz = vrz - vn * nz
        vt = np.sqrt(tvx * tvx + tvy * tvy + tvz * tvz)
        if vt > 1e-12 and mu > 0.0:
            stop = mass[i] * vt / dt
            Ft = stop if stop < prm.mu_static * Fn else mu * Fn
            fx -= Ft * tvx / vt
            fy -= Ft * tvy / vt
            fz -= Ft * tvz / vt
        wk.FX[i] += fx
        wk.FY[i] += fy
        wk.FZ[i] += fz
        # equal and opposite on the target, acting at the body's centre
        fx_t -= fx
        fy_t -= fy
        fz_t -= fz
        tx_t -= ry * fz - rz * fy
        ty_t -= rz * fx - rx * fz
        tz_t -= rx * fy - ry * fx
    diag.contact_count[0] += n_contacts
    return fx_t, fy_t, fz_t, tx_t, ty_t, tz_t
