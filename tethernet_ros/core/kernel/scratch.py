"""Scratch of the kernel's steps, per lane (lane axis last), allocated once per batch:
force and impulse buffers and the implicit method's constraint rows.  Nothing in it
survives a step except the zero padding it relies on.  Units: SI (m, s, kg, N, N s).
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from .sensing import N_CHANNELS

#: Row components of a thread or lock row: unit direction (x, y, z), bias b (m/s),
#: compliance gamma (1/kg), 1 / (w_a + w_b + gamma) (kg).
RX, RY, RZ, RB, RG, RIK = range(6)

#: The implicit method's rows.  grid_h (n, n - 1, 6, K) x-threads, grid_v (n - 1, n, 6, K)
#: y-threads, links (M, 6, K).  Contacts, one per body at most: normal (N, 3, K), the
#: target's material velocity at the body vel (N, 3, K), bias b, compliance g, 1 / (w + g)
#: ik (N, K), the bodies with a row ``bodies[:count[l], l]`` (N, K).  Locks: direction
#: (P, 3, K), bias b (P, K), 1 / (w_a + w_b) ik (P, K).
ContactRows = namedtuple("ContactRows", "normal vel b g ik bodies count")
LockRows = namedtuple("LockRows", "normal b ik")

#: F (N, 3, K): forces (N) or impulses (N s) per body; H (n (n + 1), 3, K): force of each
#: grid x-thread on its first end, padded with a zero thread before each row's first node
#: (x-thread (i, j) at i (n + 1) + j + 1); U ((n + 1) n, 3, K): y-threads (y-thread (i, j)
#: at (i + 1) n + j); EF (M, 3, K): force of each other thread on its first end; pair_f
#: (P, 3, K), acc (N, 3, K), lock_count (N, K), lock_sep (P, 3, K): drawstring scratch;
#: R (3, 3, K): the target's rotation matrix; Lb (3, K): its body angular momentum;
#: meas (C,): a measurement being taken (``sensing``).
Scratch = namedtuple("Scratch", "F H U EF pair_f acc lock_count lock_sep R Lb "
                                "grid_h grid_v links contacts locks meas")


def new_scratch(model, lanes: int) -> Scratch:
    """Zeroed scratch for ``lanes`` lanes of ``model``."""
    K = int(lanes)
    N = model.bodies.radius.shape[0]
    n = model.grid.n
    M = model.links.pairs.shape[0]
    P = model.ring.pairs.shape[0]
    return Scratch(
        F=np.zeros((N, 3, K)), H=np.zeros((n * (n + 1), 3, K)), U=np.zeros(((n + 1) * n, 3, K)),
        EF=np.zeros((max(M, 1), 3, K)), pair_f=np.zeros((max(P, 1), 3, K)),
        acc=np.zeros((N, 3, K)), lock_count=np.zeros((N, K)), lock_sep=np.zeros((P, 3, K)),
        R=np.zeros((3, 3, K)), Lb=np.zeros((3, K)),
        grid_h=np.zeros((n, max(n - 1, 0), 6, K)), grid_v=np.zeros((max(n - 1, 0), n, 6, K)),
        links=np.zeros((M, 6, K)),
        contacts=ContactRows(normal=np.zeros((N, 3, K)), vel=np.zeros((N, 3, K)),
                             b=np.zeros((N, K)), g=np.zeros((N, K)), ik=np.zeros((N, K)),
                             bodies=np.zeros((N, K), dtype=np.int64),
                             count=np.zeros(K, dtype=np.int64)),
        locks=LockRows(normal=np.zeros((P, 3, K)), b=np.zeros((P, K)), ik=np.zeros((P, K))),
        meas=np.zeros(N_CHANNELS))
