"""Tension-only Kelvin-Voigt threads: F = k C + c dC/dt along the thread while it is
stretched (C > 0) and F > 0 (a thread never pushes, not even through its damper).

The grid threads are computed branch-free on the structure-of-arrays state (row views
indexed by the loop counter, so numba needs no negative-index wrap-around and LLVM
vectorises the loops); the other threads (corner threads, tether) one by one.  Forces in N.
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline='always', error_model='numpy')
def grid_thread_forces(wk, grid):
    """Force of every grid thread on its first end, into wk.HX.. (x-threads) and wk.UX..
    (y-threads)."""
    ng = grid.n
    X, Y, Z, VX, VY, VZ = wk.X, wk.Y, wk.Z, wk.VX, wk.VY, wk.VZ
    grid_rest = grid.rest
    for i in range(ng):
        r0 = i * ng
        rx_ = X[r0:r0 + ng]
        ry_ = Y[r0:r0 + ng]
        rz_ = Z[r0:r0 + ng]
        rvx = VX[r0:r0 + ng]
        rvy = VY[r0:r0 + ng]
        rvz = VZ[r0:r0 + ng]
        kk = grid.kh[i]
        cc = grid.ch[i]
        h0 = i * (ng + 1)
        hx = wk.HX[h0:h0 + ng + 1]
        hy = wk.HY[h0:h0 + ng + 1]
        hz = wk.HZ[h0:h0 + ng + 1]
        for j in range(ng - 1):
            dx = rx_[j + 1] - rx_[j]
            dy = ry_[j + 1] - ry_[j]
            dz = rz_[j + 1] - rz_[j]
            length = np.sqrt(dx * dx + dy * dy + dz * dz)
            C = length - grid_rest
            inv = 1.0 / max(length, 1e-12)
            cdot = (dx * (rvx[j + 1] - rvx[j]) + dy * (rvy[j + 1] - rvy[j]) + dz * (rvz[j + 1] - rvz[j])) * inv
            F = kk[j] * C + cc[j] * cdot
            F = F if C > 0.0 else 0.0
            F = F if F > 0.0 else 0.0       # a thread never pushes, not even its damper
            s_ = F * inv
            hx[j + 1] = s_ * dx
            hy[j + 1] = s_ * dy
            hz[j + 1] = s_ * dz
    for i in range(ng - 1):
        r0 = i * ng
        r1 = r0 + ng
        xa = X[r0:r0 + ng]
        ya = Y[r0:r0 + ng]
        za = Z[r0:r0 + ng]
        vxa = VX[r0:r0 + ng]
        vya = VY[r0:r0 + ng]
        vza = VZ[r0:r0 + ng]
        xb = X[r1:r1 + ng]
        yb = Y[r1:r1 + ng]
        zb = Z[r1:r1 + ng]
        vxb = VX[r1:r1 + ng]
        vyb = VY[r1:r1 + ng]
        vzb = VZ[r1:r1 + ng]
        kk = grid.kv[i]
        cc = grid.cv[i]
        ux = wk.UX[r1:r1 + ng]
        uy = wk.UY[r1:r1 + ng]
        uz = wk.UZ[r1:r1 + ng]
        for j in range(ng):
            dx = xb[j] - xa[j]
            dy = yb[j] - ya[j]
            dz = zb[j] - za[j]
            length = np.sqrt(dx * dx + dy * dy + dz * dz)
            C = length - grid_rest
            inv = 1.0 / max(length, 1e-12)
            cdot = (dx * (vxb[j] - vxa[j]) + dy * (vyb[j] - vya[j]) + dz * (vzb[j] - vza[j])) * inv
            F = kk[j] * C + cc[j] * cdot
            F = F if C > 0.0 else 0.0
            F = F if F > 0.0 else 0.0
            s_ = F * inv
            ux[j] = s_ * dx
            uy[j] = s_ * dy
            uz[j] = s_ * dz


@njit(cache=True, inline='always', error_model='numpy')
def link_forces(wk, links):
    """Force of every active other thread on its first end, into wk.EF."""
    X, Y, Z, VX, VY, VZ, EF = wk.X, wk.Y, wk.Z, wk.VX, wk.VY, wk.VZ, wk.EF
    link_rest = links.rest
    for m in range(links.pairs.shape[0]):
        EF[m, 0] = 0.0
        EF[m, 1] = 0.0
        EF[m, 2] = 0.0
        if links.active[m] == 0:
            continue
        i = links.pairs[m, 0]
        j = links.pairs[m, 1]
        dx = X[j] - X[i]
        dy = Y[j] - Y[i]
        dz = Z[j] - Z[i]
        len2 = dx * dx + dy * dy + dz * dz
        if len2 <= link_rest[m] * link_rest[m] or len2 < 1e-28:
            continue
        length = np.sqrt(len2)
        inv = 1.0 / length
        cdot = (dx * (VX[j] - VX[i]) + dy * (VY[j] - VY[i]) + dz * (VZ[j] - VZ[i])) * inv
        F = links.k[m] * (length - link_rest[m]) + links.c[m] * cdot
        if F <= 0.0:
            continue
        EF[m, 0] = F * inv * dx
        EF[m, 1] = F * inv * dy
        EF[m, 2] = F * inv * dz


@njit(cache=True, inline='always', error_model='numpy')
def gather_thread_forces(wk, grid, links):
    """Sum the thread forces per body into wk.FX.. (overwriting them) in a mirror-invariant
    order: (left + right) + (down + up) for grid nodes, each pair's sum commutative, then
    the other threads through each body's slots."""
    ng = grid.n
    N = wk.X.shape[0]
    FX, FY, FZ, EF = wk.FX, wk.FY, wk.FZ, wk.EF
    for i in range(ng):
        r0 = i * ng
        h0 = i * (ng + 1)
        fx = FX[r0:r0 + ng]
        fy = FY[r0:r0 + ng]
        fz = FZ[r0:r0 + ng]
        hx = wk.HX[h0:h0 + ng + 1]
        hy = wk.HY[h0:h0 + ng + 1]
        hz = wk.HZ[h0:h0 + ng + 1]
        dxu = wk.UX[r0:r0 + ng]
        dyu = wk.UY[r0:r0 + ng]
        dzu = wk.UZ[r0:r0 + ng]
        uxu = wk.UX[r0 + ng:r0 + 2 * ng]
        uyu = wk.UY[r0 + ng:r0 + 2 * ng]
        uzu = wk.UZ[r0 + ng:r0 + 2 * ng]
        for j in range(ng):
            fx[j] = (hx[j + 1] - hx[j]) + (uxu[j] - dxu[j])
            fy[j] = (hy[j + 1] - hy[j]) + (uyu[j] - dyu[j])
            fz[j] = (hz[j + 1] - hz[j]) + (uzu[j] - dzu[j])
    for a in range(ng * ng, N):
        FX[a] = 0.0
        FY[a] = 0.0
        FZ[a] = 0.0
    node_links = links.node_links
    node_sign = links.node_sign
    for a in range(N):
        m0 = node_links[a, 0]
        m1 = node_links[a, 1]
        if m0 < 0 and m1 < 0:
            continue
        ex = 0.0
        ey = 0.0
        ez = 0.0
        if m0 >= 0:
            sg = node_sign[a, 0]
            ex = sg * EF[m0, 0]
            ey = sg * EF[m0, 1]
            ez = sg * EF[m0, 2]
        if m1 >= 0:
            sg = node_sign[a, 1]
            ex += sg * EF[m1, 0]
            ey += sg * EF[m1, 1]
            ez += sg * EF[m1, 2]
        FX[a] += ex
        FY[a] += ey
        FZ[a] += ez
