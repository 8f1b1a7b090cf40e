"""Mesh targets for the contact kernels: candidate signed-distance queries, measured
(docs/studies/mesh-contact.md, issue 34 points 2-3).

    .venv/bin/python benchmarks/bench_mesh_contact.py [--quick] [--grid-steps 0.4,0.2,0.1,0.05]
        [--points N] [--coacd-threshold 0.05] [--json out.json] [--export DIR]

Builds two test meshes from dimensions with trimesh: the Zenit-2 second stage of
core/target.py (cylinder 3.9 m x 10.4 m and the 2 m nozzle frustum, as one revolved
watertight mesh, body frame about the centre of mass) with and without a synthetic thin
aft skirt around the nozzle, and an Envisat-like body (10 x 4 x 4 m box, a 2 m boom and a
14 x 5 m solar array 3 cm thick, 26 m overall; a manifold union of three boxes).

Candidate queries, in numba, one point at a time as a kernel would call them (signed
distance, negative inside, and the outward unit normal):

- ``planes``: union of convex polytopes, each part's signed distance taken as the largest
  of its face planes' distances (exact inside a part, a lower bound outside, off by up to
  d (1 - cos(theta/2)) beside an edge of dihedral opening theta);
- ``exact``: the same union, exact outside each part: the least point-to-triangle distance
  over the part's faces that face the point (the nearest point of a convex polytope lies on
  such a face); inside, the plane value (exact for a convex part);
- ``grid``: a signed-distance grid of step h sampled from the exact mesh distance,
  trilinear, with the trilinear gradient normalised; outside the grid the value at the
  nearest grid point plus the distance to it.

Parts: the file's own (the primitives the mesh was made of, each convex) and coacd's
decomposition of the single watertight mesh.  Reference: igl.signed_distance (exact
point-to-triangle distance, winding-number sign) on the watertight mesh; points drawn
uniformly in the bounding box grown by 0.6 m, kept where |sd| <= 0.5 m.

Also: the analytic kernel's distance (core/kernel/geometry.py ``local_sdf``) timed on the
same points, one nominal episode's count of exact contact tests, coacd's determinism
(two runs compared byte for byte), trimesh's mass properties against an IEEE-only
divergence-theorem sum (math.fsum), and the mesh file formats reloaded bit for bit.
CPU time (``time.process_time``) on one thread.  Prints tables; no asserts.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
os.environ.setdefault("OMP_NUM_THREADS", "1")   # coacd / igl on one thread

NEEDED = (("trimesh", "trimesh"), ("numba", "numba"), ("scipy", "scipy"), ("igl", "libigl"),
          ("coacd", "coacd"), ("manifold3d", "manifold3d"), ("rtree", "rtree"))


def missing_modules() -> list[str]:
    out = []
    for mod, pkg in NEEDED:
        try:
            __import__(mod)
        except ImportError:
            out.append(pkg)
    return out


# ---------------------------------------------------------------------------------------
# test meshes
# ---------------------------------------------------------------------------------------
ZENIT = dict(R=1.95, L=10.4, h=2.0, r0=0.5, r1=1.0)       # core/target.py defaults
SKIRT = dict(length=1.5, wall=0.03)                         # synthetic thin aft skirt
# Envisat-like: ESA's figures are 26 m x 10 m x 5 m in orbit, a 14 m x 5 m solar array;
# the main body is taken as 10 x 4 x 4 m and the array 3 cm thick on a 2 m boom.
ENVISAT = dict(body=((0.0, -2.0, -2.0), (10.0, 2.0, 2.0)),
               boom=((10.0, -0.15, -0.15), (12.0, 0.15, 0.15)),
               array=((12.0, -2.5, -0.015), (26.0, 2.5, 0.015)))


def zenit_mesh(sections: int = 128, skirt: bool = False):
    """The Zenit-2 stage of core/target.py (nozzle on) as one revolved watertight mesh,
    axis x, origin at the analytic target's centre of mass; and its convex parts (the
    cylinder and the frustum) when there is no skirt."""
    import numpy as np
    import trimesh

    from tethernet_ros.core.shapes import target_shape
    from tethernet_ros.core.target import TargetConfig

    z = ZENIT
    R, L, h, r0, r1 = z["R"], z["L"], z["h"], z["r0"], z["r1"]
    prof = [(0.0, L / 2), (R, L / 2), (R, -L / 2)]
    if skirt:
        s, w = SKIRT["length"], SKIRT["wall"]
        prof += [(R, -L / 2 - s), (R - w, -L / 2 - s), (R - w, -L / 2)]
    prof += [(r0, -L / 2), (r1, -L / 2 - h), (0.0, -L / 2 - h)]
    prof = np.array(prof[::-1])            # axis -> axis, counter-clockwise in (r, z)

    def revolve(p):
        m = trimesh.creation.revolve(p, sections=sections)
        m.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [0, 1, 0]))
        return m

    def to_body(m):
        # rotation z -> x maps the axial coordinate z to +x: (x, y, z) = (z, y, -x)
        m.apply_translation([-target_shape(TargetConfig(nozzle=True)).com_offset, 0.0, 0.0])
        return m

    mesh = to_body(revolve(prof))
    parts = None
    if not skirt:
        cyl = np.array([(0.0, -L / 2), (R, -L / 2), (R, L / 2), (0.0, L / 2)])
        fr = np.array([(0.0, -L / 2 - h), (r1, -L / 2 - h), (r0, -L / 2), (0.0, -L / 2)])
        parts = [to_body(revolve(cyl)), to_body(revolve(fr))]
    return mesh, parts


def envisat_mesh():
    """The Envisat-like body as one watertight mesh (manifold union of three boxes) and
    its three boxes as the file's parts."""
    import trimesh

    boxes = [trimesh.creation.box(bounds=b) for b in ENVISAT.values()]
    union = trimesh.boolean.union(boxes, engine="manifold")
    return union, boxes


# ---------------------------------------------------------------------------------------
# numba queries
# ---------------------------------------------------------------------------------------
def build_kernels():
    import numpy as np
    from numba import njit

    # the kernel's own (core/kernel/mesh_sdf.py): features 0-2 vertex a, b, c, 3-5 edges
    # ab, ac, bc, 6 the face
    from tethernet_ros.core.kernel.mesh_sdf import closest_on_triangle

    @njit(cache=True, inline="always", error_model="numpy")
    def hull_sdf(px, py, pz, planes, poff, tris, tpl, toff, sph, exact):
        """Signed distance and outward normal of p to the union of convex parts.
        planes (P, 4): n, d with n.p - d the plane's signed distance; part k's planes
        poff[k]:poff[k+1]; tris (T, 9) its faces toff[k]:toff[k+1], tpl (T,) the plane of
        each face; sph (K, 4) a bounding sphere per part (culling)."""
        best = 1e300
        gx, gy, gz = 0.0, 0.0, 1.0
        for k in range(sph.shape[0]):
            dx = px - sph[k, 0]
            dy = py - sph[k, 1]
            dz = pz - sph[k, 2]
            if np.sqrt(dx * dx + dy * dy + dz * dz) - sph[k, 3] >= best:
                continue
            m = -1e300
            arg = poff[k]
            for j in range(poff[k], poff[k + 1]):
                s = planes[j, 0] * px + planes[j, 1] * py + planes[j, 2] * pz - planes[j, 3]
                if s > m:
                    m = s
                    arg = j
            if m <= 0.0 or not exact:
                if m < best:
                    best = m
                    gx, gy, gz = planes[arg, 0], planes[arg, 1], planes[arg, 2]
                continue
            if m >= best:
                continue
            d2 = 1e300
            qx, qy, qz = px, py, pz
            for t in range(toff[k], toff[k + 1]):
                j = tpl[t]
                s = planes[j, 0] * px + planes[j, 1] * py + planes[j, 2] * pz - planes[j, 3]
                if s <= 0.0 or s * s >= d2:
                    continue
                cx, cy, cz, _ = closest_on_triangle(px, py, pz, tris[t])
                e = (px - cx) ** 2 + (py - cy) ** 2 + (pz - cz) ** 2
                if e < d2:
                    d2 = e
                    qx, qy, qz = cx, cy, cz
            d = np.sqrt(d2)
            if d < best:
                best = d
                gx, gy, gz = (px - qx) / d, (py - qy) / d, (pz - qz) / d
        return best, gx, gy, gz

    @njit(cache=True, inline="always", error_model="numpy")
    def grid_sdf(px, py, pz, g, org, h):
        """Trilinear signed distance of the grid g (nx, ny, nz) with origin org and step
        h, and its normalised gradient; outside the grid the clamped value plus the
        distance to the clamped point."""
        nx, ny, nz = g.shape[0], g.shape[1], g.shape[2]
        ux = (px - org[0]) / h
        uy = (py - org[1]) / h
        uz = (pz - org[2]) / h
        ex = 0.0
        ey = 0.0
        ez = 0.0
        if ux < 0.0:
            ex = ux * h
            ux = 0.0
        elif ux > nx - 1:
            ex = (ux - (nx - 1)) * h
            ux = nx - 1.0
        if uy < 0.0:
            ey = uy * h
            uy = 0.0
        elif uy > ny - 1:
            ey = (uy - (ny - 1)) * h
            uy = ny - 1.0
        if uz < 0.0:
            ez = uz * h
            uz = 0.0
        elif uz > nz - 1:
            ez = (uz - (nz - 1)) * h
            uz = nz - 1.0
        i = min(int(ux), nx - 2)
        j = min(int(uy), ny - 2)
        k = min(int(uz), nz - 2)
        fx = ux - i
        fy = uy - j
        fz = uz - k
        c000 = g[i, j, k]
        c100 = g[i + 1, j, k]
        c010 = g[i, j + 1, k]
        c110 = g[i + 1, j + 1, k]
        c001 = g[i, j, k + 1]
        c101 = g[i + 1, j, k + 1]
        c011 = g[i, j + 1, k + 1]
        c111 = g[i + 1, j + 1, k + 1]
        c00 = c000 + (c100 - c000) * fx
        c10 = c010 + (c110 - c010) * fx
        c01 = c001 + (c101 - c001) * fx
        c11 = c011 + (c111 - c011) * fx
        c0 = c00 + (c10 - c00) * fy
        c1 = c01 + (c11 - c01) * fy
        val = c0 + (c1 - c0) * fz
        gz_ = c1 - c0
        gy_ = (c10 - c00) * (1.0 - fz) + (c11 - c01) * fz
        a0 = (c100 - c000) * (1.0 - fy) + (c110 - c010) * fy
        a1 = (c101 - c001) * (1.0 - fy) + (c111 - c011) * fy
        gx_ = a0 * (1.0 - fz) + a1 * fz
        e2 = ex * ex + ey * ey + ez * ez
        if e2 > 0.0:
            e = np.sqrt(e2)
            return val + e, ex / e, ey / e, ez / e
        n = np.sqrt(gx_ * gx_ + gy_ * gy_ + gz_ * gz_)
        if n > 1e-300:
            return val, gx_ / n, gy_ / n, gz_ / n
        return val, 0.0, 0.0, 1.0

    @njit(cache=True, error_model="numpy")
    def run_hull(P, planes, poff, tris, tpl, toff, sph, exact, out, nrm):
        for q in range(P.shape[0]):
            d, a, b, c = hull_sdf(P[q, 0], P[q, 1], P[q, 2], planes, poff, tris, tpl, toff,
                                  sph, exact)
            out[q] = d
            nrm[q, 0] = a
            nrm[q, 1] = b
            nrm[q, 2] = c

    @njit(cache=True, error_model="numpy")
    def run_grid(P, g, org, h, out, nrm):
        for q in range(P.shape[0]):
            d, a, b, c = grid_sdf(P[q, 0], P[q, 1], P[q, 2], g, org, h)
            out[q] = d
            nrm[q, 0] = a
            nrm[q, 1] = b
            nrm[q, 2] = c

    # the cells query and its build are the kernel's (core/kernel/mesh_sdf.py)
    from tethernet_ros.core.kernel.geometry import mesh_geometry, target_signed_distances
    from tethernet_ros.core.kernel.mesh_sdf import build_cells

    def cell_build(org, c, dims, band, tris, pn):
        return build_cells(org, c, dims, band, tris, pn)

    def run_cell(P, org, c, dims, far, start, cand, cdist, tris, pn, lo, hi, out, nrm):
        g = mesh_geometry(np.zeros(2), tris, pn, org, c, dims, far, start, cand, cdist, lo, hi)
        d, n = target_signed_distances(P, g)
        out[:] = d
        nrm[:] = n

    from tethernet_ros.core.kernel.geometry import local_sdf

    @njit(cache=True, error_model="numpy")
    def run_analytic(P, cyl, verts, offsets, out, nrm):
        for q in range(P.shape[0]):
            d, a, b, c = local_sdf(P[q, 0], P[q, 1], P[q, 2], cyl, verts, offsets)
            out[q] = d
            nrm[q, 0] = a
            nrm[q, 1] = b
            nrm[q, 2] = c

    return run_hull, run_grid, run_analytic, cell_build, run_cell


# ---------------------------------------------------------------------------------------
# packing, reference, sampling
# ---------------------------------------------------------------------------------------
def pack_parts(parts):
    """Convex hulls of the parts -> (planes, poff, tris, tpl, toff, sph), in part order.
    Coplanar faces of a hull share one plane (trimesh facets)."""
    import numpy as np

    planes, poff, tris, tpl, toff, sph = [], [0], [], [], [0], []
    for part in parts:
        hull = part.convex_hull
        plane_of = np.full(len(hull.faces), -1, dtype=np.int64)
        for f, n, o in zip(hull.facets, hull.facets_normal, hull.facets_origin):
            plane_of[f] = len(planes)
            planes.append((*n, float(np.dot(n, o))))
        for fi in np.nonzero(plane_of < 0)[0]:
            n = hull.face_normals[fi]
            plane_of[fi] = len(planes)
            planes.append((*n, float(np.dot(n, hull.triangles[fi, 0]))))
        tris.extend(hull.triangles.reshape(-1, 9))
        tpl.extend(plane_of)
        poff.append(len(planes))
        toff.append(len(tris))
        c = 0.5 * (hull.bounds[0] + hull.bounds[1])
        sph.append((*c, float(np.sqrt(((hull.vertices - c) ** 2).sum(axis=1)).max()) * (1 + 1e-12)))
    f = np.float64
    return (np.ascontiguousarray(planes, dtype=f), np.array(poff, dtype=np.int64),
            np.ascontiguousarray(tris, dtype=f), np.array(tpl, dtype=np.int64),
            np.array(toff, dtype=np.int64), np.ascontiguousarray(sph, dtype=f))


def pseudonormals(mesh):
    """(T, 7, 3): per triangle the angle-weighted pseudonormals of its vertices a, b, c,
    of its edges ab, ac, bc (sum of the two faces' normals) and its face normal, unit
    length (Baerentzen and Aanaes: the sign of (p - q) . n at the nearest feature is the
    sign of the signed distance of a closed mesh)."""
    import numpy as np

    F = np.asarray(mesh.faces)
    fn = np.asarray(mesh.face_normals, dtype=np.float64)
    vn = np.zeros((len(mesh.vertices), 3))
    np.add.at(vn, F.ravel(), (np.asarray(mesh.face_angles)[:, :, None] * fn[:, None, :])
              .reshape(-1, 3))
    edge = {}
    for t, (a, b, c) in enumerate(F):
        for u, v in ((a, b), (a, c), (b, c)):
            key = (min(u, v), max(u, v))
            edge[key] = edge.get(key, 0.0) + fn[t]
    pn = np.empty((len(F), 7, 3))
    for t, (a, b, c) in enumerate(F):
        pn[t, 0], pn[t, 1], pn[t, 2] = vn[a], vn[b], vn[c]
        for r, (u, v) in zip((3, 4, 5), ((a, b), (a, c), (b, c))):
            pn[t, r] = edge[(min(u, v), max(u, v))]
        pn[t, 6] = fn[t]
    pn /= np.linalg.norm(pn, axis=2, keepdims=True)
    return np.ascontiguousarray(pn)


def reference(mesh, P):
    """Exact signed distance (igl, winding-number sign) and the unit normal to p."""
    import igl
    import numpy as np

    S, _, C, _ = igl.signed_distance(P, np.asarray(mesh.vertices, dtype=np.float64),
                                     np.asarray(mesh.faces, dtype=np.int64),
                                     sign_type=igl.SIGNED_DISTANCE_TYPE_WINDING_NUMBER)
    v = P - C
    n = np.linalg.norm(v, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        g = np.sign(S)[:, None] * v / n[:, None]
    return S, g


def band_points(mesh, n, band=0.5, seed=1):
    """About n points uniform in the bounding box grown by 0.6 m with |sd| <= band."""
    import numpy as np

    rng = np.random.default_rng(seed)
    lo, hi = mesh.bounds[0] - 0.6, mesh.bounds[1] + 0.6
    keep = []
    got = 0
    while got < n:
        P = lo + (hi - lo) * rng.random((max(n, 20000), 3))
        S, G = reference(mesh, P)
        m = np.abs(S) <= band
        keep.append((P[m], S[m], G[m]))
        got += int(m.sum())
    P = np.concatenate([k[0] for k in keep])[:n]
    S = np.concatenate([k[1] for k in keep])[:n]
    G = np.concatenate([k[2] for k in keep])[:n]
    return np.ascontiguousarray(P), S, G


def timed(fn, *args, reps=3):
    best = 1e300
    for _ in range(reps):
        t0 = time.process_time()
        fn(*args)
        best = min(best, time.process_time() - t0)
    return best


def err_stats(d, S, nrm, G, mask=None):
    import numpy as np

    if mask is not None:
        d, S, nrm, G = d[mask], S[mask], nrm[mask], G[mask]
    e = np.abs(d - S)
    sign = int(np.sum((d < 0) != (S < 0)))
    cosang = np.clip(np.sum(nrm * G, axis=1), -1.0, 1.0)
    ok = np.isfinite(cosang)
    ang = np.degrees(np.arccos(cosang[ok]))
    return dict(n=int(len(e)), median=float(np.median(e)), p99=float(np.quantile(e, 0.99)),
                max=float(e.max()), sign_errors=sign, angle_p50=float(np.median(ang)),
                angle_p99=float(np.quantile(ang, 0.99)))


def fmt(x):
    return f"{x:.2e}" if x != 0 else "0"


# ---------------------------------------------------------------------------------------
# the measurements
# ---------------------------------------------------------------------------------------
def measure_case(name, mesh, parts, kernels, args, rows, coacd_parts=None, thin=None,
                 analytic=None):
    """Every method on one mesh; rows gets one dict per method."""
    import numpy as np

    run_hull, run_grid, run_analytic, cell_build, run_cell = kernels
    t0 = time.process_time()
    P, S, G = band_points(mesh, args.points)
    t_ref = time.process_time() - t0
    print(f"\n== {name}: {len(mesh.faces)} faces, {len(P)} band points "
          f"(reference igl: {t_ref:.1f} s CPU incl. rejection sampling)")
    out = np.empty(len(P))
    nrm = np.empty((len(P), 3))
    masks = {"all": None, "outside": S > 0}
    if thin is not None:
        masks["thin"] = thin(P)

    def record(method, build_s, mem, fn, fargs):
        fn(*fargs)                                   # compile / warm
        t = timed(fn, *fargs)
        qps = len(P) / t
        row = dict(case=name, method=method, build_s=build_s, mem_bytes=int(mem),
                   qps=qps, ns_per_query=1e9 / qps)
        for mk, m in masks.items():
            row[mk] = err_stats(out, S, nrm, G, m)
        rows.append(row)
        a = row["all"]
        o = row["outside"]
        extra = f" | outside p99 {fmt(o['p99'])} max {fmt(o['max'])}"
        if "thin" in row:
            extra += (f" | thin part: p99 {fmt(row['thin']['p99'])} max {fmt(row['thin']['max'])}"
                     f" sign err {row['thin']['sign_errors']}/{row['thin']['n']}")
        print(f"{method:<26} build {build_s:7.2f} s  mem {mem / 1e6:8.3f} MB  "
              f"{qps / 1e6:6.2f} Mq/s ({1e9 / qps:6.0f} ns)  err p50 {fmt(a['median'])} "
              f"p99 {fmt(a['p99'])} max {fmt(a['max'])}  sign err {a['sign_errors']}  "
              f"normal p50/p99 {a['angle_p50']:.2f}/{a['angle_p99']:.1f} deg{extra}")

    if analytic is not None:
        cyl, verts, offsets = analytic
        record("analytic local_sdf", 0.0, cyl.nbytes + verts.nbytes + offsets.nbytes,
               run_analytic, (P, cyl, verts, offsets, out, nrm))
    for label, pl in (("file parts", parts), ("coacd parts", coacd_parts)):
        if pl is None:
            continue
        t0 = time.process_time()
        packed = pack_parts(pl)
        t_pack = time.process_time() - t0
        mem = sum(a.nbytes for a in packed)
        tag = f"{label} ({len(pl)}, {len(packed[0])} pl, {len(packed[2])} tri)"
        for exact in (False, True):
            record(f"{tag} {'exact' if exact else 'planes'}", t_pack, mem, run_hull,
                   (P, *packed, exact, out, nrm))
    tris = np.ascontiguousarray(mesh.triangles.reshape(-1, 9), dtype=np.float64)
    for c in args.cell_sizes:
        t0 = time.process_time()
        pn = pseudonormals(mesh)
        blo, bhi = mesh.bounds[0].astype(np.float64), mesh.bounds[1].astype(np.float64)
        pad = args.band + c
        org = np.ascontiguousarray(blo - pad)
        dims = np.ceil((bhi + pad - org) / c).astype(np.int64)
        far, start, cand, cdist = cell_build(org, float(c), dims, float(args.band), tris, pn)
        t_build = time.process_time() - t0
        lens = np.diff(start)
        near = lens[lens > 0]
        mem = far.nbytes + start.nbytes + cand.nbytes + cdist.nbytes + tris.nbytes + pn.nbytes
        record(f"cells c={c} m (list {near.mean():.1f} avg, {near.max()} max)", t_build, mem,
               run_cell, (P, org, float(c), dims, far, start, cand, cdist, tris, pn, blo, bhi,
                          out, nrm))
    lo, hi = mesh.bounds[0] - 0.6, mesh.bounds[1] + 0.6
    for h in args.grid_steps:
        n = np.ceil((hi - lo) / h).astype(int) + 1
        if np.prod(n) > args.max_grid_nodes:
            print(f"grid h={h} m: {int(np.prod(n))} nodes ({np.prod(n) * 8 / 1e6:.0f} MB) "
                  f"over --max-grid-nodes, skipped")
            continue
        t0 = time.process_time()
        axes = [lo[i] + h * np.arange(n[i]) for i in range(3)]
        X = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        vals = np.empty(len(X))
        for s in range(0, len(X), 1_000_000):
            vals[s:s + 1_000_000] = reference(mesh, X[s:s + 1_000_000])[0]
        g = np.ascontiguousarray(vals.reshape(n))
        t_build = time.process_time() - t0
        record(f"grid h={h} m {tuple(int(v) for v in n)}", t_build, g.nbytes, run_grid,
               (P, g, np.ascontiguousarray(lo, dtype=np.float64), float(h), out, nrm))
    return P, S


def plate_sweep(kernels, steps, thickness=0.03, radius=0.002):
    """Does a grid keep a plate of the given thickness?  Plate |z| <= t/2 (infinite in x,
    y; exact node values), the grid's origin shifted through one step: the least
    trilinear value across the plate (negative: the plate is still solid there) and the
    largest (worst offset), against a node's contact radius."""
    import numpy as np

    run_grid = kernels[1]
    lines = [f"plate {thickness * 100:.0f} cm thick, grid sampled from its exact distance, "
             f"origin shifted over one step (16 offsets); a body of radius {radius * 1e3:.0f} mm "
             "feels it where the value < radius",
             f"{'h (m)':>7} {'min sd across (m), best offset':>31} {'worst offset':>13} "
             f"{'felt at every offset':>21}"]
    zs = np.linspace(-thickness, thickness, 401)
    P = np.zeros((len(zs), 3))
    P[:, 2] = zs
    out = np.empty(len(zs))
    nrm = np.empty((len(zs), 3))
    res = []
    for h in steps:
        mins = []
        for off in np.arange(16) / 16.0:
            z0 = -0.25 - off * h
            n = int(np.ceil(0.5 / h)) + 2
            zn = z0 + h * np.arange(n)
            col = np.abs(zn) - thickness / 2
            g = np.ascontiguousarray(np.broadcast_to(col, (2, 2, n)), dtype=np.float64)
            # the x, y extent is immaterial: 2 x 2 nodes at spacing h around x = y = 0
            org = np.array([-0.5 * h, -0.5 * h, z0])
            run_grid(P, g, org, float(h), out, nrm)
            mins.append(out.min())
        best, worst = min(mins), max(mins)
        res.append(dict(h=h, min_best=best, min_worst=worst, felt=bool(worst < radius)))
        lines.append(f"{h:7.4f} {best:31.4f} {worst:13.4f} {str(worst < radius):>21}")
    return lines, res


def episode_tests():
    """One nominal episode of time-min against the target with a nozzle (implicit method,
    broad phase on): CPU s, simulated s, exact contact tests."""
    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.design import REFERENCE_DESIGNS
    from tethernet_ros.core.episode import CaptureSimulation, run_simulation
    from tethernet_ros.core.scenario import scenario_for
    from tethernet_ros.core.target import TargetConfig

    out = []
    for name, nozzle in (("time-min", True), ("baseline", False)):
        cfg = SimConfig(target=TargetConfig(nozzle=nozzle))
        run_simulation(CaptureSimulation(scenario_for(REFERENCE_DESIGNS[name], None,
                                                      SimConfig(horizon=1.0))), record_trace=False)
        sim = CaptureSimulation(scenario_for(REFERENCE_DESIGNS[name], None, cfg))
        t0 = time.process_time()
        r = run_simulation(sim, record_trace=False)
        cpu = time.process_time() - t0
        out.append(dict(design=name, nozzle=nozzle, cpu_s=cpu, sim_s=r.steps * sim.dt,
                        steps=int(r.steps), tests=int(sim.data.broad.tests[0]),
                        skips=int(sim.data.broad.skips[0])))
    return out


def coacd_parts(mesh, threshold, preprocess="off", seed=0):
    """coacd's convex parts of a watertight mesh, their trimeshes, the CPU time and a
    SHA-256 of the output bytes."""
    import coacd
    import numpy as np
    import trimesh

    coacd.set_log_level("error")
    m = coacd.Mesh(np.asarray(mesh.vertices, dtype=np.float64),
                   np.asarray(mesh.faces, dtype=np.int64))
    t0 = time.process_time()
    res = coacd.run_coacd(m, threshold=threshold, preprocess_mode=preprocess, seed=seed)
    cpu = time.process_time() - t0
    h = hashlib.sha256()
    parts = []
    for v, f in res:
        v = np.ascontiguousarray(v, dtype=np.float64)
        f = np.ascontiguousarray(f, dtype=np.int64)
        h.update(v.tobytes())
        h.update(f.tobytes())
        parts.append(trimesh.Trimesh(v, f, process=False))
    return parts, cpu, h.hexdigest()


# ---------------------------------------------------------------------------------------
# mass properties with IEEE operations only
# ---------------------------------------------------------------------------------------
def ieee_mass_properties(vertices, faces):
    """Volume, centre of mass and inertia tensor (unit density, about the CoM) of a closed
    triangle mesh: the divergence theorem over the tetrahedra (origin, a, b, c), each
    term computed with +, -, * on Python floats (IEEE binary64, no FMA, no BLAS) and every
    sum taken with math.fsum (correctly rounded, independent of order).  Vertices are
    first shifted by the first vertex (exact for the shift's rounding aside) to keep the
    second moments well conditioned."""
    V = [tuple(float(c) for c in v) for v in vertices]
    ox, oy, oz = V[0]
    V = [(x - ox, y - oy, z - oz) for x, y, z in V]
    vol, mx, my, mz = [], [], [], []
    sxx, syy, szz, sxy, syz, sxz = [], [], [], [], [], []
    for i, j, k in faces:
        ax, ay, az = V[int(i)]
        bx, by, bz = V[int(j)]
        cx, cy, cz = V[int(k)]
        d = (ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx))
        vol.append(d / 6.0)
        sx, sy, sz = ax + bx + cx, ay + by + cy, az + bz + cz
        mx.append(d * sx / 24.0)
        my.append(d * sy / 24.0)
        mz.append(d * sz / 24.0)
        # int x^2 over the tetra = d/60 (ax^2 + bx^2 + cx^2 + ax bx + ax cx + bx cx)
        sxx.append(d * (ax * ax + bx * bx + cx * cx + ax * bx + ax * cx + bx * cx) / 60.0)
        syy.append(d * (ay * ay + by * by + cy * cy + ay * by + ay * cy + by * cy) / 60.0)
        szz.append(d * (az * az + bz * bz + cz * cz + az * bz + az * cz + bz * cz) / 60.0)
        # int x y = d/120 (2 ax ay + 2 bx by + 2 cx cy + ax by + ay bx + ax cy + ay cx + bx cy + by cx)
        sxy.append(d * (2 * (ax * ay + bx * by + cx * cy) + ax * by + ay * bx + ax * cy
                        + ay * cx + bx * cy + by * cx) / 120.0)
        syz.append(d * (2 * (ay * az + by * bz + cy * cz) + ay * bz + az * by + ay * cz
                        + az * cy + by * cz + bz * cy) / 120.0)
        sxz.append(d * (2 * (ax * az + bx * bz + cx * cz) + ax * bz + az * bx + ax * cz
                        + az * cx + bx * cz + bz * cx) / 120.0)
    f = math.fsum
    V0 = f(vol)
    c = (f(mx) / V0, f(my) / V0, f(mz) / V0)
    Sxx, Syy, Szz = f(sxx), f(syy), f(szz)
    Sxy, Syz, Sxz = f(sxy), f(syz), f(sxz)
    # about the CoM (parallel axis), then the tensor I = tr(S) 1 - S
    Sxx -= V0 * c[0] * c[0]
    Syy -= V0 * c[1] * c[1]
    Szz -= V0 * c[2] * c[2]
    Sxy -= V0 * c[0] * c[1]
    Syz -= V0 * c[1] * c[2]
    Sxz -= V0 * c[0] * c[2]
    inertia = [[Syy + Szz, -Sxy, -Sxz], [-Sxy, Sxx + Szz, -Syz], [-Sxz, -Syz, Sxx + Syy]]
    return V0, (c[0] + ox, c[1] + oy, c[2] + oz), inertia


def mass_check(meshes):
    import numpy as np

    lines = ["mass properties: IEEE-only fsum (divergence theorem) against trimesh "
             "(numpy, no BLAS call; np.sum pairwise order, np.power for x**3)",
             f"{'mesh':<14} {'faces':>6} {'volume m^3':>14} {'rel vol':>9} {'rel CoM':>9} "
             f"{'rel inertia':>11} {'fsum s':>7} {'repeat bits':>11}"]
    res = []
    for name, m in meshes:
        t0 = time.process_time()
        V, c, I = ieee_mass_properties(m.vertices, m.faces)
        t = time.process_time() - t0
        V2, c2, I2 = ieee_mass_properties(m.vertices, m.faces)
        same = (V, c, I) == (V2, c2, I2)
        mp = m.mass_properties
        scale = float(np.linalg.norm(m.extents))
        rv = abs(V - mp.volume) / abs(mp.volume)
        rc = float(np.max(np.abs(np.array(c) - mp.center_mass))) / scale
        I = np.array(I)
        ri = float(np.max(np.abs(I - mp.inertia)) / np.max(np.abs(mp.inertia)))
        res.append(dict(mesh=name, faces=len(m.faces), volume=V, rel_volume=rv, rel_com=rc,
                        rel_inertia=ri, cpu_s=t, repeat_identical=same))
        lines.append(f"{name:<14} {len(m.faces):6d} {V:14.9f} {rv:9.1e} {rc:9.1e} {ri:11.1e} "
                     f"{t:7.3f} {str(same):>11}")
    return lines, res


def formats_check(mesh, folder):
    """Export to each format, reload twice; SHA-256 of the file and of the reloaded
    vertices and faces."""
    import numpy as np
    import trimesh

    os.makedirs(folder, exist_ok=True)
    lines = ["mesh files: export, reload twice with trimesh.load(force='mesh'); "
             "hashes of the file bytes and of the loaded (vertices, faces)"]
    for ext in ("stl", "obj", "ply", "glb", "off"):
        path = os.path.join(folder, f"envisat.{ext}")
        mesh.export(path)
        with open(path, "rb") as fh:
            fhash = hashlib.sha256(fh.read()).hexdigest()[:12]
        hs = []
        for _ in range(2):
            m = trimesh.load(path, force="mesh")
            h = hashlib.sha256(np.ascontiguousarray(m.vertices, dtype=np.float64).tobytes()
                               + np.ascontiguousarray(m.faces, dtype=np.int64).tobytes())
            hs.append((h.hexdigest()[:12], len(m.vertices), len(m.faces), m.is_watertight))
        lines.append(f"  {ext:<4} file {fhash}  load {hs[0][0]} (V {hs[0][1]}, F {hs[0][2]}, "
                     f"watertight {hs[0][3]})  reload same: {hs[0] == hs[1]}")
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, default=100_000)
    ap.add_argument("--grid-steps", default="0.4,0.2,0.1,0.05")
    ap.add_argument("--cell-sizes", default="0.5,0.25,0.125")
    ap.add_argument("--band", type=float, default=1.0,
                    help="cells within this distance (m) of the surface keep candidate lists")
    ap.add_argument("--max-grid-nodes", type=int, default=8_000_000)
    ap.add_argument("--plate-steps", default="0.2,0.1,0.05,0.04,0.03,0.025,0.02,0.015,0.01")
    ap.add_argument("--coacd-threshold", type=float, default=0.05)
    ap.add_argument("--sections", type=int, default=128)
    ap.add_argument("--quick", action="store_true", help="20k points, grids 0.4,0.2 m")
    ap.add_argument("--skip", default="", help="comma list of: episode,coacd,grid,skirt")
    ap.add_argument("--json", default="")
    ap.add_argument("--export", default="/tmp/bench_mesh_contact")
    args = ap.parse_args(argv)
    miss = missing_modules()
    if miss:
        print("bench_mesh_contact: missing " + ", ".join(miss) + "; install with\n"
              "  .venv/bin/python -m pip install " + " ".join(miss)
              + "\n(or into a folder: pip install --target DIR ... and PYTHONPATH=DIR)")
        return 0
    if args.quick:
        args.points = 20_000
        args.grid_steps = "0.4,0.2"
    args.grid_steps = [float(s) for s in args.grid_steps.split(",") if s]
    args.cell_sizes = [float(s) for s in args.cell_sizes.split(",") if s]
    skip = set(args.skip.split(","))
    if "grid" in skip:
        args.grid_steps = []

    import numpy as np

    from tethernet_ros.core.shapes import target_shape
    from tethernet_ros.core.target import TargetConfig

    print("machine:", _cpu_name(), "| numpy", np.__version__)
    kernels = build_kernels()
    report = dict(rows=[], coacd=[], cpu_model=_cpu_name())

    # -- meshes ------------------------------------------------------------------------
    zen, zen_parts = zenit_mesh(args.sections)
    zsk, _ = zenit_mesh(args.sections, skirt=True)
    env, env_parts = envisat_mesh()
    for name, m in (("zenit", zen), ("zenit-skirt", zsk), ("envisat", env)):
        print(f"mesh {name}: {len(m.vertices)} vertices, {len(m.faces)} faces, watertight "
              f"{m.is_watertight}, volume {m.volume:.3f} m^3, extents {np.round(m.extents, 3)}")

    # -- coacd, twice each (determinism) -------------------------------------------------
    cparts = {}
    if "coacd" not in skip:
        print(f"\ncoacd (threshold {args.coacd_threshold:.3g}, preprocess off, seed 0, "
              f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS')}), run twice:")
        todo = [("zenit", zen), ("envisat", env)]
        if "skirt" not in skip:
            todo.append(("zenit-skirt", zsk))
        for name, m in todo:
            p1, t1, h1 = coacd_parts(m, args.coacd_threshold)
            p2, t2, h2 = coacd_parts(m, args.coacd_threshold)
            cparts[name] = p1
            vol = sum(p.volume for p in p1)
            report["coacd"].append(dict(mesh=name, parts=len(p1), cpu_s=[t1, t2],
                                        sha=[h1, h2], identical=h1 == h2,
                                        parts_volume=vol, mesh_volume=m.volume))
            print(f"  {name:<12} {len(p1):3d} parts  cpu {t1:6.1f} / {t2:6.1f} s  "
                  f"sha {h1[:12]} / {h2[:12]}  identical {h1 == h2}  "
                  f"parts' volume / mesh {vol / m.volume:.4f}")
        if "envisat" in cparts:
            p1, t1, h1 = coacd_parts(env, args.coacd_threshold, preprocess="auto")
            report["coacd"].append(dict(mesh="envisat preprocess auto", parts=len(p1),
                                        cpu_s=[t1], sha=[h1],
                                        parts_volume=sum(p.volume for p in p1),
                                        mesh_volume=env.volume))
            print(f"  envisat, preprocess auto (manifold remesh): {len(p1)} parts, cpu {t1:.1f} s, "
                  f"parts' volume / mesh {sum(p.volume for p in p1) / env.volume:.4f}")

    # -- queries -----------------------------------------------------------------------
    tgt = target_shape(TargetConfig(nozzle=True))
    verts, offsets = tgt.packed_polygons()
    analytic = (tgt.cylinder(), verts, offsets)
    measure_case("zenit", zen, zen_parts, kernels, args, report["rows"],
                 coacd_parts=cparts.get("zenit"), analytic=analytic)
    if "skirt" not in skip:
        L, s = ZENIT["L"], SKIRT["length"]
        x_aft = -L / 2 - tgt.com_offset

        def skirt_region(P):
            r = np.sqrt(P[:, 1] ** 2 + P[:, 2] ** 2)
            return (P[:, 0] < x_aft + 0.1) & (P[:, 0] > x_aft - s - 0.5) & (r > 1.0)
        measure_case("zenit-skirt", zsk, None, kernels, args, report["rows"],
                     coacd_parts=cparts.get("zenit-skirt"), thin=skirt_region)

    def array_region(P):
        return P[:, 0] > 12.5
    measure_case("envisat", env, env_parts, kernels, args, report["rows"],
                 coacd_parts=cparts.get("envisat"), thin=array_region)

    lines, report["plate"] = plate_sweep(kernels, [float(s) for s in args.plate_steps.split(",")])
    print("\n" + "\n".join(lines))

    # -- the kernel's need ---------------------------------------------------------------
    if "episode" not in skip:
        report["episodes"] = episode_tests()
        print("\nnominal episodes, implicit method, broad phase on:")
        for e in report["episodes"]:
            print(f"  {e['design']:<9} nozzle {e['nozzle']!s:<5} cpu {e['cpu_s']:.2f} s  "
                  f"sim {e['sim_s']:.1f} s  steps {e['steps']}  exact tests {e['tests']} "
                  f"({e['tests'] / e['steps']:.1f} per step; {e['cpu_s'] / e['steps'] * 1e6:.1f} us "
                  "per step)")
            for r in report["rows"]:
                if r["case"] != "zenit" or r["method"].startswith("analytic"):
                    continue
                an = next(x for x in report["rows"] if x["case"] == "zenit"
                          and x["method"].startswith("analytic"))
                extra = e["tests"] * (r["ns_per_query"] - an["ns_per_query"]) * 1e-9
                print(f"    {r['method']:<40} +{extra:6.3f} CPU s = x{1 + extra / e['cpu_s']:.3f} "
                      "episode (the tests' count unchanged)")

    # -- determinism -----------------------------------------------------------------
    lines, report["mass"] = mass_check([("zenit", zen), ("zenit-skirt", zsk), ("envisat", env)])
    print("\n" + "\n".join(lines))
    print("\n" + "\n".join(formats_check(env, args.export)))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(report, fh, indent=1, default=float)
    return 0


def _cpu_name() -> str:
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown"


if __name__ == "__main__":
    sys.exit(main())
