"""Physics verification of the explicit method against analytic results and invariants, on
the "spec-text" model (docs/model.md §1-5; the implicit method and the reference model have
tests of their own: test_core_implicit.py, test_core_models.py)."""
import math

import numpy as np
import pytest

from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.core.episode import CaptureSimulation, run_episode
from tethernet_ros.core.noise import NoiseModel
from tethernet_ros.core.scenario import World, actions_for, build_scenario, scenario_for

from physics_systems import particle_system

#: the model as the source's text words it (docs/model.md §1-5), on the explicit method
SPEC_TEXT = SimConfig.preset("spec-text")

E, RHO = 70e9, 1390.0
R_THREAD, L0 = 0.001, 1.25
K_THREAD = E * math.pi * R_THREAD**2 / L0          # 1.76e5 N/m


def _oscillator(mass, zeta, dt, amplitude=2e-4, prestretch=1e-3):
    """A mass between two fixed anchors on pre-stretched threads, displaced along x."""
    k = K_THREAD
    c = 2 * zeta * math.sqrt(k * mass)
    x = [[-L0, 0, 0], [amplitude, 0, 0], [L0, 0, 0]]
    rest = [L0 - prestretch, L0 - prestretch]
    return particle_system(x, np.zeros((3, 3)), [math.inf, mass, math.inf], [[0, 1], [1, 2]],
                           k, c, rest=rest, dt=dt)


def _zero_crossings(sim, n_steps):
    xs = np.empty(n_steps)
    for s in range(n_steps):
        sim.advance(1)
        xs[s] = sim.s.bodies.x[1, 0]
    t = (np.arange(n_steps) + 1) * sim.dt
    idx = np.flatnonzero((xs[:-1] > 0) & (xs[1:] <= 0))
    # linear interpolation of the downward crossings
    tc = t[idx] + (t[idx + 1] - t[idx]) * xs[idx] / (xs[idx] - xs[idx + 1])
    return tc, xs


@pytest.mark.parametrize("zeta", [0.0, 0.106])
def test_thread_spring_mass_frequency_matches_analytic(zeta):
    mass = 1.0
    omega = math.sqrt(2 * K_THREAD / mass)           # two threads in parallel
    # two threads of damping 2 zeta sqrt(k m) act like one of ratio zeta*sqrt(2) on 2k
    zeta_eff = zeta * math.sqrt(2)
    omega_d = omega * math.sqrt(1 - zeta_eff**2)
    period = 2 * math.pi / omega_d
    sim = CaptureSimulation(_oscillator(mass, zeta, dt=period / 2000))
    tc, _ = _zero_crossings(sim, 2000 * 6)
    measured = 2 * math.pi / np.mean(np.diff(tc))
    assert len(tc) >= 5
    assert measured == pytest.approx(omega_d, rel=0.01)


def test_oscillator_energy_conserved_without_damping():
    """Symplectic Euler: no secular drift, a bounded O(omega dt) oscillation that shrinks
    linearly with the step."""
    mass = 1.0
    period = 2 * math.pi / math.sqrt(2 * K_THREAD / mass)
    spreads = []
    for n_per_period in (100, 200):
        sim = CaptureSimulation(_oscillator(mass, 0.0, dt=period / n_per_period))
        e0 = sim.kinetic_energy() + sim.elastic_energy()
        e = []
        for _ in range(50 * n_per_period // 10):      # 50 periods
            sim.advance(10)
            e.append(sim.kinetic_energy() + sim.elastic_energy())
        e = np.array(e) / e0
        spreads.append(np.abs(e - 1).max())
        # no drift: the last ten periods look like the first ten
        k = len(e) // 5
        assert abs(e[-k:].mean() - e[:k].mean()) < 1e-3
    assert spreads[1] < 0.05
    assert spreads[0] / spreads[1] == pytest.approx(2.0, rel=0.25)


def test_threads_never_push():
    k, c = K_THREAD, 50.0
    # compressed below rest length: no force at all
    sim = CaptureSimulation(particle_system([[0, 0, 0], [1.0, 0, 0]], [[0.3, 0, 0], [-0.3, 0, 0]],
                                            [0.01, 0.01], [[0, 1]], k, c, rest=[1.2], dt=1e-4))
    sim.advance(100)
    assert np.allclose(sim.s.bodies.v, [[0.3, 0, 0], [-0.3, 0, 0]], rtol=0, atol=1e-12)
    # stretched but closing so fast that k*C + c*dC/dt < 0: the damper may not push
    sim = CaptureSimulation(particle_system([[0, 0, 0], [1.0 + 1e-6, 0, 0]],
                                            [[5.0, 0, 0], [-5.0, 0, 0]], [0.01, 0.01], [[0, 1]],
                                            k, 1e4, rest=[1.0], dt=1e-4))
    sim.advance(1)
    assert sim.s.bodies.v[0, 0] == pytest.approx(5.0, abs=1e-12)
    assert sim.s.bodies.v[1, 0] == pytest.approx(-5.0, abs=1e-12)


def _far_scenario(name, distance=1e4, config=None):
    d = REFERENCE_DESIGNS[name]
    return build_scenario(d, actions_for(d, None), World(distance=distance), config or SPEC_TEXT)


def test_momentum_conserved_in_free_flight():
    sim = CaptureSimulation(_far_scenario("time-min"))
    p0 = sim.linear_momentum()
    scale = np.abs(sim.s.bodies.mass[:, None] * sim.s.bodies.v).sum()
    for _ in range(6):
        sim.advance(500)
        assert np.abs(sim.linear_momentum() - p0).max() < 1e-11 * scale
    # the threads did work: the corner masses were slowed by the net
    v_corner = np.linalg.norm(sim.s.bodies.v[sim.s.corner_bodies[0]])
    assert v_corner < 0.99 * np.linalg.norm(REFERENCE_DESIGNS["time-min"].V_e)


def test_momentum_conserved_through_contact_with_target():
    """Net + target momentum stays constant while the net hits the free target (before the
    winch locks and the paid-out tether joins the dynamics)."""
    sim = CaptureSimulation(scenario_for(REFERENCE_DESIGNS["time-min"], None, SPEC_TEXT))
    p0 = sim.linear_momentum()
    scale = np.abs(sim.s.bodies.mass[:, None] * sim.s.bodies.v).sum()
    while not sim.closing_active:
        sim.advance(10)
        if not sim.closing_active:
            assert np.abs(sim.linear_momentum() - p0).max() < 1e-10 * scale
    assert sim.contact_count > 100
    assert np.linalg.norm(sim.s.target_body.vel) > 0         # the target was pushed


def _deployment_energy(name, config, seconds=3.0, every=0.01):
    sim = CaptureSimulation(_far_scenario(name, config=config))
    e = [sim.kinetic_energy()]
    n = int(round(every / sim.dt))
    for _ in range(int(round(seconds / every))):
        sim.advance(n)
        e.append(sim.kinetic_energy() + sim.elastic_energy())
    return np.array(e) / e[0]


@pytest.mark.parametrize("name", ["suboptimal", "baseline"])
def test_energy_never_gained_with_damping(name):
    """With thread damping the energy of the flying net only falls (to within the explicit
    integrator's O(omega dt) fluctuation, measured at 1.4e-4 of the launch energy)."""
    e = _deployment_energy(name, SPEC_TEXT)
    assert np.all(np.diff(e) <= 1e-3)
    assert e[-1] < 0.9


@pytest.mark.parametrize("name", ["suboptimal", "baseline"])
def test_energy_conserved_without_damping(name):
    """Without thread damping the energy of the deploying net (snap loads included) stays
    within a few per cent, and closer at half the step."""
    e = _deployment_energy(name, SPEC_TEXT.replace(damping_ratio=0.0))
    e_half = _deployment_energy(name, SPEC_TEXT.replace(damping_ratio=0.0, dt_safety=0.25))
    assert np.abs(e - 1).max() < 0.06
    assert np.abs(e_half - 1).max() < 0.03


def test_energy_conserved_while_threads_slack():
    """Right after launch all threads are slack: kinetic energy is exactly constant."""
    sim = CaptureSimulation(_far_scenario("baseline", config=SPEC_TEXT.replace(damping_ratio=0.0)))
    e0 = sim.kinetic_energy()
    sim.advance(20)
    assert sim.elastic_energy() == 0.0
    assert sim.kinetic_energy() == pytest.approx(e0, rel=1e-14)


def _mirror_maps():
    idx = np.arange(289).reshape(17, 17)
    return idx[:, ::-1].ravel(), idx[::-1, :].ravel()


def test_symmetric_launch_stays_mirror_symmetric():
    """Nominal launch at the nominal target attitude: the state is mirror-symmetric about
    x = 0 and y = 0 to round-off through deployment, first contact and closing onset."""
    sim = CaptureSimulation(scenario_for(REFERENCE_DESIGNS["time-min"], None, SPEC_TEXT))
    mx, my = _mirror_maps()
    while sim.time < 4.5:
        sim.advance(2000)
        x = sim.s.bodies.x[:289]
        assert np.abs(x[mx, 0] + x[:, 0]).max() < 1e-12
        assert np.abs(x[mx, 1:] - x[:, 1:]).max() < 1e-12
        assert np.abs(x[my, 1] + x[:, 1]).max() < 1e-12
        assert np.abs(x[my][:, [0, 2]] - x[:, [0, 2]]).max() < 1e-12
    assert sim.closing_active and sim.contact_count > 0


@pytest.mark.parametrize("name", sorted(REFERENCE_DESIGNS))
def test_no_body_sinks_into_target(name):
    res = run_episode(REFERENCE_DESIGNS[name], None, SPEC_TEXT, record_trace=False)
    assert res.max_penetration < 0.05
    assert res.closing_time == res.closing_time      # closing triggered


def test_no_body_sinks_into_target_under_noise():
    model = NoiseModel()
    for seed in range(3):
        res = run_episode(REFERENCE_DESIGNS["suboptimal"], model.sample(seed), SPEC_TEXT, record_trace=False)
        assert res.max_penetration < 0.05


def _drawstring_pair(x1, m, close_force, locked):
    """Two free nodes of mass m (kg), at the origin and x1 (m), forming one drawstring pair
    with the closing force (N) on; locked at zero distance or not yet locked."""
    from tethernet_ros.core import kernel as kn

    sc = particle_system([[0, 0, 0], x1], np.zeros((2, 3)), [m, m], [[0, 1]], 1.0, 0.0,
                         rest=[100.0], dt=1e-4)
    sc.links.active[:] = 0
    sc.drawstring = sc.drawstring._replace(
        pairs=np.array([[0, 1]], dtype=np.int64), locked=np.full(1, 1 if locked else 0, dtype=np.uint8),
        maxdist=np.zeros(1), lock_step=np.full(1, 0 if locked else -1, dtype=np.int64))
    sc.set_params(close_force=close_force)
    sc.events[kn.E_CLOSING_ACTIVE] = 1
    return sc


def test_closing_force_and_lock():
    """Two free nodes of a drawstring pair: constant F_c pulls them together; below 1 m they
    lock and never separate again."""
    m, F = 0.05, 2 * 2.0 * 20.0 / 25
    sc = _drawstring_pair([3.0, 0, 0], m, F, locked=False)
    sim = CaptureSimulation(sc)
    sim.advance(1000)
    t = sim.time
    # x(t) = F/m t^2 / 2 for each node (symplectic Euler: exact to O(dt))
    assert sim.s.bodies.x[0, 0] == pytest.approx(0.5 * F / m * t * t, rel=0.01)
    assert sim.s.bodies.v[0, 0] == pytest.approx(F / m * t, rel=1e-9)
    while not sc.drawstring.locked[0]:
        gap = sim.s.bodies.x[1, 0] - sim.s.bodies.x[0, 0]
        sim.advance(1)
    assert gap >= 1.0 > sim.s.bodies.x[1, 0] - sim.s.bodies.x[0, 0]
    # throw them apart: the lock holds (distance never grows) for the rest of the episode
    sim.s.bodies.v[0] = [-20.0, 3.0, 0.0]
    sim.s.bodies.v[1] = [20.0, -1.0, 2.0]
    dmax = sc.drawstring.maxdist[0]
    for _ in range(200):
        sim.advance(50)
        d = np.linalg.norm(sim.s.bodies.x[1] - sim.s.bodies.x[0])
        assert d <= dmax + 1e-9
        assert sc.drawstring.locked[0] == 1
        dmax = sc.drawstring.maxdist[0]


def test_lock_at_zero_distance_removes_the_separating_velocity():
    """A pair locked at zero distance (its nodes coincide) and thrown apart: the ratchet
    keeps the nodes together and must take out their relative velocity, so no kinetic
    energy appears.  (The projection left them on one point, whose direction is undefined;
    the separating velocity used to be skipped there and, pushed by any force, grew each
    step while the nodes stayed put: time-min seed 497 reached 500 m/s and diverged.)"""
    m = 0.037
    sc = _drawstring_pair([0, 0, 0], m, 3.0, locked=True)
    sim = CaptureSimulation(sc)
    sim.s.bodies.v[0] = [-5.0, 1.0, 0.5]
    sim.s.bodies.v[1] = [5.0, -1.0, 2.5]
    momentum = m * sim.s.bodies.v.sum(axis=0)
    sim.advance(1)
    rel = sim.s.bodies.v[1] - sim.s.bodies.v[0]
    assert np.linalg.norm(rel) < 1e-9 * 10.0                # all of it: every direction separates
    assert np.allclose(m * sim.s.bodies.v.sum(axis=0), momentum, rtol=0, atol=1e-12)
    ke0 = 0.5 * m * (sim.s.bodies.v ** 2).sum()
    sim.advance(2000)
    assert np.linalg.norm(sim.s.bodies.x[1] - sim.s.bodies.x[0]) < 1e-12
    assert 0.5 * m * (sim.s.bodies.v ** 2).sum() <= ke0 * (1 + 1e-9)


def test_time_min_seed_497_no_longer_diverges():
    """The 1000-sample validation's case of the bug above (diverged at t = 17.4 s)."""
    res = run_episode(REFERENCE_DESIGNS["time-min"], NoiseModel().sample(497), SPEC_TEXT,
                      record_trace=False)
    assert "diverged" not in (res.failure_reason or ""), res.failure_reason
    assert res.completion_time == res.completion_time      # it finished (T is a number)


def test_closing_force_magnitude_from_design():
    d = REFERENCE_DESIGNS["time-min"]
    sc = scenario_for(d, None, SPEC_TEXT)
    assert sc.params.close_force == pytest.approx(2 * d.m_c * d.L_n / 25)     # the text
    assert sc.params.lock_dist == 1.0
    assert len(sc.drawstring.pairs) == 12
    assert scenario_for(d).params.close_force == pytest.approx(2 * d.m_c * d.L_n)   # the code


def test_closing_triggers_at_displacement():
    d = REFERENCE_DESIGNS["mass-min"]
    res = run_episode(d, None, SPEC_TEXT, record_trace=True)
    tr = res.trace
    k = int(np.searchsorted(tr.time, res.closing_time))
    # before the trigger z_rel < d_c; the recorded sample after it is near d_c
    assert max(tr.z_rel[:k]) < d.d_c
    assert res.completion_time == pytest.approx(res.closing_time + 20.0)


def test_same_inputs_same_result_bit_for_bit():
    # (4 s of settle: the wrapped net's contacts, at a quarter of the 20 s episode's cost;
    # the goldens hold whole episodes)
    model, cfg = NoiseModel(), SPEC_TEXT.replace(settle_time=4.0)
    a = run_episode(REFERENCE_DESIGNS["time-min"], model.sample(7), cfg)
    b = run_episode(REFERENCE_DESIGNS["time-min"], model.sample(7), cfg)
    assert a.settled_cqi == b.settled_cqi and a.locked_pairs == b.locked_pairs
    assert a.trace.cqi == b.trace.cqi
    assert a.closing_time == b.closing_time


def test_divergence_is_a_failed_episode_with_reason():
    cfg = SPEC_TEXT.replace(max_speed=5.0)                  # the corners leave faster than that
    res = run_episode(REFERENCE_DESIGNS["time-min"], None, cfg, record_trace=False)
    assert not res.success
    assert res.failure_reason.startswith("simulation diverged")


def test_closing_never_triggered_fails_at_horizon():
    d = REFERENCE_DESIGNS["baseline"]
    res = run_episode(d, None, SPEC_TEXT.replace(horizon=5.0), record_trace=False)
    assert not res.success
    assert "closing never triggered" in res.failure_reason
    assert res.completion_time == 5.0


@pytest.fixture(scope="module")
def baseline_at_two_steps():
    cfg = SPEC_TEXT
    a = run_episode(REFERENCE_DESIGNS["baseline"], None, cfg, record_trace=False)
    b = run_episode(REFERENCE_DESIGNS["baseline"], None, cfg.replace(dt_safety=cfg.dt_safety / 2),
                    record_trace=False)
    return a, b


@pytest.mark.slow
def test_time_step_convergence_of_baseline_deployment(baseline_at_two_steps):
    """Halving the step: the closing time (set by the deployment and the first contact)
    moves by less than 0.1 s, and neither run diverges."""
    a, b = baseline_at_two_steps
    assert abs(a.closing_time - b.closing_time) < 0.1
    assert "diverged" not in a.failure_reason + b.failure_reason


@pytest.mark.slow
def test_settled_cqi_is_sensitive_to_nanometres():
    """Why the settled CQI of one trajectory cannot converge in dt: the same sensitivity
    shows for a 1 nm change of the launch distance at a fixed step."""
    import dataclasses

    d = REFERENCE_DESIGNS["baseline"]
    a = run_episode(d, None, SPEC_TEXT, record_trace=False)
    b = run_episode(dataclasses.replace(d, d_L=d.d_L + 1e-9), None, SPEC_TEXT, record_trace=False)
    assert abs(a.settled_cqi - b.settled_cqi) / a.settled_cqi > 0.002
