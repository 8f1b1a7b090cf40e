"""The ``mesh`` shape kind: a target read from a triangle-mesh file (docs/model.md §15,
docs/targets.md).

trimesh reads the file (STL, OBJ, PLY, GLB/glTF, OFF); what it can repair (duplicate or
degenerate faces, unreferenced vertices, small holes, inconsistent or inverted winding) is
repaired and reported; any other defect refuses the file with one line naming it and the
file.  From the loaded arrays on, everything is the project's own arithmetic in IEEE
operations, so that one file gives the same bits on every machine:

- the mass properties (``mass_properties``): uniform density from the total mass, or a
  measured CoM and inertia tensor, checked to be physically possible;
- the body frame: the CoM, the principal axes ordered x = least inertia (the long axis),
  y = greatest (a flat spin), z = the middle one, right-handed (``shapes.Shape``);
- the kernel's query tables (``kernel.mesh_sdf``): triangles, angle-weighted
  pseudonormals (angles rounded once by mpmath, ``detmath``), cell lists, cached on disk by
  the content hash of the body-frame triangles.

Units: m, kg, kg m^2.
"""
from __future__ import annotations

import hashlib
import math
import os
from functools import cached_property
from pathlib import Path

import numpy as np
from numba import njit

from .. import detmath
from ..kernel.geometry import mesh_geometry
from ..kernel.mesh_sdf import build_cells
from .base import Shape
from .mass_properties import check_inertia, mesh_mass_properties, principal_axes, signed_volume

#: side (m) of the query grid's cubic cells, and the band (m) about the surface within
#: which cells list their triangles (docs/studies/mesh-contact.md: 0.25 m, 1 m)
CELL = 0.25
BAND = 1.0
#: units a mesh file may be written in, and their size in m
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "ft": 0.3048}
#: the file formats read (trimesh's loaders)
FORMATS = (".stl", ".obj", ".ply", ".glb", ".gltf", ".off")
#: bounds of a plausible target (m): its box diagonal; beyond them the file is refused
#: (the smallest tracked debris is about 0.1 m; the ISS, the largest object, about 110 m)
MIN_SIZE, MAX_SIZE = 0.05, 200.0
#: the most faces accepted: the cell lists are built by brute force (O(cells x faces))
MAX_FACES = 20000
#: the version of the query tables' layout, part of their cache key (``query_tables``)
CACHE_VERSION = 2


class MeshError(ValueError):
    """A mesh file that cannot be a target: the message names the file and the defect."""


def read_arrays(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) and faces (F, 3) as the file holds them, by trimesh's loaders.  STL,
    OBJ, PLY and OFF are read without trimesh's processing (which calls BLAS: the project
    keeps every BLAS result away from an episode, docs/model.md §13); a GLB/glTF scene is
    flattened by trimesh, whose node transforms are matrix products."""
    import trimesh
    from trimesh.exchange.load import mesh_loaders

    ext = path.suffix.lower()[1:]
    if ext in ("glb", "gltf"):
        mesh = trimesh.load(str(path), force="mesh", process=False)
        return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)
    with open(path, "rb") as f:
        kw = mesh_loaders[ext](f, file_type=ext)
    parts = list(kw["geometry"].values()) if "geometry" in kw else [kw]
    vertices, faces, base = [], [], 0
    for part in parts:
        v = np.asarray(part.get("vertices", np.zeros((0, 3))), dtype=np.float64).reshape(-1, 3)
        f = np.asarray(part.get("faces", np.zeros((0, 3))), dtype=np.int64).reshape(-1, 3)
        vertices.append(v)
        faces.append(f + base)
        base += len(v)
    return np.concatenate(vertices), np.concatenate(faces)


def load_mesh(path: Path, units: str = "m") -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Vertices (V, 3) (m), faces (F, 3) of a closed, outward-oriented mesh file, and the
    repairs made (one string each).  Vertices that are equal are merged (exactly: a
    sorted ``numpy.unique``); trimesh judges and repairs the topology."""
    import trimesh

    name = str(path)
    if path.suffix.lower() not in FORMATS:
        raise MeshError(f"{name}: format {path.suffix or '(none)'} not read; must be one of "
                        f"{', '.join(FORMATS)}")
    if path.is_file() and path.stat().st_size == 0:
        raise MeshError(f"{name}: the file is empty (0 bytes); a target must be a closed "
                        "triangle mesh")
    try:
        raw_v, raw_f = read_arrays(path)
    except Exception as exc:          # trimesh raises many kinds for unreadable files
        raise MeshError(f"{name}: not readable as a mesh ({type(exc).__name__}: {exc})") from exc
    if len(raw_f) == 0 or len(raw_v) == 0:
        raise MeshError(f"{name}: holds no triangles")
    if not np.all(np.isfinite(raw_v)):
        raise MeshError(f"{name}: vertices that are not finite numbers")
    scale = UNITS[units]
    if scale != 1.0:
        raw_v = raw_v * scale
    vertices, inverse = np.unique(raw_v, axis=0, return_inverse=True)
    mesh = trimesh.Trimesh(vertices, inverse.reshape(-1)[raw_f], process=False)
    repairs = []
    n0 = len(mesh.faces)
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.update_faces(mesh.unique_faces())
    mesh.remove_unreferenced_vertices()
    if len(mesh.faces) < n0:
        repairs.append(f"removed {n0 - len(mesh.faces)} degenerate or duplicate faces")
    if len(mesh.faces) > MAX_FACES:
        raise MeshError(f"{name}: {len(mesh.faces)} faces; at most {MAX_FACES} (decimate it)")
    v = np.asarray(mesh.vertices)
    diag = math.sqrt(math.fsum(float(d) ** 2 for d in v.max(axis=0) - v.min(axis=0)))
    if not MIN_SIZE <= diag <= MAX_SIZE:
        hint = ""
        for u, s in sorted(UNITS.items(), key=lambda kv: kv[1]):
            if MIN_SIZE <= diag * s / scale <= MAX_SIZE and s != scale:
                hint = f" (in {u}? give units '{u}')"
                break
        raise MeshError(f"{name}: box diagonal {diag:.4g} m with units '{units}'; a target "
                        f"must be {MIN_SIZE:g}-{MAX_SIZE:g} m{hint}")
    if not mesh.is_watertight:
        trimesh.repair.fill_holes(mesh)
        if not mesh.is_watertight:
            raise MeshError(f"{name}: open surface ({_boundary_edges(mesh)} boundary edges) "
                            "that trimesh cannot close; a target must be a closed surface")
        repairs.append("closed holes")
    if not mesh.is_winding_consistent:
        trimesh.repair.fix_winding(mesh)
        if not mesh.is_winding_consistent:
            raise MeshError(f"{name}: inconsistent face winding that trimesh cannot fix")
        repairs.append("made the face winding consistent")
    faces = np.ascontiguousarray(mesh.faces, dtype=np.int64)
    vertices = np.ascontiguousarray(mesh.vertices, dtype=np.float64)
    if signed_volume(vertices, faces) < 0.0:
        faces = np.ascontiguousarray(faces[:, ::-1])
        repairs.append("turned inverted normals outward")
    bodies = _bodies(mesh)
    if len(bodies) > 1:
        how = "that overlap" if _boxes_overlap(mesh, bodies) else "apart"
        raise MeshError(f"{name}: {len(bodies)} separate bodies {how}; a target must be one "
                        "body (union them first, or give each its own file): the distance "
                        "query is exact only near one body, and a rigid target of parts "
                        "apart would need what holds them together")
    return vertices, faces, repairs


def _boundary_edges(mesh) -> int:
    import trimesh

    return int(len(trimesh.grouping.group_rows(mesh.edges_sorted, require_count=1)))


def _bodies(mesh) -> list:
    """The mesh's connected bodies (faces joined by shared edges), each an index array."""
    import trimesh

    return trimesh.graph.connected_components(mesh.face_adjacency, min_len=1,
                                              nodes=np.arange(len(mesh.faces)))


def _boxes_overlap(mesh, bodies) -> bool:
    """Whether two of the bodies have overlapping boxes."""
    v = np.asarray(mesh.vertices)
    boxes = []
    for p in bodies:
        pts = v[np.asarray(mesh.faces)[p].reshape(-1)]
        boxes.append((pts.min(axis=0), pts.max(axis=0)))
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            if np.all(boxes[i][0] < boxes[j][1]) and np.all(boxes[j][0] < boxes[i][1]):
                return True
    return False


def body_frame(moments, axes) -> tuple[np.ndarray, np.ndarray]:
    """The principal moments (3,) and axes (columns) reordered to the body frame: x the
    least, y the greatest, z the middle moment, right-handed; where the two larger moments
    are equal the order of ``principal_axes`` is kept (a symmetric top's axes stay)."""
    m = [float(v) for v in moments]
    a = np.array(axes, dtype=np.float64)
    if m[1] == m[2]:
        return np.array(m), a
    order = [0, 2, 1]
    b = a[:, order].copy()
    b[:, 2] = -b[:, 2]                      # the swap turned the frame: keep it right-handed
    return np.array([m[i] for i in order]), b


@njit(cache=True, error_model='numpy')
def _pseudonormals(tris, faces, n_vertices, angles):
    """(T, 7, 3) unit pseudonormals of each triangle's vertices a, b, c (angle-weighted),
    edges ab, ac, bc (the two faces' normals summed) and face, from the triangles (T, 9),
    their vertex indices (T, 3) and interior angles (T, 3) (rad); sums in face order."""
    nt = tris.shape[0]
    fn = np.empty((nt, 3))
    for t in range(nt):
        ux, uy, uz = tris[t, 3] - tris[t, 0], tris[t, 4] - tris[t, 1], tris[t, 5] - tris[t, 2]
        vx, vy, vz = tris[t, 6] - tris[t, 0], tris[t, 7] - tris[t, 1], tris[t, 8] - tris[t, 2]
        cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        n = np.sqrt(cx * cx + cy * cy + cz * cz)
        fn[t, 0], fn[t, 1], fn[t, 2] = cx / n, cy / n, cz / n
    vn = np.zeros((n_vertices, 3))
    for t in range(nt):
        for k in range(3):
            for c in range(3):
                vn[faces[t, k], c] += angles[t, k] * fn[t, c]
    # edges: a dictionary-free pairing, each edge's two faces found by sorting its keys
    ne = 3 * nt
    keys = np.empty(ne, dtype=np.int64)
    for t in range(nt):
        for r in range(3):
            u = faces[t, 0] if r < 2 else faces[t, 1]
            v = faces[t, 1] if r == 0 else faces[t, 2]
            keys[3 * t + r] = min(u, v) * n_vertices + max(u, v)
    order = np.argsort(keys, kind="mergesort")
    en = np.zeros((ne, 3))
    q = 0
    while q < ne:
        s = q
        while q < ne and keys[order[q]] == keys[order[s]]:
            q += 1
        sx = sy = sz = 0.0
        for m in range(s, q):
            t = order[m] // 3
            sx += fn[t, 0]
            sy += fn[t, 1]
            sz += fn[t, 2]
        for m in range(s, q):
            en[order[m], 0], en[order[m], 1], en[order[m], 2] = sx, sy, sz
    pn = np.empty((nt, 7, 3))
    for t in range(nt):
        for k in range(3):
            for c in range(3):
                pn[t, k, c] = vn[faces[t, k], c]
                pn[t, 3 + k, c] = en[3 * t + k, c]
            pn[t, 6, k] = fn[t, k]
        for r in range(7):
            n = np.sqrt(pn[t, r, 0] ** 2 + pn[t, r, 1] ** 2 + pn[t, r, 2] ** 2)
            for c in range(3):
                pn[t, r, c] = pn[t, r, c] / n
    return pn


def _interior_angles(tris: np.ndarray) -> np.ndarray:
    """(T, 3) interior angles (rad) at each triangle's vertices, rounded once (mpmath)."""
    out = np.empty((len(tris), 3))
    corners = tris.reshape(-1, 3, 3).tolist()
    for t, (a, b, c) in enumerate(corners):
        for k, (p, u, v) in enumerate(((a, b, c), (b, a, c), (c, a, b))):
            e = [u[i] - p[i] for i in range(3)]
            f = [v[i] - p[i] for i in range(3)]
            cx, cy, cz = e[1] * f[2] - e[2] * f[1], e[2] * f[0] - e[0] * f[2], e[0] * f[1] - e[1] * f[0]
            out[t, k] = detmath.atan2((cx * cx + cy * cy + cz * cz) ** 0.5,
                                      e[0] * f[0] + e[1] * f[1] + e[2] * f[2])
    return out


def cache_dir() -> Path:
    """Where built query tables are kept: $TETHERNET_CACHE or ~/.cache/tethernet_ros."""
    root = os.environ.get("TETHERNET_CACHE") or Path.home() / ".cache" / "tethernet_ros"
    return Path(root) / "shapes"


def query_tables(tris: np.ndarray, faces: np.ndarray, n_vertices: int) -> dict:
    """The kernel's tables of body-frame triangles (T, 9): pseudonormals and cell lists,
    read from the cache when the same triangles were built before (content hash)."""
    h = hashlib.sha256(np.ascontiguousarray(tris).tobytes())
    h.update(np.ascontiguousarray(faces).tobytes())
    h.update(repr((CACHE_VERSION, CELL, BAND)).encode())
    path = cache_dir() / f"{h.hexdigest()}.npz"
    if path.is_file():
        try:
            with np.load(path) as z:
                return {k: z[k] for k in z.files}
        except (OSError, ValueError, KeyError):
            pass                                     # a damaged cache entry is rebuilt
    lo, hi = tris.reshape(-1, 3).min(axis=0), tris.reshape(-1, 3).max(axis=0)
    origin = lo - BAND
    dims = np.ceil((hi - lo + 2 * BAND) / CELL).astype(np.int64)
    pn = _pseudonormals(tris, faces, n_vertices, _interior_angles(tris))
    far, start, cand, cdist = build_cells(origin, CELL, dims, BAND, tris, pn)
    tables = dict(pn=pn, origin=origin, dims=dims, far=far, start=start, cand=cand,
                  cdist=cdist, lo=lo, hi=hi)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp.npz")
        np.savez(tmp, **tables)
        os.replace(tmp, path)
    except OSError:
        pass                                         # a read-only home: no cache, same tables
    return tables


class MeshShape(Shape):
    """A target from a mesh file: its body-frame triangles, mass properties and the
    kernel's query tables."""

    kind = "mesh"

    def __init__(self, name: str, vertices, faces, mass: float, com=None, inertia=None,
                 path: Path | None = None, sha256: str = "", units: str = "m",
                 repairs=()):
        self.name, self.path, self.sha256, self.units = name, path, sha256, units
        self.repairs = list(repairs)
        self.mass = float(mass)
        faces = np.ascontiguousarray(faces, dtype=np.int64)
        integrals = mesh_mass_properties(vertices, faces)
        self.volume, self.area = integrals.volume, integrals.area
        if com is None:
            com = np.array(integrals.centroid, dtype=np.float64)
        if inertia is None:
            inertia = np.array(integrals.inertia_unit, dtype=np.float64) * (self.mass / self.volume)
        check_inertia(inertia, field="inertia")
        moments, axes = principal_axes(inertia)
        self.inertia, self.axes = body_frame(moments, axes)
        self.com = np.asarray(com, dtype=np.float64)
        # body = axes^T (v - com), elementwise (no BLAS: the same bits everywhere)
        d = np.asarray(vertices, dtype=np.float64) - self.com
        A = self.axes
        self.vertices = np.ascontiguousarray(np.stack(
            [d[:, 0] * A[0, j] + d[:, 1] * A[1, j] + d[:, 2] * A[2, j] for j in range(3)], axis=1))
        self.faces = faces
        self.tris = np.ascontiguousarray(self.vertices[faces].reshape(-1, 9))
        x, y, z = self.vertices[:, 0], self.vertices[:, 1], self.vertices[:, 2]
        r2 = x * x + y * y + z * z
        self.bounding_radius = float(np.sqrt(r2.max()))
        self.extent = (float(np.abs(x).max()), float(np.sqrt((y * y + z * z).max())))

    @classmethod
    def from_config(cls, config) -> MeshShape:
        path = config.mesh_path
        try:
            vertices, faces, repairs = load_mesh(path, config.units)
        except MeshError as exc:
            raise MeshError(f"target field 'mesh': {exc}") from None
        if repairs:
            import warnings

            warnings.warn(f"target {config.name}: {path}: repaired: {'; '.join(repairs)}",
                          stacklevel=2)
        com = np.array(config.com) * 1.0 if config.com else None
        inertia = _tensor(config.inertia) if config.inertia else None
        return cls(config.name, vertices, faces, config.mass, com=com, inertia=inertia,
                   path=path, sha256=config.mesh_sha256, units=config.units, repairs=repairs)

    @cached_property
    def _tables(self) -> dict:
        return query_tables(self.tris, self.faces, len(self.vertices))

    def geometry(self):
        t = self._tables
        return mesh_geometry(self.extent, self.tris, t["pn"], t["origin"], CELL, t["dims"],
                             t["far"], t["start"], t["cand"], t["cdist"], t["lo"], t["hi"])

    @cached_property
    def min_surface_distance(self) -> float:
        """L_c (m): the distance from the CoM to the nearest surface point."""
        return abs(self.signed_distance(np.zeros(3))[0])

    def trimesh(self):
        import trimesh

        return trimesh.Trimesh(self.vertices.copy(), self.faces.copy(), process=False)


def _tensor(values) -> np.ndarray:
    """A 3 x 3 tensor from 9 values or 6 (Ixx, Iyy, Izz, Ixy, Iyz, Ixz)."""
    v = [float(x) for x in values]
    if len(v) == 9:
        return np.array(v).reshape(3, 3)
    xx, yy, zz, xy, yz, xz = v
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
