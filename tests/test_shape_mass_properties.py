"""Mass properties of triangle meshes: tethernet_ros/core/shapes/mass_properties.py."""
import math

import numpy as np
import pytest
import trimesh

from tethernet_ros.core.shapes.mass_properties import (
    check_inertia,
    mesh_mass_properties,
    principal_axes,
    rigid_body,
)


def _rotation(seed):
    """A random proper rotation matrix."""
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def _close(actual, expected, rel, scale=None):
    actual, expected = np.asarray(actual, float), np.asarray(expected, float)
    scale = np.abs(expected).max() if scale is None else scale
    assert np.abs(actual - expected).max() <= rel * scale, (actual, expected)


@pytest.mark.parametrize("extents", [(1.0, 1.0, 1.0), (2.0, 3.0, 5.0)])
def test_box_matches_analytic(extents):
    a, b, c = extents
    box = trimesh.creation.box(extents=extents)
    mp = mesh_mass_properties(box.vertices, box.faces)
    v = a * b * c
    assert mp.volume == pytest.approx(v, rel=1e-12)
    assert mp.area == pytest.approx(2 * (a * b + b * c + c * a), rel=1e-12)
    _close(mp.centroid, [0, 0, 0], 1e-12, scale=max(extents))
    expected = np.diag([v * (b * b + c * c) / 12, v * (a * a + c * c) / 12, v * (a * a + b * b) / 12])
    _close(mp.inertia_unit, expected, 1e-12)
    assert np.array_equal(mp.inertia_unit, mp.inertia_unit.T)


def test_faceted_cylinder_matches_polygon_prism_and_cylinder():
    r, h, n = 1.95, 10.4, 256
    cyl = trimesh.creation.cylinder(radius=r, height=h, sections=n)
    mp = mesh_mass_properties(cyl.vertices, cyl.faces)
    # exact values of the faceted solid, a prism on a regular n-gon of circumradius r:
    # area n r^2 sin(a) / 2, polar second moment n r^4 sin(a) (2 + cos(a)) / 12, a = 2 pi / n
    alpha = 2 * math.pi / n
    area = n * r * r * math.sin(alpha) / 2
    polar = n * r**4 * math.sin(alpha) * (2 + math.cos(alpha)) / 12
    side = n * 2 * r * math.sin(alpha / 2) * h
    i_axis, i_side = h * polar, h * polar / 2 + area * h**3 / 12
    assert mp.volume == pytest.approx(area * h, rel=1e-12)
    assert mp.area == pytest.approx(2 * area + side, rel=1e-12)
    _close(mp.centroid, [0, 0, 0], 1e-12, scale=h)
    _close(mp.inertia_unit, np.diag([i_side, i_side, i_axis]), 1e-12)
    # the round cylinder: faceting takes a fraction ~ alpha^2 / 6 = 1e-4 off the area and
    # ~ alpha^2 / 3 = 2e-4 off the polar moment, so 5e-4 is tight yet passes
    vol = math.pi * r * r * h
    assert mp.volume == pytest.approx(vol, rel=5e-4)
    assert mp.volume < vol  # inscribed polygon
    _close(mp.inertia_unit, np.diag([vol * (3 * r * r + h * h) / 12] * 2 + [vol * r * r / 2]), 5e-4)


@pytest.mark.parametrize("shape", ["box", "icosphere"])
def test_agrees_with_trimesh(shape):
    if shape == "box":
        mesh = trimesh.creation.box(extents=(2.0, 3.0, 5.0))
        transform = np.eye(4)
        transform[:3, :3], transform[:3, 3] = _rotation(3), [1.5, -2.0, 3.0]
        mesh.apply_transform(transform)
    else:
        mesh = trimesh.creation.icosphere(subdivisions=3, radius=1.7)
        mesh.apply_translation([0.3, -0.2, 0.9])
    mp = mesh_mass_properties(mesh.vertices, mesh.faces)
    ref = mesh.mass_properties  # density 1
    assert mp.volume == pytest.approx(ref.volume, rel=1e-12)
    _close(mp.centroid, ref.center_mass, 1e-12)
    _close(mp.inertia_unit, ref.inertia, 1e-12)
    assert mp.area == pytest.approx(mesh.area, rel=1e-12)


def test_face_order_does_not_change_a_bit():
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=0.8)
    mesh.apply_translation([12.3, -4.5, 6.7])
    first = mesh_mass_properties(mesh.vertices, mesh.faces)
    perm = np.random.default_rng(5).permutation(len(mesh.faces))
    assert not np.array_equal(perm, np.arange(len(perm)))
    second = mesh_mass_properties(mesh.vertices, mesh.faces[perm])
    assert first.volume == second.volume and first.area == second.area
    assert first.centroid.tolist() == second.centroid.tolist()
    assert first.inertia_unit.tolist() == second.inertia_unit.tolist()


def test_inverted_faces_are_refused():
    box = trimesh.creation.box(extents=(2.0, 3.0, 5.0))
    with pytest.raises(ValueError, match="oriented inward"):
        mesh_mass_properties(box.vertices, box.faces[:, ::-1])


def test_principal_axes_of_diagonal_tensors_are_exact():
    moments, axes = principal_axes(np.diag([3.0, 1.0, 2.0]))
    assert moments.tolist() == [1.0, 2.0, 3.0]
    assert axes.tolist() == [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    # a symmetric top (Zenit-2: Ixx < Iyy == Izz) keeps exactly its body axes
    moments, axes = principal_axes(np.diag([1.0, 5.0, 5.0]))
    assert moments.tolist() == [1.0, 5.0, 5.0]
    assert axes.tolist() == np.eye(3).tolist()
    # an odd permutation: the third axis is negated to keep the frame right-handed
    moments, axes = principal_axes(np.diag([2.0, 1.0, 3.0]))
    assert moments.tolist() == [1.0, 2.0, 3.0]
    assert axes.tolist() == [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]


@pytest.mark.parametrize("seed", [0, 1, 2, 13])  # 13: the raw second Jacobi axis points negative
def test_principal_axes_of_rotated_tensor(seed):
    rot = _rotation(seed)
    moments, axes = principal_axes(rot @ np.diag([1.0, 2.0, 3.0]) @ rot.T)
    _close(moments, [1.0, 2.0, 3.0], 1e-12)
    for k in range(3):
        sign = 1.0 if axes[:, k] @ rot[:, k] > 0 else -1.0
        _close(axes[:, k], sign * rot[:, k], 1e-10, scale=1.0)
        assert k == 2 or axes[np.argmax(np.abs(axes[:, k])), k] > 0  # the sign rule
    _close(axes[:, 2], np.cross(axes[:, 0], axes[:, 1]), 1e-13, scale=1.0)  # right-handed
    _close(axes.T @ axes, np.eye(3), 1e-13, scale=1.0)
    assert np.linalg.det(axes) > 0.999


def test_principal_axes_of_rotated_symmetric_top():
    rot = _rotation(4)
    tensor = rot @ np.diag([1.0, 5.0, 5.0]) @ rot.T
    moments, axes = principal_axes(tensor)
    _close(moments, [1.0, 5.0, 5.0], 1e-12)
    assert abs(axes[:, 0] @ rot[:, 0]) == pytest.approx(1.0, abs=1e-12)
    _close(axes @ np.diag(moments) @ axes.T, tensor, 1e-12)
    assert np.linalg.det(axes) > 0.999
    again = principal_axes(tensor)
    assert again[0].tolist() == moments.tolist() and again[1].tolist() == axes.tolist()


def test_check_inertia():
    with pytest.raises(ValueError, match=r"'inertia'.*\(1, 1, 5\) kg m\^2 violate I1 \+ I2 >= I3"):
        check_inertia((1.0, 1.0, 5.0))
    with pytest.raises(ValueError, match="'spin_inertia'.*not positive definite"):
        check_inertia([[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]], field="spin_inertia")
    with pytest.raises(ValueError, match="not symmetric"):
        check_inertia([[2.0, 0.1, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]])
    with pytest.raises(ValueError, match="violate"):  # a rotated impossible tensor
        rot = _rotation(6)
        check_inertia(rot @ np.diag([1.0, 2.0, 3.1]) @ rot.T)
    box = trimesh.creation.box(extents=(2.0, 3.0, 5.0))
    box.apply_transform(np.block([[_rotation(7), np.zeros((3, 1))], [np.zeros((1, 3)), np.ones((1, 1))]]))
    _, inertia = rigid_body(mesh_mass_properties(box.vertices, box.faces), 300.0)
    _close(check_inertia(inertia), [325.0, 725.0, 850.0], 1e-12)
    assert check_inertia((1.0, 1.0, 2.0)) == (1.0, 1.0, 2.0)  # a flat plate, the limit


def test_rigid_body_scales_by_density():
    box = trimesh.creation.box(extents=(2.0, 3.0, 5.0))
    box.apply_translation([1.0, 2.0, -3.0])
    com, inertia = rigid_body(mesh_mass_properties(box.vertices, box.faces), 300.0)
    _close(com, [1.0, 2.0, -3.0], 1e-12)
    _close(inertia, np.diag([850.0, 725.0, 325.0]), 1e-12)
    with pytest.raises(ValueError, match="mass"):
        rigid_body(mesh_mass_properties(box.vertices, box.faces), 0.0)
