"""The ``revolution`` shape kind: the Zenit-2 second stage of the source as exact solids of
revolution (the default target; docs/model.md §1, §15).

The target is axisymmetric about its body x axis.  Its collision geometry is a union of
convex solids of revolution, each given by its meridional polygon: vertices (a, r) with a
the axial coordinate (m, body frame, origin at the centre of mass) and r the signed radial
coordinate (m), symmetric about r = 0.  The signed distance of a point is the minimum over
the solids of the 2D polygon distance in its meridional plane (exact outside the body).

Defaults (docs/model.md §1): cylinder of diameter 3.9 m and length 10.4 m, dry mass 8300 kg,
uniform density.  An engine-nozzle frustum may be added behind the -x end.
"""
from __future__ import annotations

import math
from functools import cached_property

import numpy as np

from .. import detmath
from ..kernel.geometry import revolution_geometry
from .base import Shape


class RevolutionShape(Shape):
    """The stage of a ``TargetConfig`` of kind ``revolution`` (its diameter, length, mass
    and nozzle fields); every property in the body frame, about the CoM."""

    kind = "revolution"

    def __init__(self, config):
        self.config = config
        self.name = config.name
        self.mass = float(config.mass)

    @classmethod
    def from_config(cls, config) -> RevolutionShape:
        return cls(config)

    # -- solids in the body frame with origin at the geometric centre of the cylinder --
    def _raw_polygons(self) -> list[np.ndarray]:
        c = self.config
        R, L = c.diameter / 2, c.length
        polys = [np.array([[-L / 2, -R], [L / 2, -R], [L / 2, R], [-L / 2, R]])]
        if c.nozzle:
            a0, a1 = -L / 2, -L / 2 - c.nozzle_length
            r0, r1 = c.nozzle_base_radius, c.nozzle_exit_radius
            polys.append(np.array([[a1, -r1], [a0, -r0], [a0, r0], [a1, r1]]))
        return polys

    def _revolved_segments(self) -> list[tuple[float, float, float, float]]:
        """The solids as frusta (a0, a1, r0, r1) about the cylinder's centre (m): axial
        ends a0 < a1 and the radius at each end."""
        c = self.config
        R, L = c.diameter / 2, c.length
        segs = [(-L / 2, L / 2, R, R)]
        if c.nozzle:
            segs.append((-L / 2 - c.nozzle_length, -L / 2, c.nozzle_exit_radius,
                         c.nozzle_base_radius))
        return segs

    @cached_property
    def _mass_integrals(self) -> tuple[float, float, float, float]:
        """Per unit density, over all solids: volume (m^3), first axial moment (m^4) and the
        second moments about the axis and about a transverse axis through the cylinder's
        centre (m^5).  Three-point Gauss-Legendre per frustum, exact for these integrands
        (polynomials of degree 4 in a), in IEEE operations only (no mesh, no BLAS)."""
        g = math.sqrt(0.6)
        nodes, weights = (-g, 0.0, g), (5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0)
        vol = first = axial = transverse = 0.0
        for a0, a1, r0, r1 in self._revolved_segments():
            half, mid = 0.5 * (a1 - a0), 0.5 * (a1 + a0)
            for t, w in zip(nodes, weights):
                a = mid + half * t
                r = r0 + (r1 - r0) * (t + 1.0) * 0.5
                r2 = r * r
                wh = w * half * math.pi
                vol += wh * r2
                first += wh * r2 * a
                axial += wh * 0.5 * r2 * r2
                transverse += wh * r2 * (0.25 * r2 + a * a)
        return vol, first, axial, transverse

    @cached_property
    def com_offset(self) -> float:
        """Axial position (m) of the centre of mass from the cylinder's centre."""
        if not self.config.nozzle:
            return 0.0
        vol, first, _, _ = self._mass_integrals
        return first / vol

    @cached_property
    def polygons(self) -> list[np.ndarray]:
        """Meridional polygons (a, r) relative to the centre of mass (m)."""
        return [p - np.array([self.com_offset, 0.0]) for p in self._raw_polygons()]

    @cached_property
    def volume(self) -> float:
        """V_t (m^3)."""
        c = self.config
        R, L = c.diameter / 2, c.length
        v = math.pi * R * R * L
        if c.nozzle:
            h, r0, r1 = c.nozzle_length, c.nozzle_base_radius, c.nozzle_exit_radius
            v += math.pi * h / 3 * (r0 * r0 + r0 * r1 + r1 * r1)
        return v

    @cached_property
    def area(self) -> float:
        """S_t (m^2): outer surface of the union (the shared disk is interior)."""
        c = self.config
        R, L = c.diameter / 2, c.length
        s = 2 * math.pi * R * R + 2 * math.pi * R * L
        if c.nozzle:
            h, r0, r1 = c.nozzle_length, c.nozzle_base_radius, c.nozzle_exit_radius
            s += (math.pi * (r0 + r1) * detmath.hypot(h, r1 - r0) + math.pi * r1 * r1
                  - math.pi * r0 * r0)
        return s

    @cached_property
    def inertia(self) -> np.ndarray:
        """Principal moments (Ixx, Iyy, Izz) about the CoM (kg m^2), uniform density."""
        c = self.config
        R, L, M = c.diameter / 2, c.length, c.mass
        if not c.nozzle:
            R2 = R * R
            return np.array([0.5 * M * R2, M * (3 * R2 + L * L) / 12, M * (3 * R2 + L * L) / 12])
        vol, _, axial, transverse = self._mass_integrals
        density = M / vol
        d = self.com_offset
        i_t = density * transverse - M * d * d   # parallel-axis shift to the CoM
        return np.array([density * axial, i_t, i_t])

    @cached_property
    def bounding_radius(self) -> float:
        """Radius (m) of a sphere about the CoM enclosing the body."""
        return max(detmath.hypot(a, r) for p in self.polygons for a, r in p)

    @cached_property
    def min_surface_distance(self) -> float:
        """L_c (m): smallest distance from the CoM to the surface."""
        return -self.signed_distance(np.zeros(3))[0]

    @cached_property
    def extent(self) -> tuple[float, float]:
        """(half length, radius) (m) of the stage's cylinder (the adaptive policy's
        prediction reads the cylinder, the nozzle left out: docs/model.md §14)."""
        c = self.config
        return (c.length / 2, c.diameter / 2)

    @cached_property
    def _geometry(self):
        verts, offsets = self.packed_polygons()
        return revolution_geometry(self.cylinder(), verts, offsets)

    def geometry(self):
        """The kernel's table: the cylinder and the other solids' meridional polygons."""
        return self._geometry

    def cylinder(self) -> np.ndarray:
        """[axial centre, half length, radius] (m) of the stage's cylinder about the CoM."""
        c = self.config
        return np.array([-self.com_offset, c.length / 2, c.diameter / 2])

    def packed_polygons(self) -> tuple[np.ndarray, np.ndarray]:
        """(vertices (K, 2), offsets (P + 1,)) of the solids other than the cylinder, for
        the numba kernels."""
        polys = self.polygons[1:]
        if not polys:
            return np.zeros((0, 2)), np.zeros(1, dtype=np.int64)
        verts = np.ascontiguousarray(np.concatenate(polys), dtype=np.float64)
        offsets = np.cumsum([0] + [len(p) for p in polys]).astype(np.int64)
        return verts, offsets

    def trimesh(self):
        """A single trimesh of the target in the body frame about the CoM (for figures,
        markers and checks; never on an episode's path)."""
        import trimesh

        c = self.config
        R, L = c.diameter / 2, c.length
        rot = trimesh.transformations.rotation_matrix(math.pi / 2, [0, 1, 0])  # z -> x
        parts = [trimesh.creation.cylinder(radius=R, height=L, sections=256, transform=rot)]
        if c.nozzle:
            h, r0, r1 = c.nozzle_length, c.nozzle_base_radius, c.nozzle_exit_radius
            # frustum as a revolved trapezoid about z, then rotated so +z -> -x
            prof = np.array([[0.0, 0.0], [r0, 0.0], [r1, h], [0.0, h]])
            fr = trimesh.creation.revolve(prof, sections=256)
            T = trimesh.transformations.rotation_matrix(-math.pi / 2, [0, 1, 0])
            T[:3, 3] = [-L / 2, 0.0, 0.0]
            fr.apply_transform(T)
            parts.append(fr)
        mesh = trimesh.util.concatenate(parts)
        mesh.apply_translation([-self.com_offset, 0.0, 0.0])
        return mesh
