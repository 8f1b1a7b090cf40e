"""The target as a free rigid body, one step of dt (s): a kick of the contact force and
torque, then a drift (translation at the new velocity; torque-free rotation by splitting).

The torque-free rotation is the symmetric splitting of the kinetic energy into its three
principal parts (Dullweber, Leimkuhler and McLachlan, J. Chem. Phys. 107, 5840, 1997):
rotations about the body axes x (dt/2), y (dt/2), z (dt), y (dt/2), x (dt/2), each by the
angle L_i dt_i / I_i of the current body angular momentum L.  Each sub-rotation turns the
attitude by Q and the body angular momentum by Q^T with the same orthogonal Q (a unit
quaternion built by the Cayley map, (1, phi/2 e_i) normalised: IEEE operations only, no
sin or cos), so the body angular momentum stays that of the unchanged world angular momentum, and the
energy oscillates within O(dt^2) without drift.  docs/model.md §1.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .geometry import quat_to_matrix_lane


@njit(cache=True, inline='always', error_model='numpy')
def sub_rotation(q, L, inertia, axis, dt, l):
    """Torque-free flow of L_axis^2 / (2 I_axis) over dt in lane l: q <- q (x) r and
    L <- Q(r)^T L, r the Cayley quaternion of the angle L_axis dt / I_axis about the body
    axis."""
    t = 0.5 * dt * L[axis, l] / inertia[axis, l]
    c = 1.0 / np.sqrt(1.0 + t * t)
    s = t * c
    cp = c * c - s * s   # cos and sin of the rotation angle
    sp = 2.0 * c * s
    q0, q1, q2, q3 = q[0, l], q[1, l], q[2, l], q[3, l]
    lx, ly, lz = L[0, l], L[1, l], L[2, l]
    if axis == 0:
        q[0, l] = q0 * c - s * q1
        q[1, l] = q0 * s + c * q1
        q[2, l] = c * q2 + s * q3
        q[3, l] = c * q3 - s * q2
        L[1, l] = cp * ly + sp * lz
        L[2, l] = cp * lz - sp * ly
    elif axis == 1:
        q[0, l] = q0 * c - s * q2
        q[1, l] = c * q1 - s * q3
        q[2, l] = q0 * s + c * q2
        q[3, l] = c * q3 + s * q1
        L[0, l] = cp * lx - sp * lz
        L[2, l] = cp * lz + sp * lx
    else:
        q[0, l] = q0 * c - s * q3
        q[1, l] = c * q1 + s * q2
        q[2, l] = c * q2 - s * q1
        q[3, l] = q0 * s + c * q3
        L[0, l] = cp * lx + sp * ly
        L[1, l] = cp * ly - sp * lx


@njit(cache=True, inline='always', error_model='numpy')
def integrate_target(model, data, scr, l, fx_t, fy_t, fz_t, tx_t, ty_t, tz_t, dt):
    """Advance lane l's target by dt under the force (N) and torque about its CoM (N m),
    both in the world frame.  scr.R[:, :, l] holds its rotation matrix at the start of the
    step, and the new one on return; scr.Lb is scratch.

    The state is the world angular momentum ``ang_mom``: the kick adds dt tau to it and the
    torque-free drift leaves it as it is (bit for bit), turning only the attitude;
    ``omega`` = R I^-1 R^T ang_mom follows from them."""
    tg = data.target
    vel = tg.vel
    Lw = tg.ang_mom
    R = scr.R
    L = scr.Lb
    inertia = tg.inertia
    inv_mass = tg.inv_mass[l]
    vel[0, l] += dt * inv_mass * fx_t
    vel[1, l] += dt * inv_mass * fy_t
    vel[2, l] += dt * inv_mass * fz_t
    Lw[0, l] += dt * tx_t
    Lw[1, l] += dt * ty_t
    Lw[2, l] += dt * tz_t
    for c in range(3):
        tg.pos[c, l] += dt * vel[c, l]
    q = tg.quat
    torque_free_drift(q, Lw, R, L, inertia, dt, l)
    angular_velocity_lane(R, inertia, Lw, L, tg.omega, l)


@njit(cache=True, inline='always', error_model='numpy')
def torque_free_drift(q, Lw, R, L, inertia, dt, l):
    """Lane l's attitude q[:, l] after dt (s) of torque-free rotation under its world
    angular momentum Lw[:, l] (kg m^2/s) and principal moments inertia[:, l] (the module's
    splitting); R[:, :, l] holds the rotation matrix at the start, and the new one on
    return; L scratch."""
    if Lw[0, l] != 0.0 or Lw[1, l] != 0.0 or Lw[2, l] != 0.0:
        for c in range(3):
            L[c, l] = R[0, c, l] * Lw[0, l] + R[1, c, l] * Lw[1, l] + R[2, c, l] * Lw[2, l]
        half = 0.5 * dt
        sub_rotation(q, L, inertia, 0, half, l)
        sub_rotation(q, L, inertia, 1, half, l)
        sub_rotation(q, L, inertia, 2, dt, l)
        sub_rotation(q, L, inertia, 1, half, l)
        sub_rotation(q, L, inertia, 0, half, l)
        qn = np.sqrt(q[0, l] * q[0, l] + q[1, l] * q[1, l] + q[2, l] * q[2, l] + q[3, l] * q[3, l])
        q[0, l] = q[0, l] / qn
        q[1, l] = q[1, l] / qn
        q[2, l] = q[2, l] / qn
        q[3, l] = q[3, l] / qn
    quat_to_matrix_lane(q, R, l)


@njit(cache=True, error_model='numpy')
def free_attitude(quat, ang_mom, inertia, dt, n_steps):
    """The attitude (w, x, y, z) of a free rigid body after ``n_steps`` steps of dt (s)
    from ``quat``, by the kernel's own torque-free drift: world angular momentum
    ``ang_mom`` (3,) (kg m^2/s), principal moments ``inertia`` (3,) (kg m^2)."""
    q = np.empty((4, 1))
    Lw = np.empty((3, 1))
    inert = np.empty((3, 1))
    for c in range(4):
        q[c, 0] = quat[c]
    for c in range(3):
        Lw[c, 0] = ang_mom[c]
        inert[c, 0] = inertia[c]
    R = np.empty((3, 3, 1))
    L = np.empty((3, 1))
    quat_to_matrix_lane(q, R, 0)
    for _ in range(n_steps):
        torque_free_drift(q, Lw, R, L, inert, dt, 0)
    return q[:, 0].copy()


@njit(cache=True, inline='always', error_model='numpy')
def angular_velocity_lane(R, inertia, Lw, L, omega, l):
    """omega[:, l] = R I^-1 R^T Lw of lane l (rad/s, world) from its attitude R[:, :, l],
    principal moments inertia[:, l] and world angular momentum Lw[:, l] (kg m^2/s); L
    scratch."""
    for c in range(3):
        L[c, l] = (R[0, c, l] * Lw[0, l] + R[1, c, l] * Lw[1, l] + R[2, c, l] * Lw[2, l]) \
            / inertia[c, l]
    for c in range(3):
        omega[c, l] = R[c, 0, l] * L[0, l] + R[c, 1, l] * L[1, l] + R[c, 2, l] * L[2, l]
