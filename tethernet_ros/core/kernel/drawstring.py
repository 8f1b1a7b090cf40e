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

from .data import E_STEP
from .model import LOCK_LATCH

#: Jacobi passes of the lock projection per step
LOCK_PASSES = 4


@njit(cache=True, inline='always', error_model='numpy')
def closing_forces(model, data, scr, l):
    """Lane l: add F_c along the drawstring pairs it pulls (every pair under the ratchet
    and the cinch; under the latch model only those at least ``lock_dist`` apart) to
    scr.F (a ring body in two pairs gets both pulls summed first, commutatively, so mirror
    symmetry is kept)."""
    x = data.bodies.x
    F = scr.F
    pair_f = scr.pair_f
    acc = scr.acc
    prm = model.params
    close_force = prm.close_force
    ring_pairs = model.ring.pairs
    n_pairs = ring_pairs.shape[0]
    for p in range(n_pairs):
        a = ring_pairs[p, 0]
        b = ring_pairs[p, 1]
        dx = x[b, 0, l] - x[a, 0, l]
        dy = x[b, 1, l] - x[a, 1, l]
        dz = x[b, 2, l] - x[a, 2, l]
        d = np.sqrt(dx * dx + dy * dy + dz * dz)
        if d > 1e-12 and (prm.lock_model != LOCK_LATCH or d >= prm.lock_dist):
            s_ = close_force / d
            pair_f[p, 0, l] = s_ * dx
            pair_f[p, 1, l] = s_ * dy
            pair_f[p, 2, l] = s_ * dz
        else:
            pair_f[p, 0, l] = 0.0
            pair_f[p, 1, l] = 0.0
            pair_f[p, 2, l] = 0.0
    for p in range(n_pairs):
        for c in range(3):
            acc[ring_pairs[p, 0], c, l] += pair_f[p, c, l]
            acc[ring_pairs[p, 1], c, l] -= pair_f[p, c, l]
    for p in range(n_pairs):
        for e in range(2):
            a = ring_pairs[p, e]
            for c in range(3):
                F[a, c, l] += acc[a, c, l]
                acc[a, c, l] = 0.0


@njit(cache=True, inline='always', error_model='numpy')
def update_locks(model, data, l):
    """Lane l: lock every pair closer than ``lock_dist``; a locked pair's maximum distance
    (the ratchet's limit; under the latch model only a record) follows it down."""
    x = data.bodies.x
    ring = data.ring
    pairs = model.ring.pairs
    lock_dist = model.params.lock_dist
    step = data.events[E_STEP, l]
    for p in range(pairs.shape[0]):
        a = pairs[p, 0]
        b = pairs[p, 1]
        dx = x[b, 0, l] - x[a, 0, l]
        dy = x[b, 1, l] - x[a, 1, l]
        dz = x[b, 2, l] - x[a, 2, l]
        d = np.sqrt(dx * dx + dy * dy + dz * dz)
        if ring.locked[p, l] == 0:
            if d < lock_dist:
                ring.locked[p, l] = 1
                ring.maxdist[p, l] = d
                ring.lock_step[p, l] = step
        elif d < ring.maxdist[p, l]:
            ring.maxdist[p, l] = d


@njit(cache=True, inline='always', error_model='numpy')
def project_locks(model, data, scr, l):
    """Lane l (explicit method): hold every locked pair within its maximum distance:
    positions are projected along the pair (mass-weighted, so momentum is kept) and the
    separating relative velocity is removed.  A node in two locked pairs takes the mean of
    both corrections (Jacobi with mass splitting, order-independent); LOCK_PASSES passes
    per step."""
    x = data.bodies.x
    v = data.bodies.v
    w = data.bodies.w
    corr = scr.acc
    count = scr.lock_count
    sep = scr.lock_sep
    ring_pairs = model.ring.pairs
    pair_locked = data.ring.locked
    pair_maxdist = data.ring.maxdist
    n_pairs = ring_pairs.shape[0]
    # each pair's separation before the projection (m): the direction of its separating
    # motion where the projection leaves it coincident (below)
    for p in range(n_pairs):
        for c in range(3):
            sep[p, c, l] = x[ring_pairs[p, 1], c, l] - x[ring_pairs[p, 0], c, l]
    for _ in range(LOCK_PASSES):
        any_active = False
        for p in range(n_pairs):
            if pair_locked[p, l] == 1:
                count[ring_pairs[p, 0], l] += 1.0
                count[ring_pairs[p, 1], l] += 1.0
        for p in range(n_pairs):
            if pair_locked[p, l] == 0:
                continue
            a = ring_pairs[p, 0]
            b = ring_pairs[p, 1]
            dx = x[b, 0, l] - x[a, 0, l]
            dy = x[b, 1, l] - x[a, 1, l]
            dz = x[b, 2, l] - x[a, 2, l]
            d = np.sqrt(dx * dx + dy * dy + dz * dz)
            C = d - pair_maxdist[p, l]
            wa = w[a, l]
            wb = w[b, l]
            wsum = wa + wb
            if C <= 0.0 or d < 1e-14 or wsum == 0.0:
                continue
            any_active = True
            s = C / (wsum * d)
            corr[a, 0, l] += wa * s * dx
            corr[a, 1, l] += wa * s * dy
            corr[a, 2, l] += wa * s * dz
            corr[b, 0, l] -= wb * s * dx
            corr[b, 1, l] -= wb * s * dy
            corr[b, 2, l] -= wb * s * dz
        for p in range(n_pairs):
            for e in range(2):
                a = ring_pairs[p, e]
                if count[a, l] > 0.0:
                    for c in range(3):
                        x[a, c, l] += corr[a, c, l] / count[a, l]
                    for c in range(3):
                        corr[a, c, l] = 0.0
                    count[a, l] = 0.0
        if not any_active:
            break
    # velocities: no separating relative velocity along a pair at its limit
    for p in range(n_pairs):
        if pair_locked[p, l] == 0:
            continue
        a = ring_pairs[p, 0]
        b = ring_pairs[p, 1]
        dx = x[b, 0, l] - x[a, 0, l]
        dy = x[b, 1, l] - x[a, 1, l]
        dz = x[b, 2, l] - x[a, 2, l]
        d = np.sqrt(dx * dx + dy * dy + dz * dz)
        wa = w[a, l]
        wb = w[b, l]
        wsum = wa + wb
        if d < 1e-14:
            # projected onto one point, which has no direction: the separating motion had
            # the direction of the separation before the projection
            dx = sep[p, 0, l]
            dy = sep[p, 1, l]
            dz = sep[p, 2, l]
            d = np.sqrt(dx * dx + dy * dy + dz * dz)
            if d <= pair_maxdist[p, l] or d < 1e-14:
                continue
        if wsum == 0.0 or d < pair_maxdist[p, l] * (1.0 - 1e-9):
            continue
        nx = dx / d
        ny = dy / d
        nz = dz / d
        vsep = nx * (v[b, 0, l] - v[a, 0, l]) + ny * (v[b, 1, l] - v[a, 1, l]) \
            + nz * (v[b, 2, l] - v[a, 2, l])
        if vsep > 0.0:
            s = vsep / wsum
            v[a, 0, l] += wa * s * nx
            v[a, 1, l] += wa * s * ny
            v[a, 2, l] += wa * s * nz
            v[b, 0, l] -= wb * s * nx
            v[b, 1, l] -= wb * s * ny
            v[b, 2, l] -= wb * s * nz
