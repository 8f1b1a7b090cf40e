"""A target is a shape (docs/model.md §15): the mesh kind's query against an independent
exact distance, its body frame, repairs and refusals, determinism, the catalogue, the
revolution kind kept as before, and contact with a thin plate in both kernels."""
from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from tethernet_ros.core.config import ConfigError, SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.core.episode import CaptureSimulation, run_episode
from tethernet_ros.core.noise import NoiseModel
from tethernet_ros.core.scenario import scenario_for
from tethernet_ros.core.shapes import target_shape
from tethernet_ros.core.shapes.catalogue import CATALOGUE
from tethernet_ros.core.shapes.mesh import query_tables
from tethernet_ros.core.target import TargetConfig, TargetError, target_fields


@pytest.fixture(autouse=True)
def _own_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("TETHERNET_CACHE", str(tmp_path / "cache"))


def _mesh_config(tmp_path, mesh, name="part", **kw) -> TargetConfig:
    path = tmp_path / f"{name}.stl"
    mesh.export(path)
    return TargetConfig(mesh=str(path), **{"mass": 100.0, **kw})


def _segment_d2(p, a, b):
    ab = b - a
    t = np.clip(((p - a) * ab).sum(-1) / (ab * ab).sum(-1), 0.0, 1.0)
    q = a + t[..., None] * ab
    return ((p - q) ** 2).sum(-1), q


def _reference_sd(mesh, points):
    """Exact signed distance and nearest point, independent of the kernel's query: brute
    force over every triangle (the nearest of its plane's foot, when inside it, and its
    three edges), the sign by the generalised winding number (solid angles, van
    Oosterom and Strackee 1983)."""
    tri = np.asarray(mesh.triangles)
    out_d, out_q, wind = [], [], []
    for p in points:
        a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
        n = np.cross(b - a, c - a)
        n /= np.linalg.norm(n, axis=1)[:, None]
        h = ((p - a) * n).sum(1)
        f = p - h[:, None] * n
        inside = np.ones(len(tri), bool)
        for u, v in ((a, b), (b, c), (c, a)):
            inside &= (np.cross(v - u, f - u) * n).sum(1) >= 0.0
        d2 = np.where(inside, h * h, np.inf)
        q = f.copy()
        for u, v in ((a, b), (b, c), (c, a)):
            e2, eq = _segment_d2(p, u, v)
            better = e2 < d2
            d2 = np.where(better, e2, d2)
            q[better] = eq[better]
        k = int(np.argmin(d2))
        out_d.append(math.sqrt(d2[k]))
        out_q.append(q[k])
        ra, rb, rc = a - p, b - p, c - p
        la, lb, lc = (np.linalg.norm(r, axis=1) for r in (ra, rb, rc))
        num = (ra * np.cross(rb, rc)).sum(1)
        den = la * lb * lc + (ra * rb).sum(1) * lc + (rb * rc).sum(1) * la + (rc * ra).sum(1) * lb
        wind.append(np.arctan2(num, den).sum() / (2 * math.pi))
    d = np.array(out_d)
    return np.where(np.array(wind) > 0.5, -d, d), np.array(out_q)


@pytest.mark.parametrize("name", ["zenit-2-nozzle", "envisat"])
def test_mesh_query_is_the_exact_signed_distance(name):
    shape = target_shape(TargetConfig(name=name))
    mesh = shape.trimesh()
    rng = np.random.default_rng(3)
    lo, hi = mesh.bounds
    pts = rng.uniform(lo - 0.8, hi + 0.8, size=(1500, 3))
    ref, nearest = _reference_sd(mesh, pts)
    near = ref <= 0.8                  # inside, or outside within the 1 m band: exact
    sd, nrm = shape.signed_distances(pts)
    assert near.sum() > 300 and (ref < -0.8).sum() > 10
    assert np.max(np.abs(sd[near] - ref[near])) < 1e-9
    far = ~near
    assert np.all(sd[far] <= np.abs(ref[far]) + 1e-9)   # elsewhere a lower bound ...
    assert np.all(sd[far] > 0.0)                        # ... of a point outside
    # the normal points away from the nearest surface point, unit length
    close = near & (np.abs(ref) > 1e-6)
    q = nearest[close]
    expect = (pts[close] - q) / np.linalg.norm(pts[close] - q, axis=1)[:, None]
    expect *= np.sign(ref[close])[:, None]
    assert np.max(np.abs(nrm[close] - expect)) < 1e-6


def test_deep_interior_points_are_exact():
    shape = target_shape(TargetConfig(name="zenit-2-cylinder"))
    # the centre and points along the axis: 1.95 m (faceted) from the side wall
    for x in (0.0, 2.0, -3.0):
        d, _ = shape.signed_distance([x, 0.0, 0.0])
        assert d == pytest.approx(-1.95 * math.cos(math.pi / 128), abs=1e-6)
    assert shape.min_surface_distance == pytest.approx(1.95 * math.cos(math.pi / 128), abs=1e-6)


def test_mesh_zenit_matches_the_analytic_stage():
    analytic = target_shape(TargetConfig())
    mesh = target_shape(TargetConfig(name="zenit-2-cylinder"))
    # a 128-sided prism inside the circle: volume and moments low by the faceting, about
    # 4e-4 (area ratio 1 - (2 pi / 128)^2 / 6)
    assert mesh.volume == pytest.approx(analytic.volume, rel=6e-4)
    assert mesh.volume < analytic.volume
    np.testing.assert_allclose(mesh.inertia, analytic.inertia, rtol=1e-3)
    assert mesh.extent == pytest.approx(analytic.extent, abs=1e-6)
    # the body frame: least inertia along x (the stage's long axis)
    assert mesh.inertia[0] < mesh.inertia[1] and mesh.inertia[0] < mesh.inertia[2]
    for p in ([0.0, 0.0, 3.0], [6.0, 0.0, 0.0], [5.5, 2.2, 0.0]):
        assert mesh.signed_distance(p)[0] == pytest.approx(analytic.signed_distance(p)[0],
                                                            abs=2e-3)


def test_body_frame_orders_the_principal_axes(tmp_path):
    box = trimesh.creation.box((2.0, 3.0, 6.0))       # least inertia about its 6 m side
    R = trimesh.transformations.rotation_matrix(0.7, [1.0, 2.0, 0.5])
    box.apply_transform(R)
    box.apply_translation([4.0, -1.0, 2.0])
    shape = target_shape(_mesh_config(tmp_path, box, mass=360.0))
    m = 360.0
    Ia, Ib, Ic = (m * (3 ** 2 + 6 ** 2) / 12, m * (2 ** 2 + 6 ** 2) / 12,
                  m * (2 ** 2 + 3 ** 2) / 12)   # about the 2, 3 and 6 m sides
    # x: least (the 6 m side), y: greatest (the 2 m side), z: the middle one (to STL's
    # float32 vertices)
    np.testing.assert_allclose(shape.inertia, [Ic, Ia, Ib], rtol=1e-6)
    assert shape.extent[0] == pytest.approx(3.0, abs=1e-6)
    axes = shape.axes
    assert np.linalg.det(axes) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(np.abs(axes[:, 0]), np.abs(R[:3, 2]), atol=1e-6)
    assert shape.min_surface_distance == pytest.approx(1.0, abs=1e-6)


def test_given_com_and_inertia_are_used_and_checked(tmp_path):
    box = trimesh.creation.box((2.0, 2.0, 2.0))
    cfg = _mesh_config(tmp_path, box, com=(0.1, 0.0, 0.0), inertia=(10.0, 20.0, 25.0, 0, 0, 0))
    shape = target_shape(cfg)
    np.testing.assert_allclose(shape.inertia, [10.0, 25.0, 20.0])
    assert shape.signed_distance([0.0, 0.0, 0.0])[0] == pytest.approx(-0.9)
    with pytest.raises(TargetError, match="inertia"):
        _mesh_config(tmp_path, box, name="bad", inertia=(1.0, 1.0, 5.0))


def _tube():
    tube = trimesh.creation.cylinder(radius=0.5, height=2.0, sections=32)
    side = np.abs(tube.face_normals[:, 2]) < 0.5
    return trimesh.Trimesh(tube.vertices, tube.faces[side], process=False)


@pytest.mark.parametrize("make, repaired", [
    (lambda: trimesh.Trimesh(trimesh.creation.box((1, 2, 3)).vertices,
                             trimesh.creation.box((1, 2, 3)).faces[:-1], process=False),
     "closed holes"),
    (lambda: trimesh.Trimesh(trimesh.creation.box((1, 2, 3)).vertices,
                             trimesh.creation.box((1, 2, 3)).faces[:, ::-1], process=False),
     "inverted normals"),
], ids=["hole", "inverted"])
def test_repairable_meshes_are_repaired_and_reported(tmp_path, make, repaired):
    with pytest.warns(UserWarning, match=repaired):
        shape = target_shape(_mesh_config(tmp_path, make()))
    assert shape.volume == pytest.approx(6.0)
    assert any(repaired.split()[-1] in r for r in shape.repairs)


@pytest.mark.parametrize("make, units, defect", [
    (_tube, "m", "open surface"),
    (lambda: trimesh.creation.box((2000.0, 3000.0, 1000.0)), "m", "in mm\\? give units 'mm'"),
    (lambda: trimesh.creation.box((0.01, 0.01, 0.01)), "m", "must be 0.05-200 m"),
    (lambda: trimesh.util.concatenate([trimesh.creation.box((2, 2, 2)),
                                       trimesh.creation.box((1, 1, 3))]), "m",
     "2 separate bodies that overlap; a target must be one body"),
    # two boxes 5 m apart: accepted before, its centre of mass in the gap and L_c 1.158 m
    # where the true distance is 1.5 m (issue 54)
    (lambda: trimesh.util.concatenate([
        trimesh.creation.box((1, 1, 1)),
        trimesh.creation.box((1, 1, 1), transform=trimesh.transformations.translation_matrix(
            (5.0, 0.0, 0.0)))]), "m", "2 separate bodies apart; a target must be one body"),
], ids=["open", "millimetres", "tiny", "overlapping", "apart"])
def test_bad_meshes_are_refused_naming_file_and_defect(tmp_path, make, units, defect):
    with pytest.raises(TargetError, match=defect) as err:
        _mesh_config(tmp_path, make(), units=units)
    assert "part.stl" in str(err.value) and "\n" not in str(err.value)


def test_an_empty_file_is_refused_in_the_tool_s_words(tmp_path):
    """An empty mesh file gets the tool's message, not numpy's ("need at least one array
    to concatenate", issue 54)."""
    path = tmp_path / "part.stl"
    path.write_bytes(b"")
    with pytest.raises(TargetError, match=r"part\.stl: the file is empty \(0 bytes\)"):
        target_shape(TargetConfig(mesh=str(path), mass=100.0))


def test_millimetres_accepted_with_units(tmp_path):
    shape = target_shape(_mesh_config(tmp_path, trimesh.creation.box((2000.0, 3000.0, 1000.0)),
                                      units="mm"))
    assert shape.volume == pytest.approx(6.0)


def test_bad_target_settings_name_the_field(tmp_path):
    with pytest.raises(TargetError, match="'mass'"):
        TargetConfig(mesh=str(tmp_path / "x.stl"))
    with pytest.raises(TargetError, match="'name'"):
        TargetConfig(name="hubble")
    with pytest.raises(TargetError, match="'units'"):
        _mesh_config(tmp_path, trimesh.creation.box((1, 1, 1)), units="furlong")
    with pytest.raises(TargetError, match="is not a file"):
        target_fields(str(tmp_path / "missing.obj"))
    with pytest.raises(ConfigError, match="target field 'name'"):
        SimConfig.from_dict({"target": {"name": "hubble"}})


def test_a_changed_file_is_refused_against_its_recorded_hash(tmp_path):
    cfg = _mesh_config(tmp_path, trimesh.creation.box((1, 2, 3)))
    trimesh.creation.box((1, 2, 4)).export(cfg.mesh)
    with pytest.raises(TargetError, match="the file changed"):
        TargetConfig(mesh=cfg.mesh, mass=100.0, mesh_sha256=cfg.mesh_sha256)


@pytest.mark.parametrize("fmt", ["obj", "ply", "off", "glb"])
def test_formats_give_the_same_body(tmp_path, fmt):
    envisat = target_shape(TargetConfig(name="envisat")).trimesh()
    path = tmp_path / f"envisat.{fmt}"
    envisat.export(path)
    shape = target_shape(TargetConfig(mesh=str(path), mass=8211.0))
    ref = target_shape(TargetConfig(name="envisat"))
    # the same body to the formats' rounding of the vertices (OBJ and OFF write text)
    assert shape.volume == pytest.approx(ref.volume, rel=1e-8)
    np.testing.assert_allclose(shape.inertia, ref.inertia, rtol=1e-7)


def test_query_tables_are_the_same_bits_built_or_cached(tmp_path):
    shape = target_shape(TargetConfig(name="zenit-2-nozzle"))
    built = query_tables(shape.tris, shape.faces, len(shape.vertices))     # builds (fresh cache)
    cached = query_tables(shape.tris, shape.faces, len(shape.vertices))    # reads it
    assert list((tmp_path / "cache" / "shapes").glob("*.npz"))
    for k in built:
        assert built[k].tobytes() == cached[k].tobytes(), k


def test_catalogue_entries_load_as_closed_bodies():
    for name, entry in CATALOGUE.items():
        shape = target_shape(TargetConfig(name=name))
        assert shape.mass == entry.mass
        assert shape.volume > 0 and shape.min_surface_distance > 0
        assert shape.bounding_radius >= max(shape.extent)
        # every vertex lies on the surface: the query answers 0 there
        d, _ = shape.signed_distances(shape.vertices[:50])
        assert np.max(np.abs(d)) < 1e-9, name


def test_default_target_keeps_its_settings_and_run_keys():
    # the fields a default target wrote before shapes, and nothing else
    assert SimConfig().to_dict()["target"] == {
        "diameter": 3.9, "length": 10.4, "mass": 8300.0, "nozzle": False,
        "nozzle_length": 2.0, "nozzle_base_radius": 0.5, "nozzle_exit_radius": 1.0}
    d = SimConfig(target=TargetConfig(name="envisat")).to_dict()["target"]
    assert d["name"] == "envisat" and len(d["mesh_sha256"]) == 64
    assert SimConfig.from_dict({"target": d}).target == TargetConfig(name="envisat")


def test_attitude_turns_the_face_the_chaser_sees():
    design = REFERENCE_DESIGNS["time-min"]
    sc = scenario_for(design, None, SimConfig(target=TargetConfig(attitude_deg=(0.0, 0.0, 90.0))))
    q = sc.target_body.quat
    # 90 deg about the line-of-sight's perpendicular z: the long axis x now along world y
    assert q == pytest.approx([math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4)])


def _plate(tmp_path, thickness):
    """A 30 m x 30 m plate ``thickness`` thick, turned face-on to the chaser (its normal,
    the body y axis of greatest inertia, along the line of sight)."""
    plate = trimesh.creation.box((30.0, 30.0, thickness))
    path = tmp_path / "plate.stl"
    plate.export(path)
    return TargetConfig(mesh=str(path), mass=2000.0, attitude_deg=(90.0, 0.0, 0.0))


@pytest.mark.parametrize("integrator", ["implicit", "explicit"])
def test_no_node_passes_through_a_3cm_plate(tmp_path, integrator):
    """The time-min design's net (V_z 10 m/s, its fastest) shot at a plate 3 cm thick,
    larger than the net: every node stops on the chaser's side of the plate."""
    tc = _plate(tmp_path, 0.03)
    cfg = SimConfig(target=tc) if integrator == "implicit" else \
        SimConfig(target=tc, integrator="explicit")
    sim = CaptureSimulation(scenario_for(REFERENCE_DESIGNS["time-min"], None, cfg))
    nodes = np.asarray(sim.s.net_nodes)
    deepest = -math.inf
    hit = False
    while sim.step < sim.end_step() and sim.time < 5.0:
        sim.advance(20)
        x = sim.s.bodies.x[nodes] - sim.s.target_body.pos
        z = x[:, 2]                                  # along the plate's normal (world z)
        inside = np.abs(x[:, 0]) < 14.0
        hit = hit or bool(np.any(z[inside] > -0.1))
        deepest = max(deepest, float(z[inside].max()))
    assert hit                                       # the net reached the plate
    assert deepest < 0.0                             # and no node got past its mid-plane
    assert sim.max_penetration < 0.015               # nor through half its thickness


def test_mesh_zenit_episode_agrees_with_the_analytic_one():
    design = REFERENCE_DESIGNS["time-min"]
    a = run_episode(design, None, SimConfig())
    m = run_episode(design, None, SimConfig(target=TargetConfig(name="zenit-2-cylinder")))
    assert a.success and m.success
    assert m.completion_time == pytest.approx(a.completion_time, rel=0.01)


# --- the target's uncertain mass properties (docs/noise.md §1) ---------------------------
UNCERTAIN = NoiseModel(sigma_target_mass=0.1, sigma_target_inertia=0.2, sigma_target_com=0.3)


def test_target_draws_leave_every_earlier_draw_and_are_off_by_default():
    for seed in (1, 7, 42):
        plain, drawn = NoiseModel().sample(seed), UNCERTAIN.sample(seed)
        assert plain.target_mass_offset == 0.0 and not any(plain.target_com_offset)
        assert drawn.target_mass_offset != 0.0 and all(drawn.target_com_offset)
        a, b = plain.to_dict(), drawn.to_dict()
        for k in a:
            if not k.startswith("target_"):
                assert a[k] == b[k], k                  # common random numbers kept
        sc = scenario_for(REFERENCE_DESIGNS["time-min"], plain, SimConfig())
        assert sc.target_body.inv_mass == 1.0 / 8300.0
        assert not np.any(sc.target_body.com_offset)


def test_drawn_mass_properties_reach_the_episode():
    shape = target_shape(TargetConfig(name="envisat"))
    cfg = SimConfig(target=TargetConfig(name="envisat"))
    for seed in range(1, 30):
        s = UNCERTAIN.sample(seed)
        sc = scenario_for(REFERENCE_DESIGNS["time-min"], s, cfg)
        t = sc.target_body
        f = max(1.0 + s.target_mass_offset, 0.01)
        assert 1.0 / t.inv_mass == pytest.approx(shape.mass * f)
        m = np.asarray(t.inertia)
        for k in range(3):                               # drawn, or held by the inequality
            assert m[k] <= shape.inertia[k] * f * max(1.0 + s.target_inertia_offsets[k], 0.01) \
                * (1 + 1e-12)
            assert m[k] <= m[(k + 1) % 3] + m[(k + 2) % 3] + 1e-9
        np.testing.assert_array_equal(t.com_offset, s.target_com_offset)
        assert t.bound == pytest.approx(shape.bounding_radius + np.linalg.norm(s.target_com_offset))


def test_a_moved_centre_of_mass_moves_the_surface_the_net_meets():
    """With the centre of mass 0.3 m off the shape's, the contact sees the shape where it
    was measured: a body-frame point b is the shape's point b + offset."""
    from tethernet_ros.core.kernel.geometry import target_signed_distance

    shape = target_shape(TargetConfig())
    off = np.array([0.0, 0.0, 0.3])
    p = np.array([0.0, 0.0, 2.5])
    d0, _ = target_signed_distance(p + off, shape.geometry())
    assert d0 == pytest.approx(2.5 + 0.3 - 1.95)


def test_uncertain_target_batched_lanes_equal_single_runs():
    from tethernet_ros.core.batch import BatchRunner

    design = REFERENCE_DESIGNS["time-min"]
    cfg = SimConfig(settle_time=5.0)
    samples = [(i, UNCERTAIN.sample(i)) for i in (3, 4)]
    single = {i: run_episode(design, s, cfg, record_trace=False) for i, s in samples}
    got = {tag: r for tag, r, _ in BatchRunner(design, cfg, lanes=2).run(samples)}
    for i, r in single.items():
        assert repr((got[i].steps, got[i].closing_time, got[i].settled_cqi,
                     got[i].max_penetration)) == repr((r.steps, r.closing_time, r.settled_cqi,
                                                       r.max_penetration))
    # and the draws changed the episode
    plain = run_episode(design, NoiseModel().sample(3), cfg, record_trace=False)
    assert single[3].max_penetration > 0.0
    assert repr((plain.settled_cqi, plain.max_penetration)) != \
        repr((single[3].settled_cqi, single[3].max_penetration))


def test_a_design_file_names_its_target(tmp_path):
    from tethernet_ros.cli import build_parser
    from tethernet_ros.commands.common import config_from_args
    from tethernet_ros.errors import UserError

    trimesh.creation.box((1.0, 2.0, 3.0)).export(tmp_path / "part.stl")
    design = tmp_path / "net.yaml"
    design.write_text("m_c: 2.0\nL_n: 15.0\nr_n: 0.002\nd_L: 20.0\nV_e: [2, 2, 5]\nd_c: 0.5\n"
                      "target: {mesh: part.stl, mass: 100, attitude_deg: [90, 0, 0]}\n")
    args = build_parser().parse_args(["capture", "--design", str(design)])
    t = config_from_args(args).target
    assert t.mesh == str(tmp_path / "part.stl") and t.mass == 100.0 and t.name == "part"
    assert t.attitude_deg == (90.0, 0.0, 0.0)
    # the command line's --target over the file's
    args = build_parser().parse_args(["capture", "--design", str(design), "--target", "envisat"])
    t = config_from_args(args).target
    assert (t.name, t.mass, t.attitude_deg) == ("envisat", 8211.0, (90.0, 0.0, 0.0))
    design.write_text(design.read_text().replace("mass: 100", "mass: -3"))
    args = build_parser().parse_args(["capture", "--design", str(design)])
    with pytest.raises((UserError, ConfigError), match=r"--design .*\(target:\).*'mass'"):
        config_from_args(args)


def test_the_optimiser_searches_each_target_within_its_own_bounds(tmp_path):
    from tethernet_ros.core.design import DESIGN_BOUNDS, VARIABLE_NAMES
    from tethernet_ros.design_problem import SimulatorProblem

    def bounds(target):
        return SimulatorProblem(None, SimConfig(target=target)).bounds

    assert bounds(TargetConfig()) == [DESIGN_BOUNDS[n] for n in VARIABLE_NAMES]
    envisat = dict(zip(VARIABLE_NAMES, bounds(TargetConfig(name="envisat"))))
    assert envisat["L_n"] == (32.5, 55.0) and envisat["V_z"] == DESIGN_BOUNDS["V_z"]
    # a file: the rule on its box (a 5.2 m long box: half the Zenit-2's 10.4 m)
    box = _mesh_config(tmp_path, trimesh.creation.box((5.2, 1.95, 1.95)))
    small = dict(zip(VARIABLE_NAMES, bounds(box)))
    assert small["L_n"] == pytest.approx((6.5, 11.0)) and small["d_c"] == pytest.approx((-1.25, 1.25))


def test_degenerate_and_duplicate_faces_are_removed_and_reported(tmp_path):
    box = trimesh.creation.box((1.0, 2.0, 3.0))
    faces = np.vstack([box.faces, box.faces[:2], [[0, 0, 1]]])     # two copies, one sliver
    with pytest.warns(UserWarning, match="removed 3 degenerate or duplicate faces"):
        shape = target_shape(_mesh_config(tmp_path, trimesh.Trimesh(box.vertices, faces,
                                                                      process=False)))
    assert shape.volume == pytest.approx(6.0) and len(shape.faces) == 12


def test_design_bounds_and_similar_designs_follow_the_target():
    """docs/targets.md, "Design bounds": the source's Table 1 for its own stage, lengths
    times s = largest extent / 10.4 m, d_c times middle extent / 3.9 m, the rest fixed;
    a design maps by the same factors."""
    from tethernet_ros.core.design import DESIGN_BOUNDS, REFERENCE_DESIGNS
    from tethernet_ros.core.shapes.catalogue import (REFERENCE_EXTENTS, design_bounds_for,
                                                     similar_design)

    assert design_bounds_for(REFERENCE_EXTENTS) == dict(DESIGN_BOUNDS)
    assert design_bounds_for((3.9, 10.4, 3.9)) == dict(DESIGN_BOUNDS)      # any order
    b = design_bounds_for((26.0, 5.0, 4.0))                                # Envisat
    assert b["L_n"] == (32.5, 55.0) and b["d_L"] == (37.5, 87.5) and b["m_c"] == (2.5, 10.0)
    assert b["d_c"] == (-3.205, 3.205) and b["r_n"] == DESIGN_BOUNDS["r_n"]
    assert b["V_z"] == DESIGN_BOUNDS["V_z"]
    d = REFERENCE_DESIGNS["time-min"]
    assert similar_design(d, REFERENCE_EXTENTS) == d
    e = similar_design(d, (26.0, 5.0, 4.0))
    assert e.L_n == pytest.approx(d.L_n * 2.5, rel=1e-3) and e.d_L == pytest.approx(d.d_L * 2.5, rel=1e-3)
    assert e.d_c == pytest.approx(d.d_c * 5.0 / 3.9, rel=1e-3) and e.V_e == d.V_e and e.r_n == d.r_n
    with pytest.raises(ValueError, match="extents"):
        similar_design(d, (1.0, -2.0, 3.0))


def test_targets_study_runs_the_designs_on_each_catalogue_target(tmp_path):
    """`tethernet study targets` (issue 36 point 5): the base's Zenit-2 and every catalogue
    target but the Zenit-2's own meshes, each at rest and under a 2 deg/s flat spin, the
    designs unscaled; one cell against the base, end to end, resumable from its summary."""
    import json

    from tethernet_ros import cli
    from tethernet_ros.studies.cells import targets_cells

    cells = targets_cells(SimConfig(tumble={"rate_deg_s": 8.0}))
    names = ["zenit-2"] + [n for n in CATALOGUE if not n.startswith("zenit-2")]
    assert [c.label for c in cells] == [f"{n} {s}" for n in names for s in ("rest", "flat 2")]
    for c in cells:
        assert c.config.target.name == c.label.split()[0]
        assert (c.config.tumble.rate_deg_s, c.config.tumble.axis) == \
            ((0.0, "flat") if c.label.endswith("rest") else (2.0, "flat"))
    argv = ["study", "targets", "--designs", "time-min", "--samples", "1", "--cells",
            "proba-1 rest", "--workers", "0", "--results", str(tmp_path / "r.jsonl"),
            "--out", str(tmp_path), "--no-progress"]
    assert cli.main(argv) == 0
    summary = json.loads((tmp_path / "targets.json").read_text())
    assert [c["label"] for c in summary["cells"]] == ["zenit-2 rest", "proba-1 rest"]
    table = (tmp_path / "targets.md").read_text()
    assert "proba-1 rest" in table and "zenit-2 rest" in table
    lines = (tmp_path / "r.jsonl").read_text().splitlines()
    assert cli.main(argv) == 0                             # taken from its summary
    assert (tmp_path / "r.jsonl").read_text().splitlines() == lines
