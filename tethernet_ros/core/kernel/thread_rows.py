"""Thread rows of the implicit method (``implicit``): the grid threads and the other
threads (corner threads, tether) as tension-only compliant constraints on their length,
their rows at the start of a step (with the last step's impulses as warm start) and one
projected Gauss-Seidel sweep over them.  The grid is swept by colour (module docstring of
``implicit``).  Units: SI (m, s, kg, N s).
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline='always')
def _thread_row(dx, dy, dz, rest, k, c, wsum, h):
    """Direction, bias, compliance and inverse effective mass of one thread row
    (branch-free, so that the grid loops vectorise)."""
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
def _grid_row(dx, dy, dz, rest, kd, gd, ikt, iks, inv_h):
    """A grid thread's row from its per-call constants: direction, bias, compliance and
    inverse effective mass (branch-free)."""
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    inv = 1.0 / max(length, 1e-12)
    C = length - rest
    taut = C > 0.0
    b = kd * C if taut else C * inv_h
    g = gd if taut else 0.0
    ik = ikt if taut else iks
    return dx * inv, dy * inv, dz * inv, b, g, ik


@njit(cache=True, inline='always', error_model='numpy')
def prepare_thread_rows(wk, rows, grid, links, w, h, sol):
    """Rows of every grid thread and active other thread at the start of the step, and the
    last step's impulses along this step's directions, in the explicit method's force
    layout (wk.HX.., UX.., EF as impulses): ``gather_thread_forces`` then sums them."""
    ng = grid.n
    inv_h = 1.0 / h
    X, Y, Z = wk.X, wk.Y, wk.Z
    for i in range(ng):
        r0 = i * ng
        xr = X[r0:r0 + ng]
        yr = Y[r0:r0 + ng]
        zr = Z[r0:r0 + ng]
        nxr = rows.hnx[i]
        nyr = rows.hny[i]
        nzr = rows.hnz[i]
        br = rows.hb[i]
        gr = rows.hg[i]
        ikr = rows.hik[i]
        pr = sol.grid_ph[i]
        h0 = i * (ng + 1)
        hx = wk.HX[h0:h0 + ng + 1]
        hy = wk.HY[h0:h0 + ng + 1]
        hz = wk.HZ[h0:h0 + ng + 1]
        kd = rows.hkd[i]
        gd = rows.hgd[i]
        ikt = rows.hikt[i]
        iks = rows.hiks[i]
        for j in range(ng - 1):
            nx, ny, nz, b, g, ik = _grid_row(xr[j + 1] - xr[j], yr[j + 1] - yr[j],
                                             zr[j + 1] - zr[j], grid.rest, kd[j], gd[j], ikt[j],
                                             iks[j], inv_h)
            nxr[j] = nx
            nyr[j] = ny
            nzr[j] = nz
            br[j] = b
            gr[j] = g
            ikr[j] = ik
            # the impulse P n on the second end (P < 0: tension), -P n on the first
            hx[j + 1] = -pr[j] * nx
            hy[j + 1] = -pr[j] * ny
            hz[j + 1] = -pr[j] * nz
    for i in range(ng - 1):
        r0 = i * ng
        r1 = r0 + ng
        nxr = rows.vnx[i]
        nyr = rows.vny[i]
        nzr = rows.vnz[i]
        br = rows.vb[i]
        gr = rows.vg[i]
        ikr = rows.vik[i]
        pr = sol.grid_pv[i]
        ux = wk.UX[r1:r1 + ng]
        uy = wk.UY[r1:r1 + ng]
        uz = wk.UZ[r1:r1 + ng]
        xa = X[r0:r0 + ng]
        ya = Y[r0:r0 + ng]
        za = Z[r0:r0 + ng]
        xb = X[r1:r1 + ng]
        yb = Y[r1:r1 + ng]
        zb = Z[r1:r1 + ng]
        kd = rows.vkd[i]
        gd = rows.vgd[i]
        ikt = rows.vikt[i]
        iks = rows.viks[i]
        for j in range(ng):
            nx, ny, nz, b, g, ik = _grid_row(xb[j] - xa[j], yb[j] - ya[j], zb[j] - za[j],
                                             grid.rest, kd[j], gd[j], ikt[j], iks[j], inv_h)
            nxr[j] = nx
            nyr[j] = ny
            nzr[j] = nz
            br[j] = b
            gr[j] = g
            ikr[j] = ik
            ux[j] = -pr[j] * nx
            uy[j] = -pr[j] * ny
            uz[j] = -pr[j] * nz
    for m in range(links.pairs.shape[0]):
        wk.EF[m, 0] = 0.0
        wk.EF[m, 1] = 0.0
        wk.EF[m, 2] = 0.0
        a = links.pairs[m, 0]
        b_ = links.pairs[m, 1]
        if links.active[m] == 0:
            rows.lik[m] = 0.0
            sol.link_p[m] = 0.0
            continue
        nx, ny, nz, b, g, ik = _thread_row(X[b_] - X[a], Y[b_] - Y[a], Z[b_] - Z[a],
                                           links.rest[m], links.k[m], links.c[m], w[a] + w[b_], h)
        rows.lnx[m] = nx
        rows.lny[m] = ny
        rows.lnz[m] = nz
        rows.lb[m] = b
        rows.lg[m] = g
        rows.lik[m] = ik
        wk.EF[m, 0] = -sol.link_p[m] * nx
        wk.EF[m, 1] = -sol.link_p[m] * ny
        wk.EF[m, 2] = -sol.link_p[m] * nz


@njit(cache=True, inline='always', error_model='numpy')
def apply_gathered(wk, w):
    """v += w P for the per-body impulse sums in wk.FX.. (N s)."""
    for i in range(wk.VX.shape[0]):
        wk.VX[i] += w[i] * wk.FX[i]
        wk.VY[i] += w[i] * wk.FY[i]
        wk.VZ[i] += w[i] * wk.FZ[i]


@njit(cache=True, inline='always')
def _apply(wk, w, a, b, nx, ny, nz, dP):
    """Impulse dP along n on b and -dP on a (velocities, m/s)."""
    wk.VX[a] -= w[a] * nx * dP
    wk.VY[a] -= w[a] * ny * dP
    wk.VZ[a] -= w[a] * nz * dP
    wk.VX[b] += w[b] * nx * dP
    wk.VY[b] += w[b] * ny * dP
    wk.VZ[b] += w[b] * nz * dP


@njit(cache=True, inline='always')
def _solve_row(va_x, va_y, va_z, vb_x, vb_y, vb_z, wa, wb, nx, ny, nz, b, g, ik, pr, j, ja, jb):
    """One tension-only thread row between va[ja] and vb[jb] with impulse pr[j] (N s):
    the projected Gauss-Seidel update."""
    jv = nx * (vb_x[jb] - va_x[ja]) + ny * (vb_y[jb] - va_y[ja]) + nz * (vb_z[jb] - va_z[ja])
    P = pr[j]
    Pn = min(P - (jv + b + g * P) * ik, 0.0)
    pr[j] = Pn
    dP = Pn - P
    va_x[ja] -= wa[ja] * nx * dP
    va_y[ja] -= wa[ja] * ny * dP
    va_z[ja] -= wa[ja] * nz * dP
    vb_x[jb] += wb[jb] * nx * dP
    vb_y[jb] += wb[jb] * ny * dP
    vb_z[jb] += wb[jb] * nz * dP


@njit(cache=True, inline='always', error_model='numpy')
def sweep_grid(wk, rows, grid, w, sol):
    """One Gauss-Seidel sweep over the grid threads, colour by colour: x-threads of even,
    then odd columns; y-threads of even, then odd rows (threads of one colour share no
    node)."""
    ng = grid.n
    VX, VY, VZ = wk.VX, wk.VY, wk.VZ
    for colour in range(2):
        for i in range(ng):
            r0 = i * ng
            vx = VX[r0:r0 + ng]
            vy = VY[r0:r0 + ng]
            vz = VZ[r0:r0 + ng]
            wr = w[r0:r0 + ng]
            nxr = rows.hnx[i]
            nyr = rows.hny[i]
            nzr = rows.hnz[i]
            br = rows.hb[i]
            gr = rows.hg[i]
            ikr = rows.hik[i]
            pr = sol.grid_ph[i]
            for j in range(colour, ng - 1, 2):
                _solve_row(vx, vy, vz, vx, vy, vz, wr, wr, nxr[j], nyr[j], nzr[j], br[j], gr[j],
                           ikr[j], pr, j, j, j + 1)
    for colour in range(2):
        for i in range(colour, ng - 1, 2):
            r0 = i * ng
            r1 = r0 + ng
            va_x = VX[r0:r0 + ng]
            va_y = VY[r0:r0 + ng]
            va_z = VZ[r0:r0 + ng]
            vb_x = VX[r1:r1 + ng]
            vb_y = VY[r1:r1 + ng]
            vb_z = VZ[r1:r1 + ng]
            wa = w[r0:r0 + ng]
            wb = w[r1:r1 + ng]
            nxr = rows.vnx[i]
            nyr = rows.vny[i]
            nzr = rows.vnz[i]
            br = rows.vb[i]
            gr = rows.vg[i]
            ikr = rows.vik[i]
            pr = sol.grid_pv[i]
            for j in range(ng):
                _solve_row(va_x, va_y, va_z, vb_x, vb_y, vb_z, wa, wb, nxr[j], nyr[j], nzr[j],
                           br[j], gr[j], ikr[j], pr, j, j, j)


@njit(cache=True, inline='always', error_model='numpy')
def sweep_links(wk, rows, links, w, sol):
    """One Gauss-Seidel sweep over the other threads (corner threads, tether)."""
    VX, VY, VZ = wk.VX, wk.VY, wk.VZ
    for m in range(links.pairs.shape[0]):
        if rows.lik[m] == 0.0:
            continue
        _solve_row(VX, VY, VZ, VX, VY, VZ, w, w, rows.lnx[m], rows.lny[m], rows.lnz[m],
                   rows.lb[m], rows.lg[m], rows.lik[m], sol.link_p, m, links.pairs[m, 0],
                   links.pairs[m, 1])
