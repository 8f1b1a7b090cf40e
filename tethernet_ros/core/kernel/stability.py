"""The explicit method's stable step."""
from __future__ import annotations

import numpy as np


def gershgorin_rate(pairs, coeff, active, w, n_bodies) -> np.ndarray:
    """Per-body Gershgorin bound of M^-1 A for the thread matrix A of coefficients
    ``coeff`` (stiffness N/m or damping N s/m): sum_l coeff_l (w_i + sqrt(w_i w_j))."""
    lam = np.zeros(n_bodies)
    act = active == 1
    a, b, cc = pairs[act, 0], pairs[act, 1], coeff[act]
    cross = np.sqrt(w[a] * w[b])
    np.add.at(lam, a, cc * (w[a] + cross))
    np.add.at(lam, b, cc * (w[b] + cross))
    return lam


def stable_step(pairs, k, active, w, n_bodies, c=None, k_contact=None, c_contact=None):
    """Highest natural frequency omega_max (rad/s) of the active threads (Gershgorin bound of
    M^-1 K) and the stable step (s) of symplectic Euler.

    The step is the smallest of three limits: the stiffness one 2 / omega_max; the damping
    one 2 / gamma_max (gamma_max bounds M^-1 C, C the thread damping ``c``); and that of
    each body's contact spring-damper with the target (k_contact (N/m), c_contact (N s/m)),
    2 / sqrt(k w) and 2 / (c w).  Each limit holds for its term alone; together they allow
    a step down to 0.62 of their minimum (a mode of damping ratio 0.5: h omega < 2
    (sqrt(1 + zeta^2) - zeta)), which the configuration's safety fraction (0.5) covers.

    pairs (T, 2) bodies of each thread, k (T,) stiffness (N/m), active (T,) flags,
    w (N,) inverse masses (1/kg); c (T,) damping (N s/m)."""
    omega = float(np.sqrt(gershgorin_rate(pairs, k, active, w, n_bodies).max()))
    steps = [2.0 / omega]
    if c is not None:
        gamma = float(gershgorin_rate(pairs, c, active, w, n_bodies).max())
        if gamma > 0:
            steps.append(2.0 / gamma)
    if k_contact is not None:
        om_c = float(np.sqrt((k_contact * w).max()))
        if om_c > 0:
            steps.append(2.0 / om_c)
    if c_contact is not None:
        g_c = float((c_contact * w).max())
        if g_c > 0:
            steps.append(2.0 / g_c)
    return omega, min(steps)
