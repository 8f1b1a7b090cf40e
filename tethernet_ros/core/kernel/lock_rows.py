"""Ratchet-lock rows of the implicit method (``implicit``): the drawstring's locked pairs
as rigid one-sided distance limits, per lane.  Units: SI (m, s, kg, N s).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .thread_rows import solve_pair_row


@njit(cache=True, inline='always', error_model='numpy')
def prepare_lock_rows(model, data, scr, l):
    """Lane l: rigid one-sided rows of the ratchet locks (C = d - maxdist <= 0 at the
    step's end); warm-start impulses applied."""
    x = data.bodies.x
    v = data.bodies.v
    w = data.bodies.w
    ring = data.ring
    rows = scr.locks
    lock_p = data.warm.lock_p
    pairs = model.ring.pairs
    h = model.params.dt
    for p in range(pairs.shape[0]):
        if ring.locked[p, l] == 0:
            rows.ik[p, l] = 0.0
            lock_p[p, l] = 0.0
            continue
        a = pairs[p, 0]
        b = pairs[p, 1]
        dx = x[b, 0, l] - x[a, 0, l]
        dy = x[b, 1, l] - x[a, 1, l]
        dz = x[b, 2, l] - x[a, 2, l]
        d = np.sqrt(dx * dx + dy * dy + dz * dz)
        wsum = w[a, l] + w[b, l]
        if d < 1e-12 or wsum == 0.0:
            rows.ik[p, l] = 0.0
            lock_p[p, l] = 0.0
            continue
        nx = dx / d
        ny = dy / d
        nz = dz / d
        rows.normal[p, 0, l] = nx
        rows.normal[p, 1, l] = ny
        rows.normal[p, 2, l] = nz
        rows.b[p, l] = (d - ring.maxdist[p, l]) / h
        rows.ik[p, l] = 1.0 / wsum
        dP = lock_p[p, l]
        v[a, 0, l] -= w[a, l] * nx * dP
        v[a, 1, l] -= w[a, l] * ny * dP
        v[a, 2, l] -= w[a, l] * nz * dP
        v[b, 0, l] += w[b, l] * nx * dP
        v[b, 1, l] += w[b, l] * ny * dP
        v[b, 2, l] += w[b, l] * nz * dP


@njit(cache=True, inline='always', error_model='numpy')
def sweep_locks(model, data, scr, l):
    """One Gauss-Seidel sweep over lane l's ratchet locks (rigid rows: no compliance)."""
    rows = scr.locks
    pairs = model.ring.pairs
    for p in range(pairs.shape[0]):
        if rows.ik[p, l] == 0.0:
            continue
        solve_pair_row(data.bodies.v, data.bodies.w, pairs[p, 0], pairs[p, 1],
                       rows.normal[p, 0, l], rows.normal[p, 1, l], rows.normal[p, 2, l],
                       rows.b[p, l], 0.0, rows.ik[p, l], data.warm.lock_p, p, l)
