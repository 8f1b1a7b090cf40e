"""Scratch arrays of a kernel call: the structure-of-arrays copy of the bodies' state and
the per-step force buffers, allocated once per ``advance`` call."""
from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

#: X..VZ (N,): positions (m) and velocities (m/s) by component; FX..FZ (N,): forces (N);
#: HX..HZ (n (n + 1),): force of each grid x-thread on its first end, padded with a zero
#: thread before each row's first node (x-thread (i, j) at i (n + 1) + j + 1); UX..UZ
#: ((n + 1) n,): the same for y-threads (y-thread (i, j) at (i + 1) n + j); EF (M, 3): force
#: of each other thread on its first end; pair_f (P, 3), acc (3, N), lock_count (N,),
#: lock_sep (P, 3): drawstring scratch; R (3, 3): the target's rotation matrix; Lb (3,):
#: the target's body angular momentum (kg m^2/s) within its step.
Work = namedtuple("Work", "X Y Z VX VY VZ FX FY FZ HX HY HZ UX UY UZ EF pair_f acc lock_count "
                          "lock_sep R Lb")


@njit(cache=True, inline='always')
def make_work(bodies, grid, links, ring):
    """Scratch for one ``advance`` call, with the bodies' state copied in."""
    N = bodies.x.shape[0]
    ng = grid.n
    n_links = links.pairs.shape[0]
    n_pairs = ring.pairs.shape[0]
    wk = Work(np.empty(N), np.empty(N), np.empty(N), np.empty(N), np.empty(N), np.empty(N),
              np.zeros(N), np.zeros(N), np.zeros(N),
              np.zeros(ng * (ng + 1)), np.zeros(ng * (ng + 1)), np.zeros(ng * (ng + 1)),
              np.zeros((ng + 1) * ng), np.zeros((ng + 1) * ng), np.zeros((ng + 1) * ng),
              np.zeros((max(n_links, 1), 3)), np.zeros((max(n_pairs, 1), 3)), np.zeros((3, N)),
              np.zeros(N), np.zeros((n_pairs, 3)), np.empty((3, 3)), np.zeros(3))
    x = bodies.x
    v = bodies.v
    for i in range(N):
        wk.X[i] = x[i, 0]
        wk.Y[i] = x[i, 1]
        wk.Z[i] = x[i, 2]
        wk.VX[i] = v[i, 0]
        wk.VY[i] = v[i, 1]
        wk.VZ[i] = v[i, 2]
    return wk


@njit(cache=True, inline='always')
def store_work(wk, bodies):
    """Copy the structure-of-arrays state back into the bodies' (N, 3) arrays."""
    x = bodies.x
    v = bodies.v
    for i in range(x.shape[0]):
        x[i, 0] = wk.X[i]
        x[i, 1] = wk.Y[i]
        x[i, 2] = wk.Z[i]
        v[i, 0] = wk.VX[i]
        v[i, 1] = wk.VY[i]
        v[i, 2] = wk.VZ[i]
