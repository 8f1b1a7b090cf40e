"""The implicit (compliant-constraint) method against invariants and the explicit method:
momentum to round-off, no energy gained, threads that never push, contact without sinking,
and the same deployment as the explicit method."""

import numpy as np
import pytest

from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.core.episode import CaptureSimulation, run_episode
from tethernet_ros.core.scenario import World, actions_for, build_scenario, scenario_for

from physics_systems import particle_system

IMPLICIT = SimConfig.preset("reference", integrator="implicit")


def _far(name, config=IMPLICIT):
    d = REFERENCE_DESIGNS[name]
    return CaptureSimulation(build_scenario(d, actions_for(d, None), World(distance=1e4), config))


def test_momentum_conserved_in_free_flight():
    sim = _far("time-min")
    b = sim.s.bodies
    p0 = sim.linear_momentum()
    scale = np.abs(b.mass[:, None] * b.v).sum()
    for _ in range(6):
        sim.advance(300)
        assert np.abs(sim.linear_momentum() - p0).max() < 1e-12 * scale
    assert np.linalg.norm(b.v[sim.s.corner_bodies[0]]) < 0.99 * np.linalg.norm(REFERENCE_DESIGNS["time-min"].V_e)


def test_momentum_conserved_through_contact_with_target():
    sim = CaptureSimulation(scenario_for(REFERENCE_DESIGNS["time-min"], None, IMPLICIT))
    b = sim.s.bodies
    p0 = sim.linear_momentum()
    scale = np.abs(b.mass[:, None] * b.v).sum()
    while not sim.closing_active:
        sim.advance(10)
        if not sim.closing_active:
            assert np.abs(sim.linear_momentum() - p0).max() < 1e-11 * scale
    assert sim.contact_count > 100
    assert np.linalg.norm(sim.s.target_body.vel) > 0


@pytest.mark.parametrize("name", ["suboptimal", "baseline"])
def test_energy_never_gained_while_the_net_deploys(name):
    """Kinetic + strain energy of the flying net, sampled every 10 ms for 3 s, never rises
    by more than 1e-5 of the launch energy and falls overall.  Measured with the default 4
    sweeps: at most 3.4e-6 (suboptimal) and 8.6e-6 (baseline).  With 2 sweeps the
    under-converged threads of the heavier suboptimal net keep stretch that the next step
    releases: rises up to 7.6e-3, which is why the default is 4."""
    sim = _far(name)
    e = [sim.kinetic_energy()]
    for _ in range(300):
        sim.advance(10)
        e.append(sim.kinetic_energy() + sim.elastic_energy())
    e = np.array(e) / e[0]
    assert np.all(np.diff(e) <= 1e-5)
    assert e[-1] < 0.95


def test_threads_never_push():
    k, c = 1.8e5, 50.0
    cfg = SimConfig(integrator="implicit")
    # compressed below rest length and closing: no impulse at all
    sc = particle_system([[0, 0, 0], [1.0, 0, 0]], [[0.3, 0, 0], [-0.3, 0, 0]], [0.01, 0.01],
                         [[0, 1]], k, c, rest=[1.2], dt=1e-3, config=cfg)
    sim = CaptureSimulation(sc)
    sim.advance(100)
    assert np.allclose(sc.bodies.v, [[0.3, 0, 0], [-0.3, 0, 0]], rtol=0, atol=1e-15)
    # stretched but closing fast: the damper may not push either
    sc = particle_system([[0, 0, 0], [1.0 + 1e-6, 0, 0]], [[5.0, 0, 0], [-5.0, 0, 0]],
                         [0.01, 0.01], [[0, 1]], k, 1e4, rest=[1.0], dt=1e-3, config=cfg)
    sim = CaptureSimulation(sc)
    sim.advance(1)
    assert sc.bodies.v[0, 0] == pytest.approx(5.0, abs=1e-12)
    assert sc.bodies.v[1, 0] == pytest.approx(-5.0, abs=1e-12)


def test_a_slack_thread_becomes_taut_without_overshoot_in_one_step():
    """Speculative limit: a slack thread about to snap stops exactly at its rest length
    within the step (an inelastic snap at this step size, as for the critically damped
    threads of the reference model) and never stretches through."""
    k = 1.8e5
    c = float(2 * 0.106 * k / 600.0)
    sc = particle_system([[0, 0, 0], [0.99, 0, 0]], [[-2.0, 0, 0], [2.0, 0, 0]], [0.01, 0.01],
                         [[0, 1]], k, c, rest=[1.0], dt=1e-3, config=SimConfig(integrator="implicit"))
    sim = CaptureSimulation(sc)
    p0 = 0.01 * sc.bodies.v.sum(axis=0)
    sim.advance(20)
    d = np.linalg.norm(sc.bodies.x[1] - sc.bodies.x[0])
    assert d <= 1.0 + 1e-3
    assert np.allclose(0.01 * sc.bodies.v.sum(axis=0), p0, rtol=0, atol=1e-15)


@pytest.mark.parametrize("name", sorted(REFERENCE_DESIGNS))
def test_no_body_sinks_into_the_target(name):
    res = run_episode(REFERENCE_DESIGNS[name], None, IMPLICIT, record_trace=False)
    assert res.max_penetration < 0.02
    assert res.closing_time == res.closing_time


@pytest.mark.parametrize("name", ["suboptimal", "mass-min", "time-min"])
def test_deployment_and_closing_time_agree_with_the_explicit_method(name):
    """The deployment is not chaotic: the closing time (set by the flight and the first
    contact) of the nominal launch agrees within 1 % with the explicit method's."""
    d = REFERENCE_DESIGNS[name]
    cfg_e = SimConfig.preset("reference", integrator="explicit", settle_time=0.0)
    cfg_i = IMPLICIT.replace(settle_time=0.0)
    te = run_episode(d, None, cfg_e, record_trace=False).closing_time
    ti = run_episode(d, None, cfg_i, record_trace=False).closing_time
    assert ti == pytest.approx(te, rel=0.01)


def test_tether_masses_inside_the_stage_at_winch_lock_are_not_expelled():
    """Regression (issue 20 point 8): closing triggered late, when the straight line of
    the paid-out tether ran through the stage; the tether masses that joined the dynamics
    inside it were expelled at over 1000 m/s (max penetration 1.44 m, settled CQI 18).
    They now collide only once they are outside (kernel.state.CONTACT_ONCE_OUTSIDE)."""
    from tethernet_ros.core.noise import NoiseModel
    from tethernet_ros.montecarlo.seeds import sample_seed

    sample = NoiseModel().with_scales(closing=10.0).sample(sample_seed(0, 102))
    sim = CaptureSimulation(scenario_for(REFERENCE_DESIGNS["time-min"], sample, SimConfig()))
    sim.advance(49203)       # the step before closing starts
    tether = sim.s.tether.nodes
    sim.advance(1)
    assert sim.closing_active
    inside = [t for t in tether
              if sim.s.target.signed_distance(_body_frame(sim, t))[0] < 0.0]
    assert inside, "the scenario no longer puts a tether mass inside the stage"
    sim.advance(2000)
    speed = np.sqrt((sim.s.bodies.v[tether] ** 2).sum(axis=1))
    assert speed.max() < 20.0
    assert sim.max_penetration < 0.01


def _body_frame(sim, body):
    """Position of a body in the target's frame, about its centre of mass (m)."""
    from tethernet_ros.core.kernel import quat_to_matrix

    t = sim.s.target_body
    return quat_to_matrix(t.quat).T @ (sim.s.bodies.x[body] - t.pos)
