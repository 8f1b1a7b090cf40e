"""Thread rows of the implicit method (``implicit``): the grid threads and the other
threads (corner threads, tether) as tension-only compliant constraints on their length,
their rows at the start of a step (with the last step's impulses as warm start) and one
projected Gauss-Seidel sweep over them.  The grid is swept by colour (module docstring of
``implicit``); every grid loop runs over all lanes side by side, its innermost loop the
lane loop (contiguous, independent: SIMD across episodes).  Units: SI (m, s, kg, N s).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .scratch import RB, RG, RIK, RX, RY, RZ


@njit(cache=True, inline='always')
def _thread_row(dx, dy, dz, rest, k, c, wsum, h):
    """Direction, bias, compliance and inverse effective mass of one thread row."""
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    inv = 1.0 / max(length, 1e-12)
    C = length - rest
    denom = h * k + c
    taut = C > 0.0 and denom > 0.0
    safe = denom if denom > 0.0 else 1.0
    b = k * C / safe if taut else C / h
    g = 1.0 / (h * safe) if taut else 0.0
    s = wsum + g
    ik = 1.0 / s if s > 0.0 else 0.0
    return dx * inv, dy * inv, dz * inv, b, g, ik


@njit(cache=True, inline='always')
def _grid_row(rows, a, b, x, rest, const, inv_h, P, U, u):
    """Row of the grid thread from body a to body b in every lane, from its constants
    ``const`` (k / (h k + c), 1 / (h (h k + c)), taut and slack inverse effective mass);
    and its last impulse P (per lane) along its new direction into U[u] (on b; -U on a)."""
    K = x.shape[2]
    kd = const[0]
    gd = const[1]
    ikt = const[2]
    iks = const[3]
    for l in range(K):
        dx = x[b, 0, l] - x[a, 0, l]
        dy = x[b, 1, l] - x[a, 1, l]
        dz = x[b, 2, l] - x[a, 2, l]
        length = np.sqrt(dx * dx + dy * dy + dz * dz)
        inv = 1.0 / max(length, 1e-12)
        C = length - rest
        taut = C > 0.0
        nx = dx * inv
        ny = dy * inv
        nz = dz * inv
        rows[RX, l] = nx
        rows[RY, l] = ny
        rows[RZ, l] = nz
        rows[RB, l] = kd * C if taut else C * inv_h
        rows[RG, l] = gd if taut else 0.0
        rows[RIK, l] = ikt if taut else iks
        # the impulse P n on the second end (P < 0: tension), -P n on the first
        U[u, 0, l] = -P[l] * nx
        U[u, 1, l] = -P[l] * ny
        U[u, 2, l] = -P[l] * nz


@njit(cache=True, inline='always', error_model='numpy')
def prepare_grid_rows(model, data, scr):
    """Rows of every grid thread at the start of the step, in every lane, and the last
    step's impulses along this step's directions in the explicit method's force layout
    (scr.H, scr.U as impulses): ``gather_thread_forces`` then sums them."""
    g = model.grid
    ng = g.n
    inv_h = 1.0 / model.params.dt
    x = data.bodies.x
    ws = data.warm
    for i in range(ng):
        for j in range(ng - 1):
            a = i * ng + j
            _grid_row(scr.grid_h[i, j], a, a + 1, x, g.rest, g.hconst[i, j], inv_h,
                      ws.grid_ph[i, j], scr.H, i * (ng + 1) + j + 1)
    for i in range(ng - 1):
        for j in range(ng):
            a = i * ng + j
            _grid_row(scr.grid_v[i, j], a, a + ng, x, g.rest, g.vconst[i, j], inv_h,
                      ws.grid_pv[i, j], scr.U, a + ng)


@njit(cache=True, inline='always', error_model='numpy')
def prepare_link_rows(model, data, scr, l):
    """Lane l: rows of every active other thread, and its last impulse into scr.EF."""
    x = data.bodies.x
    w = data.bodies.w
    ln = data.links
    ws = data.warm
    rows = scr.links
    EF = scr.EF
    pairs = model.links.pairs
    h = model.params.dt
    for m in range(pairs.shape[0]):
        EF[m, 0, l] = 0.0
        EF[m, 1, l] = 0.0
        EF[m, 2, l] = 0.0
        a = pairs[m, 0]
        b_ = pairs[m, 1]
        if ln.active[m, l] == 0:
            rows[m, RIK, l] = 0.0
            ws.link_p[m, l] = 0.0
            continue
        nx, ny, nz, b, g, ik = _thread_row(x[b_, 0, l] - x[a, 0, l], x[b_, 1, l] - x[a, 1, l],
                                           x[b_, 2, l] - x[a, 2, l], ln.rest[m, l], ln.k[m, l],
                                           ln.c[m, l], w[a, l] + w[b_, l], h)
        rows[m, RX, l] = nx
        rows[m, RY, l] = ny
        rows[m, RZ, l] = nz
        rows[m, RB, l] = b
        rows[m, RG, l] = g
        rows[m, RIK, l] = ik
        p = ws.link_p[m, l]
        EF[m, 0, l] = -p * nx
        EF[m, 1, l] = -p * ny
        EF[m, 2, l] = -p * nz


@njit(cache=True, inline='always', error_model='numpy')
def apply_gathered(data, scr):
    """v += w P for the per-body impulse sums in scr.F (N s), every lane."""
    v = data.bodies.v
    w = data.bodies.w
    F = scr.F
    for i in range(v.shape[0]):
        for c in range(3):
            for l in range(v.shape[2]):
                v[i, c, l] += w[i, l] * F[i, c, l]


@njit(cache=True, inline='always')
def _solve_grid_row(v, w, a, b, rows, P):
    """The projected Gauss-Seidel update of one tension-only grid row between bodies a and
    b, every lane, with impulse P (per lane, N s)."""
    for l in range(v.shape[2]):
        nx = rows[RX, l]
        ny = rows[RY, l]
        nz = rows[RZ, l]
        jv = nx * (v[b, 0, l] - v[a, 0, l]) + ny * (v[b, 1, l] - v[a, 1, l]) \
            + nz * (v[b, 2, l] - v[a, 2, l])
        p = P[l]
        pn = min(p - (jv + rows[RB, l] + rows[RG, l] * p) * rows[RIK, l], 0.0)
        P[l] = pn
        dp = pn - p
        wa = w[a, l]
        wb = w[b, l]
        v[a, 0, l] -= wa * nx * dp
        v[a, 1, l] -= wa * ny * dp
        v[a, 2, l] -= wa * nz * dp
        v[b, 0, l] += wb * nx * dp
        v[b, 1, l] += wb * ny * dp
        v[b, 2, l] += wb * nz * dp


@njit(cache=True, inline='always', error_model='numpy')
def sweep_grid(model, data, scr):
    """One Gauss-Seidel sweep over the grid threads of every lane, colour by colour:
    x-threads of even, then odd columns; y-threads of even, then odd rows (threads of one
    colour share no node)."""
    ng = model.grid.n
    v = data.bodies.v
    w = data.bodies.w
    ws = data.warm
    for colour in range(2):
        for i in range(ng):
            for j in range(colour, ng - 1, 2):
                a = i * ng + j
                _solve_grid_row(v, w, a, a + 1, scr.grid_h[i, j], ws.grid_ph[i, j])
    for colour in range(2):
        for i in range(colour, ng - 1, 2):
            for j in range(ng):
                a = i * ng + j
                _solve_grid_row(v, w, a, a + ng, scr.grid_v[i, j], ws.grid_pv[i, j])


@njit(cache=True, inline='always')
def solve_pair_row(v, w, a, b, nx, ny, nz, bias, g, ik, P, j, l):
    """One tension-only (or one-sided) row between bodies a and b of lane l with impulse
    P[j, l] (N s): the projected Gauss-Seidel update."""
    jv = nx * (v[b, 0, l] - v[a, 0, l]) + ny * (v[b, 1, l] - v[a, 1, l]) \
        + nz * (v[b, 2, l] - v[a, 2, l])
    p = P[j, l]
    pn = min(p - (jv + bias + g * p) * ik, 0.0)
    P[j, l] = pn
    dp = pn - p
    v[a, 0, l] -= w[a, l] * nx * dp
    v[a, 1, l] -= w[a, l] * ny * dp
    v[a, 2, l] -= w[a, l] * nz * dp
    v[b, 0, l] += w[b, l] * nx * dp
    v[b, 1, l] += w[b, l] * ny * dp
    v[b, 2, l] += w[b, l] * nz * dp


@njit(cache=True, inline='always', error_model='numpy')
def sweep_links(model, data, scr, l):
    """One Gauss-Seidel sweep over lane l's other threads (corner threads, tether)."""
    v = data.bodies.v
    w = data.bodies.w
    rows = scr.links
    pairs = model.links.pairs
    for m in range(pairs.shape[0]):
        if rows[m, RIK, l] == 0.0:
            continue
        solve_pair_row(v, w, pairs[m, 0], pairs[m, 1], rows[m, RX, l], rows[m, RY, l],
                       rows[m, RZ, l], rows[m, RB, l], rows[m, RG, l], rows[m, RIK, l],
                       data.warm.link_p, m, l)
