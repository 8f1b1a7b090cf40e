"""The shape type every target kind implements (``shapes``: the body frame and units)."""
from __future__ import annotations

import numpy as np


class Shape:
    """What every target kind provides (subclasses fill the attributes in ``__init__``).

    Attributes: ``name`` (str); ``kind`` (a key of ``shapes._kinds()``); ``mass`` (kg);
    ``inertia`` (3,) principal moments about the CoM in body axes (kg m^2); ``volume``
    (m^3); ``area`` (m^2); ``min_surface_distance`` L_c (m, from the CoM to the nearest
    surface point); ``bounding_radius`` (m, a sphere about the CoM enclosing the body);
    ``extent`` (half length along body x, radius about body x) of a cylinder about the CoM
    enclosing the body (m; the adaptive closing policy's prediction, docs/model.md §14);
    ``repairs``: what was repaired of its file (one line each; none for a built-in shape).
    """

    name: str
    kind: str
    mass: float
    inertia: np.ndarray
    volume: float
    area: float
    min_surface_distance: float
    bounding_radius: float
    extent: tuple[float, float]
    repairs: tuple | list = ()

    def geometry(self):
        """The kernel's table of this shape (``kernel.geometry.TargetGeometry``)."""
        raise NotImplementedError

    def signed_distance(self, p_body) -> tuple[float, np.ndarray]:
        """Signed distance (m, negative inside) of a body-frame point and the outward unit
        normal, by the kernel's own query (the same numbers an episode sees)."""
        from ..kernel import target_signed_distance

        d, n = target_signed_distance(np.asarray(p_body, dtype=np.float64), self.geometry())
        return float(d), n

    def signed_distances(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Signed distances (N,) and outward normals (N, 3) of body-frame points (N, 3)."""
        from ..kernel import target_signed_distances

        return target_signed_distances(np.ascontiguousarray(points, dtype=np.float64),
                                       self.geometry())

    def trimesh(self):
        """A trimesh of the shape in the body frame (figures, markers, checks; never on an
        episode's path)."""
        raise NotImplementedError
