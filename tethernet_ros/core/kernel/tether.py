"""The main tether: paid out freely by the winch while the net flies (its lumped masses
kinematic on the straight line from the winch to the net's centre, without tension), then
locked when closing starts (segments get their current lengths as rest lengths and the
masses join the dynamics)."""
from __future__ import annotations

import numpy as np
from numba import njit

from .data import CONTACT_ONCE_OUTSIDE
from .model import DAMPING_ELEMENT, TETHER_REVERSED


@njit(cache=True, inline='always', error_model='numpy')
def pay_out_tether(model, data, l):
    """Lane l: place the tether's masses on the straight line winch -> net centre, evenly,
    with the matching interpolated velocities: node k the (k+1)-th from the winch
    (``TETHER_REVERSED``, against the chain's order) or from the centre (``TETHER_CHAIN``)."""
    x = data.bodies.x
    v = data.bodies.v
    te = model.tether
    wb = te.winch
    cn = te.centre
    n_tether = te.nodes.shape[0]
    for k in range(n_tether):
        f = ((k + 1.0) if te.order == TETHER_REVERSED else (n_tether - k + 0.0)) / (n_tether + 1.0)
        t = te.nodes[k]
        for c in range(3):
            x[t, c, l] = x[wb, c, l] + f * (x[cn, c, l] - x[wb, c, l])
        for c in range(3):
            v[t, c, l] = v[wb, c, l] + f * (v[cn, c, l] - v[wb, c, l])


@njit(cache=True, inline='always', error_model='numpy')
def lock_tether(model, data, l):
    """Lane l: the winch locks the paid-out length: the tether segments get their rest
    lengths (the current ones), stiffness E A / l and damping, and the tether's lumped
    masses (one segment of tether each) join the dynamics; each collides with the target
    once it is outside it (``CONTACT_ONCE_OUTSIDE``)."""
    x = data.bodies.x
    bd = data.bodies
    ln = data.links
    te = model.tether
    prm = model.params
    pairs = model.links.pairs
    mass = bd.mass
    for k in range(te.links.shape[0]):
        m = te.links[k]
        a = pairs[m, 0]
        b = pairs[m, 1]
        dx = x[b, 0, l] - x[a, 0, l]
        dy = x[b, 1, l] - x[a, 1, l]
        dz = x[b, 2, l] - x[a, 2, l]
        ln.rest[m, l] = max(np.sqrt(dx * dx + dy * dy + dz * dz), 1e-6)
        ln.active[m, l] = 1
    for k in range(te.nodes.shape[0]):
        t = te.nodes[k]
        mass[t, l] = prm.tether_lin_density * ln.rest[te.links[0], l]
        bd.w[t, l] = 1.0 / mass[t, l]
        bd.contact_mask[t, l] = CONTACT_ONCE_OUTSIDE
        bd.c_contact[t, l] = 2.0 * prm.zeta_contact * np.sqrt(model.bodies.k_contact[t] * mass[t, l])
    for k in range(te.links.shape[0]):
        m = te.links[k]
        a = pairs[m, 0]
        b = pairs[m, 1]
        kk = prm.tether_EA / ln.rest[m, l]
        ln.k[m, l] = kk
        if prm.thread_damping == DAMPING_ELEMENT:
            meff = (mass[a, l] * mass[b, l]) / (mass[a, l] + mass[b, l])
            ln.c[m, l] = 2.0 * prm.zeta_thread * np.sqrt(kk * meff)
        else:
            ln.c[m, l] = 2.0 * prm.zeta_thread * kk / prm.omega_1
