"""The main tether: paid out freely by the winch while the net flies (its lumped masses
kinematic on the straight line from the winch to the net's centre, without tension), then
locked when closing starts (segments get their current lengths as rest lengths and the
masses join the dynamics)."""
from __future__ import annotations

import numpy as np
from numba import njit

from .state import CONTACT_ONCE_OUTSIDE, DAMPING_ELEMENT


@njit(cache=True, inline='always', error_model='numpy')
def pay_out_tether(wk, tether):
    """Place the tether's masses on the straight line winch -> net centre, evenly, with
    the matching interpolated velocities."""
    X, Y, Z, VX, VY, VZ = wk.X, wk.Y, wk.Z, wk.VX, wk.VY, wk.VZ
    wb = tether.winch
    cn = tether.centre
    n_tether = tether.nodes.shape[0]
    for k in range(n_tether):
        f = (k + 1.0) / (n_tether + 1.0)
        t = tether.nodes[k]
        X[t] = X[wb] + f * (X[cn] - X[wb])
        Y[t] = Y[wb] + f * (Y[cn] - Y[wb])
        Z[t] = Z[wb] + f * (Z[cn] - Z[wb])
        VX[t] = VX[wb] + f * (VX[cn] - VX[wb])
        VY[t] = VY[wb] + f * (VY[cn] - VY[wb])
        VZ[t] = VZ[wb] + f * (VZ[cn] - VZ[wb])


@njit(cache=True, inline='always', error_model='numpy')
def lock_tether(wk, bodies, links, tether, prm):
    """The winch locks the paid-out length: the tether segments get their rest lengths
    (the current ones), stiffness E A / l and damping, and the tether's lumped masses
    (one segment of tether each) join the dynamics; each collides with the target once it
    is outside it (``CONTACT_ONCE_OUTSIDE``)."""
    X, Y, Z = wk.X, wk.Y, wk.Z
    mass = bodies.mass
    for k in range(tether.links.shape[0]):
        m = tether.links[k]
        a = links.pairs[m, 0]
        b = links.pairs[m, 1]
        dx = X[b] - X[a]
        dy = Y[b] - Y[a]
        dz = Z[b] - Z[a]
        links.rest[m] = max(np.sqrt(dx * dx + dy * dy + dz * dz), 1e-6)
        links.active[m] = 1
    for k in range(tether.nodes.shape[0]):
        t = tether.nodes[k]
        mass[t] = prm.tether_lin_density * links.rest[tether.links[0]]
        bodies.w[t] = 1.0 / mass[t]
        bodies.contact_mask[t] = CONTACT_ONCE_OUTSIDE
        bodies.c_contact[t] = 2.0 * prm.zeta_contact * np.sqrt(bodies.k_contact[t] * mass[t])
    for k in range(tether.links.shape[0]):
        m = tether.links[k]
        a = links.pairs[m, 0]
        b = links.pairs[m, 1]
        kk = prm.tether_EA / links.rest[m]
        links.k[m] = kk
        if prm.thread_damping == DAMPING_ELEMENT:
            meff = (mass[a] * mass[b]) / (mass[a] + mass[b])
            links.c[m] = 2.0 * prm.zeta_thread * np.sqrt(kk * meff)
        else:
            links.c[m] = 2.0 * prm.zeta_thread * kk / prm.omega_1
