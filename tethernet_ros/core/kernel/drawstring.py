"""The drawstring: constant closing force F_c along each adjacent pair of ring bodies once
closing is active, and the locks of pairs that came closer than the lock distance.

Lock model "ratchet": the force pulls every pair; a locked pair is a one-sided distance
joint whose maximum distance starts at the lock distance and only shrinks toward 0
(positions projected, separating velocity removed, momentum kept).
Lock model "latch" (the reference implementation): the force pulls a pair only while it is
at least the lock distance apart; a pair that came closer is latched for good (it counts
as locked) but held by nothing, and the force resumes if it drifts apart again.
Forces in N, lengths in m.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .state import LOCK_RATCHET

#: Jacobi passes of the lock projection per step
LOCK_PASSES = 4


@njit(cache=True, inline='always', error_model='numpy')
def closing_forces(wk, ring, close_force, lock_model, lock_dist):
    """Add F_c along the drawstring pairs it pulls (every pair; under the latch model only
    those at least ``lock_dist`` apart) to wk.FX.. (a ring body in two pairs gets both pulls
    summed first, commutatively, so mirror symmetry is kept)."""
    X, Y, Z = wk.X, wk.Y, wk.Z
    pair_f = wk.pair_f
    acc = wk.acc
    ring_pairs = ring.pairs
    n_pairs = ring_pairs.shape[0]
    for p in range(n_pairs):
        a = ring_pairs[p, 0]
        b = ring_pairs[p, 1]
        dx = X[b] - X[a]
        dy = Y[b] - Y[a]
        dz = Z[b] - Z[a]
        d = np.sqrt(dx * dx + dy * dy + dz * dz)
        if d > 1e-12 and (lock_model == LOCK_RATCHET or d >= lock_dist):
            s_ = close_force / d
            pair_f[p, 0] = s_ * dx
            pair_f[p, 1] = s_ * dy
            pair_f[p, 2] = s_ * dz
        else:
            pair_f[p, 0] = 0.0
            pair_f[p, 1] = 0.0
            pair_f[p, 2] = 0.0
    for p in range(n_pairs):
        for c in range(3):
            acc[c, ring_pairs[p, 0]] += pair_f[p, c]
            acc[c, ring_pairs[p, 1]] -= pair_f[p, c]
    for p in range(n_pairs):
        for e in range(2):
            a = ring_pairs[p, e]
            wk.FX[a] += acc[0, a]
            wk.FY[a] += acc[1, a]
            wk.FZ[a] += acc[2, a]
            acc[0, a] = 0.0
            acc[1, a] = 0.0
            acc[2, a] = 0.0


@njit(cache=True, inline='always', error_model='numpy')
def update_locks(wk, ring, lock_dist, step):
    """Lock every pair closer than ``lock_dist``; a locked pair's maximum distance (the
    ratchet's limit; under the latch model only a record) follows it down."""
    X, Y, Z = wk.X, wk.Y, wk.Z
    for p in range(ring.pairs.shape[0]):
        a = ring.pairs[p, 0]
        b = ring.pairs[p, 1]
        dx = X[b] - X[a]
        dy = Y[b] - Y[a]
        dz = Z[b] - Z[a]
        d = np.sqrt(dx * dx + dy * dy + dz * dz)
        if ring.locked[p] == 0:
            if d < lock_dist:
                ring.locked[p] = 1
                ring.maxdist[p] = d
                ring.lock_step[p] = step
        elif d < ring.maxdist[p]:
            ring.maxdist[p] = d


@njit(cache=True, inline='always', error_model='numpy')
def project_locks(wk, w, ring):
    """Hold every locked pair within its maximum distance: positions are projected along
    the pair (mass-weighted, so momentum is kept) and the separating relative velocity is
    removed.  A node in two locked pairs takes the mean of both corrections (Jacobi with
    mass splitting, order-independent); LOCK_PASSES passes per step."""
    X, Y, Z, VX, VY, VZ = wk.X, wk.Y, wk.Z, wk.VX, wk.VY, wk.VZ
    corr = wk.acc
    count = wk.lock_count
    sep = wk.lock_sep
    ring_pairs = ring.pairs
    pair_locked = ring.locked
    pair_maxdist = ring.maxdist
    n_pairs = ring_pairs.shape[0]
    # each pair's separation before the projection (m): the direction of its separating
    # motion where the projection leaves it coincident (below)
    for p in range(n_pairs):
        sep[p, 0] = X[ring_pairs[p, 1]] - X[ring_pairs[p, 0]]
        sep[p, 1] = Y[ring_pairs[p, 1]] - Y[ring_pairs[p, 0]]
        sep[p, 2] = Z[ring_pairs[p, 1]] - Z[ring_pairs[p, 0]]
    for _ in range(LOCK_PASSES):
        any_active = False
        for p in range(n_pairs):
            if pair_locked[p] == 1:
                count[ring_pairs[p, 0]] += 1.0
                count[ring_pairs[p, 1]] += 1.0
        for p in range(n_pairs):
            if pair_locked[p] == 0:
                continue
            a = ring_pairs[p, 0]
            b = ring_pairs[p, 1]
            dx = X[b] - X[a]
            dy = Y[b] - Y[a]
            dz = Z[b] - Z[a]
            d = np.sqrt(dx * dx + dy * dy + dz * dz)
            C = d - pair_maxdist[p]
            wsum = w[a] + w[b]
            if C <= 0.0 or d < 1e-14 or wsum == 0.0:
                continue
            any_active = True
            s = C / (wsum * d)
            corr[0, a] += w[a] * s * dx
            corr[1, a] += w[a] * s * dy
            corr[2, a] += w[a] * s * dz
            corr[0, b] -= w[b] * s * dx
            corr[1, b] -= w[b] * s * dy
            corr[2, b] -= w[b] * s * dz
        for p in range(n_pairs):
            for e in range(2):
                a = ring_pairs[p, e]
                if count[a] > 0.0:
                    X[a] += corr[0, a] / count[a]
                    Y[a] += corr[1, a] / count[a]
                    Z[a] += corr[2, a] / count[a]
                    corr[0, a] = 0.0
                    corr[1, a] = 0.0
                    corr[2, a] = 0.0
                    count[a] = 0.0
        if not any_active:
            break
    # velocities: no separating relative velocity along a pair at its limit
    for p in range(n_pairs):
        if pair_locked[p] == 0:
            continue
        a = ring_pairs[p, 0]
        b = ring_pairs[p, 1]
        dx = X[b] - X[a]
        dy = Y[b] - Y[a]
        dz = Z[b] - Z[a]
        d = np.sqrt(dx * dx + dy * dy + dz * dz)
        wsum = w[a] + w[b]
        if d < 1e-14:
            # projected onto one point, which has no direction: the separating motion had
            # the direction of the separation before the projection
            dx = sep[p, 0]
            dy = sep[p, 1]
            dz = sep[p, 2]
            d = np.sqrt(dx * dx + dy * dy + dz * dz)
            if d <= pair_maxdist[p] or d < 1e-14:
                continue
        if wsum == 0.0 or d < pair_maxdist[p] * (1.0 - 1e-9):
            continue
        nx = dx / d
        ny = dy / d
        nz = dz / d
        vsep = nx * (VX[b] - VX[a]) + ny * (VY[b] - VY[a]) + nz * (VZ[b] - VZ[a])
        if vsep > 0.0:
            s = vsep / wsum
            VX[a] += w[a] * s * nx
            VY[a] += w[a] * s * ny
            VZ[a] += w[a] * s * nz
            VX[b] -= w[b] * s * nx
            VY[b] -= w[b] * s * ny
            VZ[b] -= w[b] * s * nz
