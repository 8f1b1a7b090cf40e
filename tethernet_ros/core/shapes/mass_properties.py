"""Mass properties of closed triangle meshes, with the same bits on every machine.

The numbers come from IEEE basic operations (+, -, *, /, sqrt) on Python floats, and every
sum over faces is a ``math.fsum`` (correctly rounded, so independent of the face order and
of SIMD).  numpy only holds and converts arrays here; it never reduces them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["MassIntegrals", "mesh_mass_properties", "signed_volume", "principal_axes",
           "check_inertia", "rigid_body"]

#: Jacobi: stop at off-diagonal norm <= _REL_TOL x Frobenius norm or after _MAX_SWEEPS sweeps of _PAIRS
_REL_TOL, _MAX_SWEEPS, _PAIRS = 1e-15, 50, ((0, 1), (0, 2), (1, 2))
#: relative tolerance of :func:`check_inertia` (symmetry and triangle inequality)
_CHECK_TOL = 1e-9


@dataclass(frozen=True)
class MassIntegrals:
    """Geometric integrals of a solid: ``volume`` (m^3), ``area`` (m^2, whole surface),
    ``centroid`` (3,) (m) and ``inertia_unit`` (3, 3), the inertia tensor per unit density
    about the centroid (m^5, products of inertia with their minus sign)."""

    volume: float
    area: float
    centroid: np.ndarray
    inertia_unit: np.ndarray


def _frozen(values) -> np.ndarray:
    out = np.array(values, dtype=np.float64)
    out.flags.writeable = False
    return out


def _shifted(vs: np.ndarray) -> list:
    """The vertices (V, 3) as Python floats, shifted by vertices[0] (less cancellation)."""
    x0, y0, z0 = vs[0].tolist()
    return [(x - x0, y - y0, z - z0) for x, y, z in vs.tolist()]


def _det(a, b, c) -> float:
    """a . (b x c): six times the signed volume of the tetrahedron (0, a, b, c)."""
    (ax, ay, az), (bx, by, bz), (cx, cy, cz) = a, b, c
    return ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)


def signed_volume(vertices, faces) -> float:
    """The volume (m^3) the faces (F, 3) of vertices (V, 3) enclose, negative when they
    face inward: the fsum of the tetrahedra (vertices[0], a, b, c), as in
    :func:`mesh_mass_properties`."""
    pts = _shifted(np.asarray(vertices, dtype=np.float64))
    return math.fsum(_det(pts[i], pts[j], pts[k]) for i, j, k in np.asarray(faces).tolist()) / 6.0


def mesh_mass_properties(vertices, faces) -> MassIntegrals:
    """Volume, area, centroid and unit-density inertia of a closed triangle mesh.

    ``vertices`` (V, 3) in m, ``faces`` (F, 3) vertex indices, consistently oriented with
    the normals outward.  Divergence theorem over the signed tetrahedra (vertices[0], a, b, c)
    of the faces: all vertices are shifted by vertices[0] first to reduce cancellation, so
    the result depends on the vertex order but not on the face order.  Per tetrahedron
    (0, a, b, c) with d = a . (b x c) and s = a + b + c: volume d/6, first moments d s/24,
    second moments int x_i x_j dV = d (a_i a_j + b_i b_j + c_i c_j + s_i s_j) / 120.
    Raises ValueError when the volume is not positive (faces inverted, or an open mesh);
    an open mesh whose volume stays positive is not detected.
    """
    vs = np.asarray(vertices, dtype=np.float64)
    fs = np.asarray(faces)
    if vs.ndim != 2 or vs.shape[1] != 3 or len(vs) == 0:
        raise ValueError(f"mesh vertices must have shape (V, 3), got {vs.shape}")
    if fs.ndim != 2 or fs.shape[1] != 3 or len(fs) == 0 or not np.issubdtype(fs.dtype, np.integer):
        raise ValueError(f"mesh faces must be integers of shape (F, 3), got {fs.dtype} {fs.shape}")
    if not np.isfinite(vs).all():
        raise ValueError("mesh vertices are not all finite")
    if fs.min() < 0 or fs.max() >= len(vs):
        raise ValueError(f"mesh faces index vertices outside 0..{len(vs) - 1}")
    x0, y0, z0 = vs[0].tolist()
    pts = _shifted(vs)
    # per face: 6 x the signed tetra volume, its first moments x 24, second moments x 120, area
    rows = []
    for i, j, k in fs.tolist():
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = pts[i], pts[j], pts[k]
        d = _det(pts[i], pts[j], pts[k])
        sx, sy, sz = ax + bx + cx, ay + by + cy, az + bz + cz
        ux, uy, uz, wx, wy, wz = bx - ax, by - ay, bz - az, cx - ax, cy - ay, cz - az
        nx, ny, nz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
        rows.append((d, d * sx, d * sy, d * sz,
                     d * (ax * ax + bx * bx + cx * cx + sx * sx), d * (ay * ay + by * by + cy * cy + sy * sy),
                     d * (az * az + bz * bz + cz * cz + sz * sz), d * (ax * ay + bx * by + cx * cy + sx * sy),
                     d * (ay * az + by * bz + cy * cz + sy * sz), d * (az * ax + bz * bx + cz * cx + sz * sx),
                     0.5 * math.sqrt(nx * nx + ny * ny + nz * nz)))
    D, Mx, My, Mz, Sxx, Syy, Szz, Sxy, Syz, Szx, area = (math.fsum(col) for col in zip(*rows))
    volume = D / 6.0
    if not volume > 0.0:
        raise ValueError(f"mesh volume {volume:.6g} m^3 is not positive: faces oriented inward "
                         "(inverted normals) or the mesh is not closed")
    # centroid relative to vertices[0]; second moments about the centroid (m^5)
    gx, gy, gz = Mx / (4.0 * D), My / (4.0 * D), Mz / (4.0 * D)
    cxx, cyy, czz = Sxx / 120.0 - volume * gx * gx, Syy / 120.0 - volume * gy * gy, Szz / 120.0 - volume * gz * gz
    cxy, cyz, czx = Sxy / 120.0 - volume * gx * gy, Syz / 120.0 - volume * gy * gz, Szx / 120.0 - volume * gz * gx
    inertia = [[cyy + czz, -cxy, -czx], [-cxy, cxx + czz, -cyz], [-czx, -cyz, cxx + cyy]]
    return MassIntegrals(volume, area, _frozen([gx + x0, gy + y0, gz + z0]), _frozen(inertia))


def principal_axes(inertia) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (3,) ascending (same unit as ``inertia``, e.g. kg m^2) and axes
    (3, 3) whose columns are the unit principal axes in that order, a right-handed frame.

    Cyclic Jacobi on Python floats (sweeps (0,1), (0,2), (1,2); stop when the off-diagonal
    norm is below 1e-15 of the Frobenius norm, or after 50 sweeps); the off-diagonals used
    are the means of the two triangles.  Signs: each axis is flipped so that its component
    of largest magnitude is positive (ties: the first index), then the third axis is
    flipped if the frame is left-handed.  Ties of moments keep their index order.

    With equal moments (a symmetric top, a sphere) the axes of the degenerate plane are not
    unique: the solver returns, deterministically, what the Jacobi rotations give.  If the
    off-diagonals are exactly 0, no rotation is made, and the axes are exactly the identity
    columns permuted into ascending moments (stable for ties), signs + -- except that an odd
    permutation has its third column negated, to stay right-handed.  So a body with
    Ixx < Iyy == Izz (e.g. a Zenit-2 stage) keeps exactly its axes x, y, z.
    """
    m = np.asarray(inertia, dtype=np.float64)
    if m.shape != (3, 3) or not np.isfinite(m).all():
        raise ValueError(f"inertia must be a finite (3, 3) tensor, got shape {m.shape}")
    r = m.tolist()
    a = [[r[i][i] if i == j else 0.5 * (r[i][j] + r[j][i]) for j in range(3)] for i in range(3)]
    v = [[1.0 if i == j else 0.0 for j in range(3)] for i in range(3)]
    frob = math.sqrt(math.fsum(a[i][j] * a[i][j] for i in range(3) for j in range(3)))
    for _ in range(_MAX_SWEEPS):
        if math.sqrt(2.0 * math.fsum(a[p][q] * a[p][q] for p, q in _PAIRS)) <= _REL_TOL * frob:
            break
        for p, q in _PAIRS:
            apq = a[p][q]
            if apq == 0.0:
                continue
            theta = (a[q][q] - a[p][p]) / (2.0 * apq)
            # t = tan of the rotation angle, the smaller root; 0.5 / theta where theta^2 would overflow
            t = 0.5 / theta if abs(theta) > 1e150 else math.copysign(
                1.0 / (abs(theta) + math.sqrt(theta * theta + 1.0)), theta)
            c = 1.0 / math.sqrt(t * t + 1.0)
            s = t * c
            a[p][p] -= t * apq
            a[q][q] += t * apq
            a[p][q] = a[q][p] = 0.0
            o = 3 - p - q
            aop, aoq = a[o][p], a[o][q]
            a[o][p] = a[p][o] = c * aop - s * aoq
            a[o][q] = a[q][o] = s * aop + c * aoq
            for row in v:
                vp, vq = row[p], row[q]
                row[p], row[q] = c * vp - s * vq, s * vp + c * vq
    order = sorted(range(3), key=lambda i: a[i][i])
    cols = []
    for i in order:
        col = [v[0][i], v[1][i], v[2][i]]
        big = max(range(3), key=lambda k: abs(col[k]))  # first index on ties
        cols.append([-e for e in col] if col[big] < 0.0 else col)
    (x0, x1, x2), (y0, y1, y2), (z0, z1, z2) = cols
    if (x1 * y2 - x2 * y1) * z0 + (x2 * y0 - x0 * y2) * z1 + (x0 * y1 - x1 * y0) * z2 < 0.0:
        cols[2] = [-e for e in cols[2]]
    return np.array([a[i][i] for i in order]), np.array(cols).T


def check_inertia(moments_or_tensor, field: str = "inertia") -> tuple[float, float, float]:
    """Raise ValueError naming ``field`` unless the inertia (3 principal moments or a (3, 3)
    tensor, kg m^2) is physically possible: symmetric (1e-9 of the largest entry), positive
    definite, and with principal moments I1 <= I2 <= I3 meeting I1 + I2 >= I3 (1e-9 of I3).
    Returns the principal moments ascending (kg m^2)."""
    x = np.asarray(moments_or_tensor, dtype=np.float64)
    head = f"target field '{field}':"
    if x.shape not in ((3,), (3, 3)) or not np.isfinite(x).all():
        raise ValueError(f"{head} inertia must be 3 finite principal moments or a finite 3x3 tensor "
                         f"(kg m^2), got shape {x.shape}")
    if x.shape == (3, 3):
        r = x.tolist()
        scale = max(abs(e) for row in r for e in row)
        for p, q in _PAIRS:
            if abs(r[p][q] - r[q][p]) > _CHECK_TOL * scale:
                raise ValueError(f"{head} inertia tensor is not symmetric (I[{p}][{q}] = {r[p][q]:.6g}, "
                                 f"I[{q}][{p}] = {r[q][p]:.6g} kg m^2); not a physical rigid body")
        i1, i2, i3 = principal_axes(x)[0].tolist()
    else:
        i1, i2, i3 = sorted(x.tolist())
    text = f"principal moments ({i1:.6g}, {i2:.6g}, {i3:.6g}) kg m^2"
    if not i1 > 0.0:
        raise ValueError(f"{head} {text} are not all positive (not positive definite); not a physical rigid body")
    if i1 + i2 < i3 * (1.0 - _CHECK_TOL):
        raise ValueError(f"{head} {text} violate I1 + I2 >= I3; not a physical rigid body")
    return i1, i2, i3


def rigid_body(integrals: MassIntegrals, mass: float) -> tuple[np.ndarray, np.ndarray]:
    """Uniform-density body of total ``mass`` (kg) with the shape of ``integrals``: its
    centre of mass (3,) (m) and inertia tensor about it (3, 3) (kg m^2)."""
    mass = float(mass)
    if not (math.isfinite(mass) and mass > 0.0):
        raise ValueError(f"mass must be positive and finite (kg), got {mass!r}")
    rho = mass / integrals.volume
    return (np.array(integrals.centroid.tolist()),
            np.array([[e * rho for e in row] for row in integrals.inertia_unit.tolist()]))
