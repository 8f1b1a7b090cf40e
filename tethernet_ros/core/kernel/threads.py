"""Tension-only Kelvin-Voigt threads for the explicit method: F = k C + c dC/dt along the
thread while it is stretched (C > 0) and F > 0 (a thread never pushes, not even through
its damper).

The grid threads are computed branch-free, every lane side by side; the other threads
(corner threads, tether) one by one.  Forces in N.
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline='always', error_model='numpy')
def _thread_force(dx, dy, dz, dvx, dvy, dvz, rest, k, c):
    """F / length of a grid thread (its force is that times (dx, dy, dz))."""
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    C = length - rest
    inv = 1.0 / max(length, 1e-12)
    cdot = (dx * dvx + dy * dvy + dz * dvz) * inv
    F = k * C + c * cdot
    F = F if C > 0.0 else 0.0
    F = F if F > 0.0 else 0.0       # a thread never pushes, not even its damper
    return F * inv


@njit(cache=True, inline='always', error_model='numpy')
def grid_thread_forces(model, data, scr):
    """Force of every grid thread on its first end, into scr.H (x-threads) and scr.U
    (y-threads)."""
    g = model.grid
    ng = g.n
    x = data.bodies.x
    v = data.bodies.v
    H = scr.H
    U = scr.U
    K = x.shape[2]
    for i in range(ng):
        for j in range(ng - 1):
            a = i * ng + j
            b = a + 1
            k = g.kh[i, j]
            c = g.ch[i, j]
            hh = i * (ng + 1) + j + 1
            for l in range(K):
                dx = x[b, 0, l] - x[a, 0, l]
                dy = x[b, 1, l] - x[a, 1, l]
                dz = x[b, 2, l] - x[a, 2, l]
                s_ = _thread_force(dx, dy, dz, v[b, 0, l] - v[a, 0, l], v[b, 1, l] - v[a, 1, l],
                                   v[b, 2, l] - v[a, 2, l], g.rest, k, c)
                H[hh, 0, l] = s_ * dx
                H[hh, 1, l] = s_ * dy
                H[hh, 2, l] = s_ * dz
    for i in range(ng - 1):
        for j in range(ng):
            a = i * ng + j
            b = a + ng
            k = g.kv[i, j]
            c = g.cv[i, j]
            for l in range(K):
                dx = x[b, 0, l] - x[a, 0, l]
                dy = x[b, 1, l] - x[a, 1, l]
                dz = x[b, 2, l] - x[a, 2, l]
                s_ = _thread_force(dx, dy, dz, v[b, 0, l] - v[a, 0, l], v[b, 1, l] - v[a, 1, l],
                                   v[b, 2, l] - v[a, 2, l], g.rest, k, c)
                U[b, 0, l] = s_ * dx
                U[b, 1, l] = s_ * dy
                U[b, 2, l] = s_ * dz


@njit(cache=True, inline='always', error_model='numpy')
def link_forces(model, data, scr, l):
    """Force of every active other thread of lane l on its first end, into scr.EF."""
    x = data.bodies.x
    v = data.bodies.v
    ln = data.links
    EF = scr.EF
    pairs = model.links.pairs
    for m in range(pairs.shape[0]):
        EF[m, 0, l] = 0.0
        EF[m, 1, l] = 0.0
        EF[m, 2, l] = 0.0
        if ln.active[m, l] == 0:
            continue
        i = pairs[m, 0]
        j = pairs[m, 1]
        dx = x[j, 0, l] - x[i, 0, l]
        dy = x[j, 1, l] - x[i, 1, l]
        dz = x[j, 2, l] - x[i, 2, l]
        rest = ln.rest[m, l]
        len2 = dx * dx + dy * dy + dz * dz
        if len2 <= rest * rest or len2 < 1e-28:
            continue
        length = np.sqrt(len2)
        inv = 1.0 / length
        cdot = (dx * (v[j, 0, l] - v[i, 0, l]) + dy * (v[j, 1, l] - v[i, 1, l])
                + dz * (v[j, 2, l] - v[i, 2, l])) * inv
        F = ln.k[m, l] * (length - rest) + ln.c[m, l] * cdot
        if F <= 0.0:
            continue
        EF[m, 0, l] = F * inv * dx
        EF[m, 1, l] = F * inv * dy
        EF[m, 2, l] = F * inv * dz


@njit(cache=True, inline='always', error_model='numpy')
def gather_thread_forces(model, scr):
    """Sum the thread forces (or impulses) per body into scr.F (overwriting it) in a
    mirror-invariant order: (left + right) + (down + up) for grid nodes, each pair's sum
    commutative, then the other threads through each body's slots."""
    ng = model.grid.n
    F = scr.F
    H = scr.H
    U = scr.U
    EF = scr.EF
    N = F.shape[0]
    K = F.shape[2]
    for i in range(ng):
        for j in range(ng):
            a = i * ng + j
            hh = i * (ng + 1) + j
            for c in range(3):
                for l in range(K):
                    F[a, c, l] = (H[hh + 1, c, l] - H[hh, c, l]) + (U[a + ng, c, l] - U[a, c, l])
    for a in range(ng * ng, N):
        for c in range(3):
            for l in range(K):
                F[a, c, l] = 0.0
    slots = model.links.slots
    signs = model.links.signs
    for a in range(N):
        m0 = slots[a, 0]
        m1 = slots[a, 1]
        if m0 < 0 and m1 < 0:
            continue
        for c in range(3):
            for l in range(K):
                if m0 >= 0:
                    e = signs[a, 0] * EF[m0, c, l]
                    if m1 >= 0:
                        e += signs[a, 1] * EF[m1, c, l]
                else:
                    e = 0.0
                    e += signs[a, 1] * EF[m1, c, l]
                F[a, c, l] += e
