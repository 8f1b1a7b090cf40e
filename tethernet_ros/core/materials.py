"""Build-time laws of the model's materials: thread damping, contact stiffness and the
sizes of the contact spheres.  Evaluated once per scenario, never inside the kernel.

Units: SI (m, kg, N/m, N s/m, Pa, rad/s).
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import eigh_tridiagonal


def element_damping(k, m_a, m_b, zeta):
    """Per-element Kelvin-Voigt damping c = 2 zeta sqrt(k m_eff) (N s/m), m_eff = m_a m_b /
    (m_a + m_b) computed so that it is the same to the last bit whichever end comes first
    (docs/model.md §2)."""
    m_eff = (m_a * m_b) / (m_a + m_b)
    return 2.0 * zeta * np.sqrt(k * m_eff)


def stiffness_damping(k, zeta, omega_1):
    """Stiffness-proportional damping c = 2 zeta k / omega_1 (N s/m): every mode of
    frequency omega gets the damping ratio zeta omega / omega_1, the net's first axial mode
    exactly zeta (the reference implementation, docs/model.md §10)."""
    return 2.0 * zeta * np.asarray(k, dtype=float) / omega_1


def first_axial_frequency(node_mass, k, min_omega: float = 10.0) -> float:
    """First axial natural frequency omega_1 (rad/s) of an n x n net.

    node_mass (n, n): lumped mass of node (i, j) (kg); k: stiffness of every grid thread
    (N/m).  As in the reference implementation, the axial model couples the x motion of
    the nodes of a row through its x-threads (and the y motion of a column through its
    y-threads, the same problem transposed): a free-free chain per row and column.  The
    rigid-body modes (omega = 0) are skipped: the result is the smallest frequency above
    ``min_omega``.
    """
    m = np.asarray(node_mass, dtype=float)
    best = math.inf
    for chains in (m, m.T):
        for row in chains:
            # M^-1/2 K M^-1/2 of the chain: tridiagonal and symmetric
            deg = np.full(len(row), 2.0 * k)
            deg[0] = deg[-1] = k
            diag = deg / row
            off = -k / np.sqrt(row[:-1] * row[1:])
            lam = eigh_tridiagonal(diag, off, eigvals_only=True)
            om = np.sqrt(np.clip(lam, 0.0, None))
            om = om[om > min_omega]
            if om.size:
                best = min(best, float(om.min()))
    return best


def effective_modulus(e1: float, nu1: float, e2: float, nu2: float) -> float:
    """Contact modulus E* = 1 / ((1 - nu1^2) / E1 + (1 - nu2^2) / E2) (Pa)."""
    return 1.0 / ((1.0 - nu1 * nu1) / e1 + (1.0 - nu2 * nu2) / e2)


def hertz_linear_stiffness(radius, e_star: float, penetration: float, divisor: float):
    """Linear contact stiffness (N/m) of a sphere of ``radius`` (m) on a large body, as the
    reference implementation sets it: the Hertz coefficient K = 4/3 E* sqrt(R) (F = K
    delta^1.5) times sqrt(2 penetration / 3), divided by ``divisor`` (10 there, for the
    mass lumped in the nodes)."""
    return (4.0 / 3.0) * e_star * np.sqrt(np.asarray(radius, dtype=float)) \
        * math.sqrt(2.0 * penetration / 3.0) / divisor


def sphere_radius(mass, density: float):
    """Radius (m) of a solid sphere of ``mass`` (kg) at ``density`` (kg/m^3)."""
    return np.cbrt(3.0 * np.asarray(mass, dtype=float) / (4.0 * math.pi * density))


@lru_cache(maxsize=64)
def kelvin_voigt_restitution(zeta: float) -> float:
    """Coefficient of restitution of a linear Kelvin-Voigt contact of damping ratio zeta
    that never pulls: the body leaves when k delta + c d(delta)/dt falls to zero (or the
    penetration ends), not when delta returns to 0.  In the time of the undamped contact
    (omega t), delta'' + 2 zeta delta' + delta = 0 from delta = 0, delta' = 1; e = -delta'
    at release.  0.732 at zeta = 0.106, 0.135 at zeta = 1; it depends on zeta only."""
    if zeta < 0:
        raise ValueError(f"zeta: got {zeta}; must be >= 0")

    def rhs(_t, y):
        return [y[1], -(y[0] + 2.0 * zeta * y[1])]

    def released(_t, y):
        return min(y[0] + 2.0 * zeta * y[1], y[0])

    released.terminal = True
    released.direction = -1
    sol = solve_ivp(rhs, (1e-9, 100.0), [1e-9, 1.0], events=released, rtol=1e-10, atol=1e-13)
    if not sol.t_events[0].size:
        return 0.0
    return float(max(-sol.y_events[0][0][1], 0.0))
