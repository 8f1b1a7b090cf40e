"""Build-time laws of the model's materials: thread damping, contact stiffness and the
sizes of the contact spheres.  Evaluated once per scenario, never inside the kernel.

Units: SI (m, kg, N/m, N s/m, Pa, rad/s).
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from . import detmath


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
    ``min_omega``.  The eigenvalues come from :func:`smallest_eigenvalue_above` (bisection
    in IEEE arithmetic), not from LAPACK, whose last bits depend on the CPU kernel that
    OpenBLAS picks (docs/model.md §13).
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
            lam = smallest_eigenvalue_above(diag, off, min_omega * min_omega)
            if lam is not None:
                best = min(best, math.sqrt(lam))
    return best


def _count_below(diag, off, x: float) -> int:
    """Number of eigenvalues < x of the symmetric tridiagonal matrix (diag, off): the
    negative pivots of the LDL^T factorisation of T - x I (Sturm sequence)."""
    count = 0
    q = 1.0
    for i in range(len(diag)):
        e2 = off[i - 1] * off[i - 1] if i > 0 else 0.0
        q = (diag[i] - x) - (e2 / q if i > 0 else 0.0)
        if q == 0.0:
            q = -1e-300   # a zero pivot: x is an eigenvalue; count it as below
        if q < 0.0:
            count += 1
    return count


def smallest_eigenvalue_above(diag, off, threshold: float) -> float | None:
    """The smallest eigenvalue > ``threshold`` of the symmetric tridiagonal matrix with
    diagonal ``diag`` (n,) and off-diagonal ``off`` (n - 1,), or None if there is none.

    Bisection on the Sturm count within the Gershgorin interval, to adjacent binary64
    numbers: only IEEE operations, so the same bits on every machine."""
    d = [float(v) for v in diag]
    e = [float(v) for v in off]
    n = len(d)
    k = _count_below(d, e, threshold)
    if k >= n:
        return None
    lo, hi = threshold, threshold
    for i in range(n):
        r = (abs(e[i - 1]) if i > 0 else 0.0) + (abs(e[i]) if i < n - 1 else 0.0)
        hi = max(hi, d[i] + r)
    hi = hi + abs(hi) * 1e-15 + 1e-300
    # invariant: count_below(lo) <= k < count_below(hi)
    while True:
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            return hi
        if _count_below(d, e, mid) > k:
            hi = mid
        else:
            lo = mid


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
    """Radius (m) of a solid sphere of ``mass`` (kg) at ``density`` (kg/m^3); the cube
    root is :func:`detmath.cbrt_array` (numpy's cbrt takes CPU-dependent SIMD paths)."""
    return detmath.cbrt_array(3.0 * np.asarray(mass, dtype=float) / (4.0 * math.pi * density))


@lru_cache(maxsize=64)
def kelvin_voigt_restitution(zeta: float) -> float:
    """Coefficient of restitution of a linear Kelvin-Voigt contact of damping ratio zeta
    that never pulls: the body leaves when k delta + c d(delta)/dt falls to zero, not when
    delta returns to 0.  In the time of the undamped contact (omega t),
    delta'' + 2 zeta delta' + delta = 0 from delta = 0, delta' = 1, and e = -delta' at
    release.  Closed form (Schwager and Poschel, Granular Matter 9, 465-469, 2007), with
    omega_d = sqrt(1 - zeta^2):

      zeta < 1:  e = exp(-zeta t_r),  t_r = (pi - atan2(2 zeta omega_d, 1 - 2 zeta^2)) / omega_d
      zeta = 1:  e = exp(-2)
      zeta > 1:  e = (r+ / r-) exp(r+ t_r),  t_r = ln(r- / r+) / s,  r+- = -zeta +- s,
                 s = sqrt(zeta^2 - 1)

    0.732 at zeta = 0.106, 0.135 at zeta = 1; it depends on zeta only.  Evaluated at 96
    bits (:mod:`detmath`) and rounded once: the same bits on every machine."""
    if not zeta >= 0:
        raise ValueError(f"zeta: got {zeta}; must be >= 0")
    m = detmath.WIDE
    z = m.mpf(float(zeta))
    if z == 0:
        return 1.0
    if z < 1:
        wd = m.sqrt(1 - z * z)
        t_r = (m.pi - m.atan2(2 * z * wd, 1 - 2 * z * z)) / wd
        return float(m.exp(-z * t_r))
    if z == 1:
        return float(m.exp(-2))
    s_ = m.sqrt(z * z - 1)
    rp, rm = -z + s_, -z - s_
    t_r = m.log(rm / rp) / s_
    return float(rp / rm * m.exp(rp * t_r))
