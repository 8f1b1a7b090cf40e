"""Row storage of the implicit method (``implicit``): one array per row quantity, per
constraint kind, allocated once per kernel call; and the grid threads' constants for the
step.  Units: SI (m, s, kg, N s).
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

#: Per-step rows.  Grid x-threads (n, n - 1) and y-threads (n - 1, n): unit direction
#: (hnx, hny, hnz / vnx..), bias b (m/s), compliance gamma (1/kg) and 1 / (w_a + w_b +
#: gamma) (kg).  Links (M,): the same plus their ends' rows.  Contacts, one per body at
#: most (N,): normal (cnx..), the target's material velocity at the body (cvx..), bias,
#: compliance, 1 / (w + gamma), and ``crow`` the bodies with a row (first ``n_rows[0]``).
#: Locks (P,): direction, bias, 1 / (w_a + w_b).  Constant over a call, per grid thread:
#: k / (h k + c) (1/s), 1 / (h (h k + c)) (1/kg) and 1 / (w_a + w_b + gamma) when taut,
#: 1 / (w_a + w_b) when slack (hkd, hgd, hikt, hiks; vkd.. for y-threads).
Rows = namedtuple("Rows", "hnx hny hnz hb hg hik vnx vny vnz vb vg vik "
                          "hkd hgd hikt hiks vkd vgd vikt viks "
                          "lnx lny lnz lb lg lik "
                          "cnx cny cnz cvx cvy cvz cb cg cik crow n_rows "
                          "qnx qny qnz qb qik")


@njit(cache=True, inline='always')
def _thread_constants(k, c, wsum, h):
    """k / (h k + c), 1 / (h (h k + c)), and the inverse effective masses taut and slack."""
    denom = h * k + c
    if denom <= 0.0:
        return 0.0, 0.0, (1.0 / wsum if wsum > 0.0 else 0.0), (1.0 / wsum if wsum > 0.0 else 0.0)
    g = 1.0 / (h * denom)
    return k / denom, g, 1.0 / (wsum + g), (1.0 / wsum if wsum > 0.0 else 0.0)


@njit(cache=True)
def make_rows(grid, n_links, n_bodies, n_pairs, w, h):
    """Row storage of one call, with the grid threads' constants for the step h (s)."""
    ng = grid.n
    nh = (ng, max(ng - 1, 0))
    nv = (max(ng - 1, 0), ng)
    rows = Rows(np.zeros(nh), np.zeros(nh), np.zeros(nh), np.zeros(nh), np.zeros(nh), np.zeros(nh),
                np.zeros(nv), np.zeros(nv), np.zeros(nv), np.zeros(nv), np.zeros(nv), np.zeros(nv),
                np.zeros(nh), np.zeros(nh), np.zeros(nh), np.zeros(nh),
                np.zeros(nv), np.zeros(nv), np.zeros(nv), np.zeros(nv),
                np.zeros(n_links), np.zeros(n_links), np.zeros(n_links), np.zeros(n_links),
                np.zeros(n_links), np.zeros(n_links),
                np.zeros(n_bodies), np.zeros(n_bodies), np.zeros(n_bodies), np.zeros(n_bodies),
                np.zeros(n_bodies), np.zeros(n_bodies), np.zeros(n_bodies), np.zeros(n_bodies),
                np.zeros(n_bodies), np.zeros(n_bodies, dtype=np.int64), np.zeros(1, dtype=np.int64),
                np.zeros(n_pairs), np.zeros(n_pairs), np.zeros(n_pairs), np.zeros(n_pairs),
                np.zeros(n_pairs))
    for i in range(ng):
        for j in range(ng - 1):
            a = i * ng + j
            kd, gd, ikt, iks = _thread_constants(grid.kh[i, j], grid.ch[i, j], w[a] + w[a + 1], h)
            rows.hkd[i, j] = kd
            rows.hgd[i, j] = gd
            rows.hikt[i, j] = ikt
            rows.hiks[i, j] = iks
    for i in range(ng - 1):
        for j in range(ng):
            a = i * ng + j
            kd, gd, ikt, iks = _thread_constants(grid.kv[i, j], grid.cv[i, j], w[a] + w[a + ng], h)
            rows.vkd[i, j] = kd
            rows.vgd[i, j] = gd
            rows.vikt[i, j] = ikt
            rows.viks[i, j] = iks
    return rows
