"""Design validation, the mass formula, target properties and the CQI of known shapes."""
import math

import numpy as np
import pytest

from tethernet_ros.core.design import (REFERENCE_DESIGNS, Design, DesignError, load_design)
from tethernet_ros.core.metrics import (capture_quality_index, capture_verdict,
                                        hull_volume_area, wilson_interval)
from tethernet_ros.core.shapes import target_shape
from tethernet_ros.core.target import TargetConfig


@pytest.mark.parametrize("name, mass", [("baseline", 5.31), ("suboptimal", 29.52), ("mass-min", 7.53)])
def test_mass_formula_reproduces_reference_masses(name, mass):
    assert REFERENCE_DESIGNS[name].mass() == pytest.approx(mass, abs=0.02)


def test_vector_round_trip_and_bounds():
    d = REFERENCE_DESIGNS["time-min"]
    assert Design.from_vector(d.to_vector()) == d
    assert Design.from_dict(d.to_dict()) == d
    assert d.within_bounds()
    assert not REFERENCE_DESIGNS["baseline"].within_bounds()     # m_c = 0.5 < 1


@pytest.mark.parametrize("changes, field", [
    ({"m_c": float("nan")}, "m_c"),
    ({"L_n": 0.0}, "L_n"),
    ({"r_n": -0.001}, "r_n"),
    ({"d_L": float("inf")}, "d_L"),
    ({"V_e": (1.0, 1.0, 0.0)}, r"V_e\[2\]"),
    ({"V_e": (-1.0, 1.0, 2.0)}, r"V_e\[0\]"),
])
def test_bad_values_name_the_field(changes, field):
    data = REFERENCE_DESIGNS["baseline"].to_dict()
    data.update(changes)
    with pytest.raises(DesignError, match=field):
        Design.from_dict(data)


def test_load_design_errors(tmp_path):
    with pytest.raises(DesignError, match="unknown design"):
        load_design("nonsense")
    missing = tmp_path / "x.yaml"
    with pytest.raises(DesignError, match="does not exist"):
        load_design(str(missing))
    bad = tmp_path / "bad.yaml"
    bad.write_text("m_c: [1, 2\nL_n: 3\n")
    with pytest.raises(DesignError, match="not valid YAML"):
        load_design(str(bad))
    partial = tmp_path / "partial.yaml"
    partial.write_text("m_c: 1.0\nL_n: 20\nr_n: 0.001\nd_L: 20\nd_c: 0.5\n")
    with pytest.raises(DesignError, match="V_e"):
        load_design(str(partial))
    good = tmp_path / "good.yaml"
    good.write_text("m_c: 1.0\nL_n: 20\nr_n: 0.001\nd_L: 20\nV_e: [1, 1, 5]\nd_c: 0.5\n")
    assert load_design(str(good)).V_e == (1.0, 1.0, 5.0)


def test_target_properties_analytic_and_mesh():
    t = target_shape(TargetConfig())
    R, L = 1.95, 10.4
    assert t.volume == pytest.approx(math.pi * R * R * L)
    assert t.area == pytest.approx(2 * math.pi * R * R + 2 * math.pi * R * L)
    assert t.min_surface_distance == pytest.approx(R)
    mesh = t.trimesh()
    assert mesh.volume == pytest.approx(t.volume, rel=1e-3)
    assert mesh.area == pytest.approx(t.area, rel=1e-3)
    assert t.inertia[0] == pytest.approx(0.5 * 8300 * R * R)


def test_target_with_nozzle_consistent_with_mesh():
    t = target_shape(TargetConfig(nozzle=True))
    mesh = t.trimesh()
    assert mesh.volume == pytest.approx(t.volume, rel=2e-3)
    # the concatenated meshes both carry the shared disk, which is inside the union
    shared = 2 * math.pi * t.config.nozzle_base_radius**2
    assert mesh.area - shared == pytest.approx(t.area, rel=2e-3)
    assert abs(mesh.center_mass[0]) < 1e-3          # CoM at the body origin
    d, n = t.signed_distance([-10.4 / 2 - t.com_offset - 1.0, 0.0, 0.0])
    assert d < 0                                     # inside the nozzle


def test_signed_distance_of_cylinder():
    t = target_shape(TargetConfig())
    d, n = t.signed_distance([0.0, 3.0, 0.0])
    assert d == pytest.approx(3.0 - 1.95) and np.allclose(n, [0, 1, 0])
    d, n = t.signed_distance([6.2, 0.0, 0.5])
    assert d == pytest.approx(1.0) and np.allclose(n, [1, 0, 0])
    d, n = t.signed_distance([5.2 + 3.0, 1.95 + 4.0, 0.0])
    assert d == pytest.approx(5.0)


def _cube(a, centre=(0, 0, 0), n=5):
    g = np.linspace(-a / 2, a / 2, n)
    pts = np.array([[x, y, z] for x in g for y in g for z in g]) + np.asarray(centre)
    return pts


def test_cqi_of_known_shapes():
    t = target_shape(TargetConfig())
    Vt, St, Lc = t.volume, t.area, t.min_surface_distance
    # a cube of side 4 m centred on the target
    pts = _cube(4.0)
    m = np.ones(len(pts))
    terms = capture_quality_index(pts, m, np.zeros(3), Vt, St, Lc)
    assert terms.hull_volume == pytest.approx(64.0)
    assert terms.hull_area == pytest.approx(96.0)
    assert terms.cqi == pytest.approx(0.1 * abs(64 - Vt) / Vt + 0.1 * abs(96 - St) / St)
    # the same cube shifted by 3 m: the distance term 0.8 q / L_c adds
    terms2 = capture_quality_index(pts + [0, 3.0, 0], m, np.zeros(3), Vt, St, Lc)
    assert terms2.cqi - terms.cqi == pytest.approx(0.8 * 3.0 / 1.95)
    # a flat square net: zero volume, both faces count as area
    g = np.linspace(-5, 5, 17)
    flat = np.array([[x, y, 0.0] for x in g for y in g])
    v, s = hull_volume_area(flat)
    assert v == 0.0 and s == pytest.approx(200.0)
    # points on the target's own surface: the CQI of a perfect wrap is ~0
    mesh = t.trimesh()
    terms3 = capture_quality_index(mesh.vertices, np.ones(len(mesh.vertices)), np.zeros(3), Vt, St, Lc)
    assert terms3.cqi < 2e-3


def test_verdict_rule():
    assert capture_verdict(1.9, 10) == (True, "")
    ok, why = capture_verdict(2.1, 12)
    assert not ok and "CQI" in why
    ok, why = capture_verdict(1.0, 9)
    assert not ok and "locked pairs" in why


def test_wilson_interval_known_value():
    lo, hi = wilson_interval(98, 100)
    assert lo == pytest.approx(0.9300, abs=5e-4) and hi == pytest.approx(0.9945, abs=5e-4)
