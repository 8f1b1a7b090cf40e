"""Target geometry for the kernels: the target's shape as one typed table
(:data:`TargetGeometry`), its signed distance by one dispatch on the shape's kind
(:func:`target_sdf`), the signed distance of solids of revolution, and the rotation
matrix of a quaternion.  Lengths in m, body frame (origin at the centre of mass, axes the
principal axes).
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .mesh_sdf import mesh_sdf

#: the shapes' kinds (TargetGeometry.kind is the index): a union of convex solids of
#: revolution about the body x axis, or a closed triangle mesh (``mesh_sdf``)
SHAPE_KINDS = ("revolution", "mesh")
SHAPE_REVOLUTION, SHAPE_MESH = 0, 1

#: The target's shape for the kernels.  kind: index into SHAPE_KINDS; extent (2,): the
#: half length along body x and the radius about it (m) of a cylinder about the CoM
#: enclosing the shape (the adaptive policy's prediction).  Revolution: cyl [axial centre,
#: half length, radius] (m) of the main cylinder, verts (V, 2) and offsets (S + 1,) the
#: other solids' meridional polygons.  Mesh (``mesh_sdf``): tris (T, 9) the triangles, pn
#: (T, 7, 3) their features' pseudonormals, the cell grid origin (3,), cell side (m), dims
#: (3,), per cell far (C,) a lower bound of the distance, start (C + 1,) into cand (K,)
#: and cdist (K,) the candidate triangles and their distance to the cell's centre; lo, hi
#: (3,) the mesh's box.  A kind's unused arrays are empty.
TargetGeometry = namedtuple("TargetGeometry", "kind extent cyl verts offsets tris pn origin cell "
                                              "dims far start cand cdist lo hi")


def revolution_geometry(cyl, verts, offsets) -> TargetGeometry:
    """The geometry of a union of solids of revolution (no mesh arrays)."""
    cyl = np.ascontiguousarray(cyl, dtype=np.float64)
    return TargetGeometry(
        kind=SHAPE_REVOLUTION, extent=np.array([cyl[1], cyl[2]]), cyl=cyl,
        verts=np.ascontiguousarray(verts, dtype=np.float64),
        offsets=np.ascontiguousarray(offsets, dtype=np.int64),
        tris=np.zeros((0, 9)), pn=np.zeros((0, 7, 3)), origin=np.zeros(3), cell=1.0,
        dims=np.zeros(3, dtype=np.int64), far=np.zeros(0), start=np.zeros(1, dtype=np.int64),
        cand=np.zeros(0, dtype=np.int32), cdist=np.zeros(0), lo=np.zeros(3), hi=np.zeros(3))


def mesh_geometry(extent, tris, pn, origin, cell, dims, far, start, cand, cdist, lo,
                  hi) -> TargetGeometry:
    """The geometry of a closed triangle mesh (no solids of revolution)."""
    f = np.float64
    return TargetGeometry(
        kind=SHAPE_MESH, extent=np.ascontiguousarray(extent, dtype=f), cyl=np.zeros(3),
        verts=np.zeros((0, 2)), offsets=np.zeros(1, dtype=np.int64),
        tris=np.ascontiguousarray(tris, dtype=f), pn=np.ascontiguousarray(pn, dtype=f),
        origin=np.ascontiguousarray(origin, dtype=f), cell=float(cell),
        dims=np.ascontiguousarray(dims, dtype=np.int64), far=np.ascontiguousarray(far, dtype=f),
        start=np.ascontiguousarray(start, dtype=np.int64),
        cand=np.ascontiguousarray(cand, dtype=np.int32), cdist=np.ascontiguousarray(cdist, dtype=f),
        lo=np.ascontiguousarray(lo, dtype=f), hi=np.ascontiguousarray(hi, dtype=f))


@njit(cache=True, inline='always', error_model='numpy')
def polygon_sdf(pa, pr, verts, start, stop):
    """Signed distance (m) of the 2D point (pa, pr) to the convex polygon
    verts[start:stop] and its gradient (ga, gr).  Negative inside."""
    d = (pa - verts[start, 0]) ** 2 + (pr - verts[start, 1]) ** 2
    ba = pa - verts[start, 0]
    br = pr - verts[start, 1]
    s = 1.0
    n = stop - start
    for k in range(n):
        i = start + k
        j = i - 1 if k > 0 else stop - 1
        ea = verts[j, 0] - verts[i, 0]
        er = verts[j, 1] - verts[i, 1]
        wa = pa - verts[i, 0]
        wr = pr - verts[i, 1]
        t = (wa * ea + wr * er) / (ea * ea + er * er)
        if t < 0.0:
            t = 0.0
        elif t > 1.0:
            t = 1.0
        qa = wa - ea * t
        qr = wr - er * t
        dd = qa * qa + qr * qr
        if dd < d:
            d = dd
            ba = qa
            br = qr
        c1 = pr >= verts[i, 1]
        c2 = pr < verts[j, 1]
        c3 = ea * wr > er * wa
        if (c1 and c2 and c3) or ((not c1) and (not c2) and (not c3)):
            s = -s
    dist = np.sqrt(d)
    if dist > 1e-14:
        ga = s * ba / dist
        gr = s * br / dist
    else:
        ga = 0.0
        gr = 1.0
    return s * dist, ga, gr


@njit(cache=True, inline='always', error_model='numpy')
def cylinder_sdf(pa, pr, cyl):
    """Signed distance (m) of the meridional point (pa, pr >= 0) to the cylinder
    cyl = [axial centre, half length, radius] and its gradient (ga, gr).  Written with
    |pa - centre| so that it is exactly mirror-symmetric about the mid-plane."""
    da = pa - cyl[0]
    sa = 1.0 if da >= 0.0 else -1.0
    qa = abs(da) - cyl[1]
    qr = pr - cyl[2]
    if qa > 0.0 and qr > 0.0:
        d = np.sqrt(qa * qa + qr * qr)
        return d, sa * qa / d, qr / d
    if qa > qr:
        return qa, sa, 0.0
    return qr, 0.0, 1.0


@njit(cache=True, inline='always', error_model='numpy')
def local_sdf(lx, ly, lz, cyl, verts, offsets):
    """Signed distance and outward unit normal (body frame) of a body-frame point to the
    union of the cylinder and the extra solids of revolution."""
    r = np.sqrt(ly * ly + lz * lz)
    if r > 1e-12:
        uy = ly / r
        uz = lz / r
    else:
        uy = 1.0
        uz = 0.0
    best, ga, gr = cylinder_sdf(lx, r, cyl)
    for p in range(offsets.shape[0] - 1):
        sd, pa_, pr_ = polygon_sdf(lx, r, verts, offsets[p], offsets[p + 1])
        if sd < best:
            best = sd
            ga = pa_
            gr = pr_
    return best, ga, gr * uy, gr * uz


@njit(cache=True, inline='always', error_model='numpy')
def target_sdf(lx, ly, lz, g):
    """Signed distance (m, negative inside) and outward unit normal (body frame) of the
    body-frame point (lx, ly, lz) to the target's shape g (:data:`TargetGeometry`); the one
    dispatch on the shape's kind."""
    if g.kind == SHAPE_MESH:
        return mesh_sdf(lx, ly, lz, g)
    return local_sdf(lx, ly, lz, g.cyl, g.verts, g.offsets)


@njit(cache=True, inline='always', error_model='numpy')
def lane_sdf(bx, by, bz, tg, l, g):
    """:func:`target_sdf` of lane l's body-frame point b (m, about its centre of mass),
    read in the shape's frame: at b + the lane's centre-of-mass offset
    (``data.TargetData.com_offset``)."""
    return target_sdf(bx + tg.com_offset[0, l], by + tg.com_offset[1, l],
                      bz + tg.com_offset[2, l], g)


@njit(cache=True)
def target_signed_distance(p_local, g):
    """Signed distance (m) of a body-frame point to the target's shape g and the outward
    normal."""
    sd, nx, ny, nz = target_sdf(p_local[0], p_local[1], p_local[2], g)
    return sd, np.array([nx, ny, nz])


@njit(cache=True)
def target_signed_distances(points, g):
    """Signed distances (N,) and outward normals (N, 3) of body-frame points (N, 3)."""
    n = points.shape[0]
    d = np.empty(n)
    nrm = np.empty((n, 3))
    for q in range(n):
        d[q], nrm[q, 0], nrm[q, 1], nrm[q, 2] = target_sdf(points[q, 0], points[q, 1],
                                                           points[q, 2], g)
    return d, nrm


@njit(cache=True)
def quat_to_matrix(q):
    """Rotation matrix of the unit quaternion q = (w, x, y, z) (body -> world)."""
    R = np.empty((3, 3))
    quat_to_matrix_into(q, R)
    return R


@njit(cache=True, inline='always')
def quat_to_matrix_into(q, R):
    w, x, y, z = q[0], q[1], q[2], q[3]
    R[0, 0] = 1 - 2 * (y * y + z * z)
    R[0, 1] = 2 * (x * y - w * z)
    R[0, 2] = 2 * (x * z + w * y)
    R[1, 0] = 2 * (x * y + w * z)
    R[1, 1] = 1 - 2 * (x * x + z * z)
    R[1, 2] = 2 * (y * z - w * x)
    R[2, 0] = 2 * (x * z - w * y)
    R[2, 1] = 2 * (y * z + w * x)
    R[2, 2] = 1 - 2 * (x * x + y * y)


@njit(cache=True, inline='always')
def quat_to_matrix_lane(q, R, lane):
    """R[:, :, lane] = rotation matrix of the unit quaternion q[:, lane] (w, x, y, z)."""
    w, x, y, z = q[0, lane], q[1, lane], q[2, lane], q[3, lane]
    R[0, 0, lane] = 1 - 2 * (y * y + z * z)
    R[0, 1, lane] = 2 * (x * y - w * z)
    R[0, 2, lane] = 2 * (x * z + w * y)
    R[1, 0, lane] = 2 * (x * y + w * z)
    R[1, 1, lane] = 1 - 2 * (x * x + z * z)
    R[1, 2, lane] = 2 * (y * z - w * x)
    R[2, 0, lane] = 2 * (x * z - w * y)
    R[2, 1, lane] = 2 * (y * z + w * x)
    R[2, 2, lane] = 1 - 2 * (x * x + y * y)
