"""The target as a free rigid body: translation, Euler's equations in the body frame and
the quaternion, one symplectic-Euler step of dt (s)."""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline='always', error_model='numpy')
def integrate_target(target, R, fx_t, fy_t, fz_t, tx_t, ty_t, tz_t, dt, inv_mass):
    """Advance the target by dt under the force (N) and torque about its CoM (N m), both in
    the world frame.  R: its rotation matrix at the start of the step."""
    tgt_vel = target.vel
    tgt_omega = target.omega
    tgt_inertia = target.inertia
    inv_i0 = 1.0 / tgt_inertia[0]
    inv_i1 = 1.0 / tgt_inertia[1]
    inv_i2 = 1.0 / tgt_inertia[2]
    ox, oy, oz = tgt_omega[0], tgt_omega[1], tgt_omega[2]
    tgt_vel[0] += dt * inv_mass * fx_t
    tgt_vel[1] += dt * inv_mass * fy_t
    tgt_vel[2] += dt * inv_mass * fz_t
    # Euler's equations in the body frame: I dw/dt = tau - w x I w
    tbx = R[0, 0] * tx_t + R[1, 0] * ty_t + R[2, 0] * tz_t
    tby = R[0, 1] * tx_t + R[1, 1] * ty_t + R[2, 1] * tz_t
    tbz = R[0, 2] * tx_t + R[1, 2] * ty_t + R[2, 2] * tz_t
    wbx = R[0, 0] * ox + R[1, 0] * oy + R[2, 0] * oz
    wby = R[0, 1] * ox + R[1, 1] * oy + R[2, 1] * oz
    wbz = R[0, 2] * ox + R[1, 2] * oy + R[2, 2] * oz
    nwx = wbx + dt * inv_i0 * (tbx + (tgt_inertia[1] - tgt_inertia[2]) * wby * wbz)
    nwy = wby + dt * inv_i1 * (tby + (tgt_inertia[2] - tgt_inertia[0]) * wbz * wbx)
    nwz = wbz + dt * inv_i2 * (tbz + (tgt_inertia[0] - tgt_inertia[1]) * wbx * wby)
    ox = R[0, 0] * nwx + R[0, 1] * nwy + R[0, 2] * nwz
    oy = R[1, 0] * nwx + R[1, 1] * nwy + R[1, 2] * nwz
    oz = R[2, 0] * nwx + R[2, 1] * nwy + R[2, 2] * nwz
    tgt_omega[0] = ox
    tgt_omega[1] = oy
    tgt_omega[2] = oz
    for c in range(3):
        target.pos[c] += dt * tgt_vel[c]
    q = target.quat
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    h = 0.5 * dt
    n0 = q0 + h * (-ox * q1 - oy * q2 - oz * q3)
    n1 = q1 + h * (ox * q0 + oy * q3 - oz * q2)
    n2 = q2 + h * (-ox * q3 + oy * q0 + oz * q1)
    n3 = q3 + h * (ox * q2 - oy * q1 + oz * q0)
    qn = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3)
    q[0] = n0 / qn
    q[1] = n1 / qn
    q[2] = n2 / qn
    q[3] = n3 / qn
