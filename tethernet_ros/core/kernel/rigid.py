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

from .geometry import quat_to_matrix_into


@njit(cache=True, inline='always', error_model='numpy')
def _sub_rotation(q, L, inertia, axis, dt):
    """Torque-free flow of L_axis^2 / (2 I_axis) over dt: q <- q (x) r and L <- Q(r)^T L,
    r the Cayley quaternion of the angle L_axis dt / I_axis about the body axis."""
    t = 0.5 * dt * L[axis] / inertia[axis]
    c = 1.0 / np.sqrt(1.0 + t * t)
    s = t * c
    cp = c * c - s * s   # cos and sin of the rotation angle
    sp = 2.0 * c * s
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    lx, ly, lz = L[0], L[1], L[2]
    if axis == 0:
        q[0] = q0 * c - s * q1
        q[1] = q0 * s + c * q1
        q[2] = c * q2 + s * q3
        q[3] = c * q3 - s * q2
        L[1] = cp * ly + sp * lz
        L[2] = cp * lz - sp * ly
    elif axis == 1:
        q[0] = q0 * c - s * q2
        q[1] = c * q1 - s * q3
        q[2] = q0 * s + c * q2
        q[3] = c * q3 + s * q1
        L[0] = cp * lx - sp * lz
        L[2] = cp * lz + sp * lx
    else:
        q[0] = q0 * c - s * q3
        q[1] = c * q1 + s * q2
        q[2] = c * q2 - s * q1
        q[3] = q0 * s + c * q3
        L[0] = cp * lx + sp * ly
        L[1] = cp * ly - sp * lx


@njit(cache=True, inline='always', error_model='numpy')
def integrate_target(target, R, fx_t, fy_t, fz_t, tx_t, ty_t, tz_t, dt, inv_mass, L):
    """Advance the target by dt under the force (N) and torque about its CoM (N m), both in
    the world frame.  R: its rotation matrix at the start of the step (holds the new one on
    return); L (3,): scratch for the body angular momentum (kg m^2/s).

    The state is the world angular momentum ``ang_mom``: the kick adds dt tau to it and the
    torque-free drift leaves it as it is (bit for bit), turning only the attitude;
    ``omega`` = R I^-1 R^T ang_mom follows from them."""
    tgt_vel = target.vel
    Lw = target.ang_mom
    inertia = target.inertia
    tgt_vel[0] += dt * inv_mass * fx_t
    tgt_vel[1] += dt * inv_mass * fy_t
    tgt_vel[2] += dt * inv_mass * fz_t
    Lw[0] += dt * tx_t
    Lw[1] += dt * ty_t
    Lw[2] += dt * tz_t
    for c in range(3):
        target.pos[c] += dt * tgt_vel[c]
    q = target.quat
    if Lw[0] != 0.0 or Lw[1] != 0.0 or Lw[2] != 0.0:
        for c in range(3):
            L[c] = R[0, c] * Lw[0] + R[1, c] * Lw[1] + R[2, c] * Lw[2]
        half = 0.5 * dt
        _sub_rotation(q, L, inertia, 0, half)
        _sub_rotation(q, L, inertia, 1, half)
        _sub_rotation(q, L, inertia, 2, dt)
        _sub_rotation(q, L, inertia, 1, half)
        _sub_rotation(q, L, inertia, 0, half)
        qn = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        q[0] = q[0] / qn
        q[1] = q[1] / qn
        q[2] = q[2] / qn
        q[3] = q[3] / qn
    quat_to_matrix_into(q, R)
    angular_velocity_into(R, inertia, Lw, L, target.omega)


@njit(cache=True, inline='always', error_model='numpy')
def angular_velocity_into(R, inertia, Lw, L, omega):
    """omega = R I^-1 R^T Lw (rad/s, world) of the attitude R and world angular momentum
    Lw (kg m^2/s); L (3,) scratch."""
    for c in range(3):
        L[c] = (R[0, c] * Lw[0] + R[1, c] * Lw[1] + R[2, c] * Lw[2]) / inertia[c]
    for c in range(3):
        omega[c] = R[c, 0] * L[0] + R[c, 1] * L[1] + R[c, 2] * L[2]
