"""The explicit method's stable step."""
from __future__ import annotations

import numpy as np


def stable_step(pairs, k, active, w, n_bodies):
    """Upper bound of the highest natural frequency omega_max (rad/s) of the active
    threads (Gershgorin bound of M^-1 K: omega_max^2 <= max_i sum_l k_l (w_i +
    sqrt(w_i w_j))), and the stable step 2 / omega_max (s) of symplectic Euler.

    pairs (T, 2) bodies of each thread, k (T,) stiffness (N/m), active (T,) flags,
    w (N,) inverse masses (1/kg)."""
    lam = np.zeros(n_bodies)
    act = active == 1
    a, b, kk = pairs[act, 0], pairs[act, 1], k[act]
    cross = np.sqrt(w[a] * w[b])
    np.add.at(lam, a, kk * (w[a] + cross))
    np.add.at(lam, b, kk * (w[b] + cross))
    omega = float(np.sqrt(lam.max()))
    return omega, 2.0 / omega
