"""Ratchet-lock rows of the implicit method (``implicit``): the drawstring's locked pairs
as rigid one-sided distance limits.  Units: SI (m, s, kg, N s).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .thread_rows import _apply, _solve_row


@njit(cache=True, inline='always', error_model='numpy')
def prepare_lock_rows(wk, rows, ring, w, h, sol):
    """Rigid one-sided rows of the ratchet locks (C = d - maxdist <= 0 at the step's end);
    warm-start impulses applied."""
    X, Y, Z = wk.X, wk.Y, wk.Z
    for p in range(ring.pairs.shape[0]):
        if ring.locked[p] == 0:
            rows.qik[p] = 0.0
            sol.lock_p[p] = 0.0
            continue
        a = ring.pairs[p, 0]
        b = ring.pairs[p, 1]
        dx = X[b] - X[a]
        dy = Y[b] - Y[a]
        dz = Z[b] - Z[a]
        d = np.sqrt(dx * dx + dy * dy + dz * dz)
        wsum = w[a] + w[b]
        if d < 1e-12 or wsum == 0.0:
            rows.qik[p] = 0.0
            sol.lock_p[p] = 0.0
            continue
        rows.qnx[p] = dx / d
        rows.qny[p] = dy / d
        rows.qnz[p] = dz / d
        rows.qb[p] = (d - ring.maxdist[p]) / h
        rows.qik[p] = 1.0 / wsum
        _apply(wk, w, a, b, rows.qnx[p], rows.qny[p], rows.qnz[p], sol.lock_p[p])


@njit(cache=True, inline='always', error_model='numpy')
def sweep_locks(wk, rows, ring, w, sol):
    """One Gauss-Seidel sweep over the ratchet locks (rigid rows: no compliance)."""
    VX, VY, VZ = wk.VX, wk.VY, wk.VZ
    for p in range(ring.pairs.shape[0]):
        if rows.qik[p] == 0.0:
            continue
        _solve_row(VX, VY, VZ, VX, VY, VZ, w, w, rows.qnx[p], rows.qny[p], rows.qnz[p],
                   rows.qb[p], 0.0, rows.qik[p], sol.lock_p, p, ring.pairs[p, 0], ring.pairs[p, 1])
