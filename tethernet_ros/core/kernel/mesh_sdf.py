"""Signed distance of a point to a closed triangle mesh, the kernel's own (docs/model.md
§15, docs/studies/mesh-contact.md).

The query is exact: the least point-to-triangle distance over the triangles that can be
nearest, the sign that of (p - q) . n with q the nearest point and n the angle-weighted
pseudonormal of q's feature (vertex, edge or face; Baerentzen and Aanaes 2005: exact for
a closed, consistently oriented mesh).  The candidates come from a uniform grid of cubic
cells built once per mesh (:func:`build_cells`): each cell lists every triangle that can
be nearest to a point of the cell, sorted by its distance to the cell's centre, so that
the scan stops once no later candidate can be nearer.  Every point inside the mesh is
answered exactly.  A cell outside it and farther than the band from the surface lists
nothing and answers a lower bound of the distance; a point outside the cells answers
its distance to the mesh's box (a lower bound too).  Both bounds are only
ever read as "no contact" (their normals are not used), and they stay valid for the broad
phase (``broadphase``: a lower bound of a 1-Lipschitz function proves as much as it).

Only IEEE operations (+, -, *, /, sqrt) in a fixed order, and a stable sort: the same
triangles give the same bits on every machine.  Lengths in m.
"""
from __future__ import annotations

import numpy as np
from numba import njit

#: feature of a triangle's nearest point: vertex a, b, c; edge ab, ac, bc; the face
F_A, F_B, F_C, F_AB, F_AC, F_BC, F_FACE = range(7)


@njit(cache=True, inline='always', error_model='numpy')
def closest_on_triangle(px, py, pz, t):
    """Nearest point (qx, qy, qz) of the triangle t = (a, b, c) (9 floats, m) to p and its
    feature (``F_*``), by the Voronoi regions of the triangle (Ericson, Real-Time Collision
    Detection, 2005, section 5.1.5)."""
    ax, ay, az = t[0], t[1], t[2]
    abx, aby, abz = t[3] - ax, t[4] - ay, t[5] - az
    acx, acy, acz = t[6] - ax, t[7] - ay, t[8] - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return ax, ay, az, F_A
    bpx, bpy, bpz = px - t[3], py - t[4], pz - t[5]
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return t[3], t[4], t[5], F_B
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        return ax + v * abx, ay + v * aby, az + v * abz, F_AB
    cpx, cpy, cpz = px - t[6], py - t[7], pz - t[8]
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return t[6], t[7], t[8], F_C
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        return ax + w * acx, ay + w * acy, az + w * acz, F_AC
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return (t[3] + w * (t[6] - t[3]), t[4] + w * (t[7] - t[4]),
                t[5] + w * (t[8] - t[5]), F_BC)
    denom = 1.0 / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    return ax + abx * v + acx * w, ay + aby * v + acy * w, az + abz * v + acz * w, F_FACE


@njit(cache=True, inline='always', error_model='numpy')
def mesh_sdf(px, py, pz, g):
    """Signed distance (m, negative inside) of the body-frame point p to the mesh of the
    target geometry g (``geometry.TargetGeometry``) and the outward unit normal, or a lower
    bound of the distance where p is farther than g's band (normal then (0, 0, 1))."""
    c = g.cell
    ux = (px - g.origin[0]) / c
    uy = (py - g.origin[1]) / c
    uz = (pz - g.origin[2]) / c
    dims = g.dims
    if (ux < 0.0 or uy < 0.0 or uz < 0.0 or ux >= dims[0] or uy >= dims[1]
            or uz >= dims[2]):
        ex = max(g.lo[0] - px, 0.0, px - g.hi[0])
        ey = max(g.lo[1] - py, 0.0, py - g.hi[1])
        ez = max(g.lo[2] - pz, 0.0, pz - g.hi[2])
        return np.sqrt(ex * ex + ey * ey + ez * ez), 0.0, 0.0, 1.0
    ix, iy, iz = int(ux), int(uy), int(uz)
    cell = (ix * dims[1] + iy) * dims[2] + iz
    first = g.start[cell]
    last = g.start[cell + 1]
    if first == last:
        return g.far[cell], 0.0, 0.0, 1.0
    # a candidate whose distance to the cell's centre, less p's distance to it, exceeds
    # the best distance so far cannot be nearer (the lists are sorted by that distance)
    wx = px - (g.origin[0] + (ix + 0.5) * c)
    wy = py - (g.origin[1] + (iy + 0.5) * c)
    wz = pz - (g.origin[2] + (iz + 0.5) * c)
    rp = np.sqrt(wx * wx + wy * wy + wz * wz)
    d2 = 1e300
    qx, qy, qz = px, py, pz
    bt = 0
    bf = F_FACE
    for m in range(first, last):
        lb = g.cdist[m] - rp
        if lb > 0.0 and lb * lb >= d2:
            break
        t = g.cand[m]
        cx, cy, cz, f = closest_on_triangle(px, py, pz, g.tris[t])
        e = (px - cx) * (px - cx) + (py - cy) * (py - cy) + (pz - cz) * (pz - cz)
        if e < d2:
            d2 = e
            qx, qy, qz = cx, cy, cz
            bt = t
            bf = f
    pn = g.pn
    d = np.sqrt(d2)
    s = (px - qx) * pn[bt, bf, 0] + (py - qy) * pn[bt, bf, 1] + (pz - qz) * pn[bt, bf, 2]
    sg = 1.0 if s >= 0.0 else -1.0
    if d > 1e-12:
        return sg * d, sg * (px - qx) / d, sg * (py - qy) / d, sg * (pz - qz) / d
    return 0.0, pn[bt, F_FACE, 0], pn[bt, F_FACE, 1], pn[bt, F_FACE, 2]


@njit(cache=True, error_model='numpy')
def build_cells(origin, cell, dims, band, tris, pn):
    """The cell lists of the triangles tris (T, 9) (m), pseudonormals pn (T, 7, 3), on the
    grid of ``dims`` cubic cells of side ``cell`` from ``origin``: per cell the exact
    unsigned distance u of its centre to the mesh; when the centre is inside the mesh or
    u - rho <= band (rho the cell's half diagonal), every triangle within u + 2 rho of the
    centre (any triangle nearest to a point of the cell is among them), sorted by that
    distance (stable: ties by index); else none, and the lower bound u - rho (the cell is
    outside).  Every point inside the mesh is thus answered exactly.  Returns (far (C,),
    start (C + 1,), cand (K,) int32, cdist (K,)).  Brute force over the triangles in a
    fixed order: O(cells x triangles)."""
    ncell = dims[0] * dims[1] * dims[2]
    rho = 0.5 * cell * np.sqrt(3.0)
    far = np.zeros(ncell)
    counts = np.zeros(ncell + 1, dtype=np.int64)
    dist = np.empty(tris.shape[0])
    lists_t = []
    lists_d = []
    for i in range(dims[0]):
        for j in range(dims[1]):
            for k in range(dims[2]):
                cid = (i * dims[1] + j) * dims[2] + k
                px = origin[0] + (i + 0.5) * cell
                py = origin[1] + (j + 0.5) * cell
                pz = origin[2] + (k + 0.5) * cell
                u = 1e300
                side = 1.0
                for t in range(tris.shape[0]):
                    cx, cy, cz, f = closest_on_triangle(px, py, pz, tris[t])
                    dist[t] = np.sqrt((px - cx) * (px - cx) + (py - cy) * (py - cy)
                                      + (pz - cz) * (pz - cz))
                    if dist[t] < u:
                        u = dist[t]
                        side = ((px - cx) * pn[t, f, 0] + (py - cy) * pn[t, f, 1]
                                + (pz - cz) * pn[t, f, 2])
                if side >= 0.0 and u - rho > band:
                    far[cid] = u - rho
                    continue
                order = np.argsort(dist, kind="mergesort")
                for t in order:
                    if dist[t] > u + 2.0 * rho:
                        break
                    lists_t.append(t)
                    lists_d.append(dist[t])
                    counts[cid + 1] += 1
    start = np.cumsum(counts)
    cand = np.empty(len(lists_t), dtype=np.int32)
    cdist = np.empty(len(lists_t))
    for m in range(len(lists_t)):
        cand[m] = lists_t[m]
        cdist[m] = lists_d[m]
    return far, start, cand, cdist
