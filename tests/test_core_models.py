"""The reference implementation's modelling choices (docs/model.md §10) against closed forms:
the net's first axial frequency, stiffness-proportional thread damping, Hertz contact
stiffness, sphere sizes, the latch lock and the drawstring through the corner masses."""
import math

import numpy as np
import pytest

from tethernet_ros.core import kernel as kn
from tethernet_ros.core import materials
from tethernet_ros.core.config import ConfigError, SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.core.episode import CaptureSimulation
from tethernet_ros.core.layout import corner_nodes
from tethernet_ros.core.scenario import scenario_for

from physics_systems import particle_system


def test_first_axial_frequency_of_a_uniform_chain():
    """Free-free chain of n equal masses m and springs k: omega_1 = 2 sqrt(k/m) sin(pi/2n)."""
    n, m, k = 17, 0.012, 1.8e5
    got = materials.first_axial_frequency(np.full((n, n), m), k)
    assert got == pytest.approx(2 * math.sqrt(k / m) * math.sin(math.pi / (2 * n)), rel=1e-12)


def test_first_axial_frequency_of_the_reference_net():
    """The reference's own net (23 x 23 nodes, 22 m, r 0.5 mm, rho 1390, E 70 GPa, corner
    threads sqrt 2 meshes of radius 0.5 mm / sqrt 2) by its method: 700.05 rad/s.  (Its
    code hard-codes 757.418 rad/s beside the commented-out call; the net that value was
    computed for is not stated.)"""
    n, side, r, rho, e = 23, 22.0, 5e-4, 1390.0, 70e9
    l0 = side / (n - 1)
    half = rho * l0 * math.pi * r * r / 2
    m = np.full((n, n), 4 * half)
    m[0, :] = m[-1, :] = m[:, 0] = m[:, -1] = 3 * half
    half_corner = rho * l0 * math.sqrt(2) * math.pi * (r / math.sqrt(2)) ** 2 / 2
    for i, j in ((0, 0), (0, n - 1), (n - 1, 0), (n - 1, n - 1)):
        m[i, j] = 2 * half + half_corner
    assert materials.first_axial_frequency(m, e * math.pi * r * r / l0) == pytest.approx(700.05, abs=0.01)


def test_stiffness_damping_gives_zeta_to_the_first_mode():
    """c = 2 zeta k / omega_1: a single spring-mass of frequency omega_1 gets ratio zeta."""
    k, m, zeta = 1e5, 0.1, 0.106
    omega = math.sqrt(k / m)
    c = materials.stiffness_damping(k, zeta, omega)
    assert c / (2 * math.sqrt(k * m)) == pytest.approx(zeta, rel=1e-12)


def _decay_rate(integrator, k, m, c, dt, periods=6):
    """Measured amplitude decay rate (1/s) of a mass m between two fixed anchors on
    pre-stretched threads (stiffness k, damping c), displaced along them."""
    amp, pre, l0 = 1e-3, 1e-2, 1.0
    sc = particle_system([[-l0, 0, 0], [amp, 0, 0], [l0, 0, 0]], np.zeros((3, 3)),
                         [math.inf, m, math.inf], [[0, 1], [1, 2]], k, c,
                         rest=[l0 - pre, l0 - pre], dt=dt,
                         config=SimConfig(integrator=integrator))
    sim = CaptureSimulation(sc)
    omega = math.sqrt(2 * k / m)
    n = int(round(periods * 2 * math.pi / omega / dt))
    xs = np.empty(n)
    for s in range(n):
        sim.advance(1)
        xs[s] = sc.bodies.x[1, 0]
    t = (np.arange(n) + 1) * dt
    peaks = [s for s in range(1, n - 1) if xs[s] > xs[s - 1] and xs[s] >= xs[s + 1] and xs[s] > 0]
    assert len(peaks) >= periods - 2
    return -float(np.mean(np.diff(np.log(xs[peaks])) / np.diff(t[peaks])))


K_DAMPED, M_DAMPED = 2.0e3, 0.5                     # omega_n = 89 rad/s
C_DAMPED = float(materials.stiffness_damping(K_DAMPED, 0.106, 600.0))   # omega_1 of our nets


def test_stiffness_damped_thread_decays_at_its_closed_form_rate():
    """m x'' + 2 c x' + 2 k x = 0 with the stiffness-proportional c = 2 zeta k / omega_1:
    the amplitude decays as exp(-c t / m) (explicit method, 2000 steps a period)."""
    sigma = C_DAMPED / M_DAMPED
    dt = 2 * math.pi / math.sqrt(2 * K_DAMPED / M_DAMPED) / 2000
    assert _decay_rate("explicit", K_DAMPED, M_DAMPED, C_DAMPED, dt) == pytest.approx(sigma, rel=0.01)


def test_implicit_step_decays_as_implicit_euler_and_converges():
    """The implicit method is implicit Euler on a taut thread: per step the amplitude is
    multiplied by 1 / |1 - h lambda| (lambda = -sigma +- i omega_d), a decay rate
    ln|1 - h lambda| / h that exceeds the model's sigma by about h omega^2 / 2 and
    tends to it as h -> 0."""
    sigma = C_DAMPED / M_DAMPED
    omega_d = math.sqrt(2 * K_DAMPED / M_DAMPED - sigma**2)
    excess = []
    for h in (1e-4, 5e-5):
        expected = math.log(math.hypot(1 + h * sigma, h * omega_d)) / h
        got = _decay_rate("implicit", K_DAMPED, M_DAMPED, C_DAMPED, h)
        assert got == pytest.approx(expected, rel=0.01)
        excess.append(got - sigma)
    assert excess[0] / excess[1] == pytest.approx(2.0, rel=0.1)


def test_hertz_stiffness_matches_the_reference_values():
    """docs/model.md §10: about 3.6e6 N/m for a 7 mm net node and 7.9e6 N/m for a 0.5 kg
    aluminium corner mass (Hertz at 0.1 mm, divided by 10)."""
    e_net = materials.effective_modulus(70e9, 0.36, 69e9, 0.33)
    e_al = materials.effective_modulus(69e9, 0.33, 69e9, 0.33)
    r_node = 0.007
    assert materials.hertz_linear_stiffness(r_node, e_net, 1e-4, 10.0) == pytest.approx(3.6e6, rel=0.02)
    r_cm = materials.sphere_radius(0.5, 2700.0)
    assert r_cm == pytest.approx(0.0354, abs=1e-4)
    assert materials.hertz_linear_stiffness(r_cm, e_al, 1e-4, 10.0) == pytest.approx(7.9e6, rel=0.02)


def test_density_sized_spheres_hold_the_bodies_mass():
    sc = scenario_for(REFERENCE_DESIGNS["mass-min"], None, SimConfig.preset("reference"))
    b = sc.bodies
    vol = 4 / 3 * math.pi * b.radius**3
    assert np.allclose(vol[:289] * 1390.0, b.mass[:289], rtol=1e-12)
    assert np.allclose(vol[sc.corner_bodies] * 2700.0, b.mass[sc.corner_bodies], rtol=1e-12)


def test_drawstring_through_corner_masses():
    cfg = SimConfig.preset("reference")
    sc = scenario_for(REFERENCE_DESIGNS["mass-min"], None, cfg)
    ring = set(sc.drawstring.pairs.ravel().tolist())
    assert set(sc.corner_bodies.tolist()) <= ring
    assert not set(corner_nodes(cfg)) & ring
    assert len(sc.drawstring.pairs) == 12


def _latch_pair(x1, v0, v1, m=0.05, force=3.0):
    sc = particle_system([[0, 0, 0], x1], [v0, v1], [m, m], [[0, 1]], 1.0, 0.0, rest=[100.0],
                         dt=1e-4, config=SimConfig(lock_model="latch"))
    sc.links.active[:] = 0
    sc.drawstring = sc.drawstring._replace(
        pairs=np.array([[0, 1]], dtype=np.int64), locked=np.zeros(1, dtype=np.uint8),
        maxdist=np.zeros(1), lock_step=np.full(1, -1, dtype=np.int64))
    sc.set_params(close_force=force)
    sc.events[kn.E_CLOSING_ACTIVE] = 1
    return sc


def test_latch_releases_no_force_and_the_pull_resumes_beyond_the_lock_distance():
    """Closer than 1 m: the pair latches (counts as locked) and feels no force at all, not
    even while it drifts apart; at 1 m the closing force pulls again."""
    sc = _latch_pair([0.5, 0, 0], [-0.1, 0, 0], [0.1, 0, 0])
    sim = CaptureSimulation(sc)
    sim.advance(1)
    assert sc.drawstring.locked[0] == 1
    for _ in range(20):                      # drifts from 0.5 m to 0.9 m: no force
        sim.advance(100)
        assert np.array_equal(sc.bodies.v, [[-0.1, 0, 0], [0.1, 0, 0]])
        assert sc.drawstring.locked[0] == 1
    while np.linalg.norm(sc.bodies.x[1] - sc.bodies.x[0]) < 1.0:
        sim.advance(1)
    sim.advance(10)
    assert sc.bodies.v[1, 0] < 0.1 and sc.bodies.v[0, 0] > -0.1       # pulled together again
    assert sc.drawstring.locked[0] == 1                                 # a latch stays latched


def test_a_whole_number_makes_the_same_settings_as_its_float():
    """A YAML file writes 15 where a flag gives 15.0: every field declared float stores a
    float, so both make the same configuration, design and run key; integer fields stay
    integers and a bool is still refused."""
    from tethernet_ros.core.design import Design
    from tethernet_ros.core.noise import NoiseModel
    from tethernet_ros.montecarlo.keys import run_key

    ints = SimConfig.from_dict({"settle_time": 20, "launch": {"max_tilt_deg": 15, "max_wait": 100},
                                "tumble": {"rate_deg_s": 2, "phase_deg": 10},
                                "sensing": {"rate_hz": 50}, "policy": {"closing_time": 1},
                                "tug": {"hold_time": 5}})
    floats = SimConfig.from_dict({"settle_time": 20.0,
                                  "launch": {"max_tilt_deg": 15.0, "max_wait": 100.0},
                                  "tumble": {"rate_deg_s": 2.0, "phase_deg": 10.0},
                                  "sensing": {"rate_hz": 50.0}, "policy": {"closing_time": 1.0},
                                  "tug": {"hold_time": 5.0}})
    assert repr(ints.to_dict()) == repr(floats.to_dict())
    assert type(ints.grid_nodes) is int and type(ints.tether_segments) is int
    design = dict(m_c=2, L_n=20, r_n=0.001, d_L=15, V_e=[5, 6, 10], d_c=-1)
    a, b = Design.from_dict(design), Design.from_dict({k: (float(v) if isinstance(v, int) else v)
                                                        for k, v in design.items()})
    assert run_key(a, NoiseModel(sigma_target_mass=0), ints) == \
        run_key(b, NoiseModel(sigma_target_mass=0.0), floats)
    with pytest.raises(ConfigError, match="settle_time"):
        SimConfig(settle_time=True)


def test_presets_and_choices_are_validated():
    assert SimConfig.preset("reference").lock_model == "latch"
    with pytest.raises(ConfigError, match="'preset'"):
        SimConfig.preset("vortex")
    with pytest.raises(ConfigError, match="'contact_model'"):
        SimConfig(contact_model="soft")
    with pytest.raises(ConfigError, match="'preset'"):
        SimConfig.from_dict({"preset": "nope"})
    assert SimConfig.from_dict({"preset": "reference", "friction": 0.3}).friction == 0.3


@pytest.mark.parametrize("corners", ["net", "corner_mass"])
def test_lumped_masses_add_up_to_the_system_mass(corners):
    """The lumped bodies of the net (nodes and corner masses) carry m_a (38 L_n of thread
    plus 4 m_c) and the four corner threads, wherever the drawstring's corners are; the
    body layout puts the corner masses right after the n^2 nodes."""
    from tethernet_ros.core.layout import BodyLayout

    cfg = SimConfig(drawstring_corners=corners)
    lay = BodyLayout.of(cfg)
    assert (lay.n_net, lay.corner0, lay.tether0, lay.chaser, lay.n_bodies) == (289, 289, 293, 302, 303)
    for d in REFERENCE_DESIGNS.values():
        m = scenario_for(d, None, cfg).bodies.mass
        lin = cfg.density * math.pi * d.r_n ** 2
        corner_threads = 4 * cfg.corner_thread_meshes * d.L_n / 16 * lin
        assert m[:lay.tether0].sum() == pytest.approx(d.mass(cfg.density) + corner_threads, rel=1e-12)
        assert m[lay.chaser] == cfg.chaser_mass
