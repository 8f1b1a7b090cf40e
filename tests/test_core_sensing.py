"""Sensing and closing policies (core/sensing.py, core/policies.py): the default is the
source's trigger; latency, the planned target distance and noise do what they say; a
controller outside the kernel (the ROS loop's path) gives the kernel's closed loop bit for
bit; bad settings are refused naming the field."""
from __future__ import annotations

import math

import numpy as np
import pytest

from tethernet_ros.core.config import ConfigError, SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.core.episode import CaptureSimulation, EpisodeResult, run_episode, run_simulation
from tethernet_ros.core.noise import NoiseModel
from tethernet_ros.core.policies import Policy, PolicyConfig
from tethernet_ros.core.scenario import scenario_for
from tethernet_ros.core.sensing import (C_NET, C_TGT, Sensor, SensingConfig, det_log, next_normal,
                                        true_measurement)
from tethernet_ros.core.tumble import TumbleConfig

DESIGN = REFERENCE_DESIGNS["time-min"]
SHORT = SimConfig(settle_time=2.0)


def outcome(r: EpisodeResult) -> tuple:
    return (r.success, repr(r.settled_cqi), r.locked_pairs, repr(r.closing_time), r.steps,
            r.failure_reason, repr(r.max_penetration))


def test_ideal_sensing_at_any_rate_of_one_per_step_is_the_source_trigger():
    s = NoiseModel().sample(3)
    base = run_episode(DESIGN, s, SHORT, record_trace=False)
    every_ms = SHORT.replace(sensing=SensingConfig(rate_hz=1000.0))
    assert outcome(run_episode(DESIGN, s, every_ms, record_trace=False)) == outcome(base)


def test_latency_delays_the_closing_by_exactly_its_steps():
    s = NoiseModel().sample(3)
    base = run_episode(DESIGN, s, SHORT, record_trace=False)
    late = run_episode(DESIGN, s, SHORT.replace(sensing=SensingConfig(latency=0.25)),
                       record_trace=False)
    assert round((late.closing_time - base.closing_time) / 1e-3) == 250


def test_planned_distance_belief_closes_when_the_net_passes_the_planned_target():
    s = NoiseModel().sample(3)
    assert abs(s.distance_offset) > 0.01
    cfg = SHORT.replace(sensing=SensingConfig(target_position="planned"))
    sim = CaptureSimulation(scenario_for(DESIGN, s, cfg))
    threshold = DESIGN.d_c + s.closing_offset
    while not sim.closing_active:
        sim.advance(1)
        m = true_measurement(sim.model, sim.data, 0)
        crossed = m[C_NET + 2] - DESIGN.d_L >= threshold
        assert m[C_TGT + 2] == DESIGN.d_L
        assert crossed == sim.closing_active


def test_net_reference_points_differ_and_are_what_they_say():
    sim = CaptureSimulation(scenario_for(DESIGN, None, SimConfig()))
    sim.advance(1500)
    b = sim.s.bodies
    net, corners = sim.s.net_nodes, sim.s.corner_bodies
    want = {"com": (b.x[net] * b.mass[net, None]).sum(0) / b.mass[net].sum(),
            "centre": b.x[len(net) // 2], "corners": b.x[corners].mean(0)}
    for point, expect in want.items():
        cfg = SimConfig(sensing=SensingConfig(net_point=point))
        s2 = CaptureSimulation(scenario_for(DESIGN, None, cfg))
        s2.advance(1500)
        got = true_measurement(s2.model, s2.data, 0)[C_NET:C_NET + 3]
        assert np.allclose(got, expect, rtol=1e-12, atol=1e-12), point


def test_det_log_is_the_logarithm_to_two_ulp():
    xs = np.concatenate([np.geomspace(1e-300, 1e300, 2001), np.linspace(0.01, 10, 2001)])
    for x in xs:
        got, want = det_log(float(x)), math.log(float(x))
        assert abs(got - want) <= 2 * math.ulp(want) + 1e-300, x


def test_sensor_noise_is_standard_normal_and_seeded():
    from numba import njit

    @njit
    def draws(seed, n):
        st = np.array([seed], dtype=np.uint64)
        out = np.empty(n)
        for i in range(n):
            out[i] = next_normal(st, 0)
        return out

    a = draws(7, 200_000)
    assert np.array_equal(a, draws(7, 200_000)) and not np.array_equal(a, draws(8, 200_000))
    assert abs(a.mean()) < 0.01 and abs(a.std() - 1.0) < 0.01
    assert abs(np.mean(np.abs(a) > 1.96) - 0.05) < 0.003


def _closed_loop_outside(cfg_inside: SimConfig, sample) -> EpisodeResult:
    """The episode with the kernel's policy 'external' and the sensor and policy run
    outside it, as the ROS nodes run them: at each measurement step the true measurement
    goes through a Sensor, the newest measurement through a Policy, and a decision to
    close is commanded back."""
    cfg_outside = cfg_inside.replace(policy=PolicyConfig(kind="external",
                                                         closing_time=cfg_inside.policy.closing_time,
                                                         apex=cfg_inside.policy.apex))
    sc = scenario_for(DESIGN, sample, cfg_outside)
    sim = CaptureSimulation(sc)
    inside_model = scenario_for(DESIGN, sample, cfg_inside).kernel()[0]
    sensor = Sensor(sim.model.control, sc.sensor_seed)
    policy = Policy(inside_model, sc.close_threshold)
    period = sim.model.control.period
    while not sim.closing_active and sim.step < sim.end_step():
        sim.advance(period)
        meas = sensor.measure(true_measurement(sim.model, sim.data, 0), sim.step)
        if meas is not None and policy.decide(meas):
            assert sim.command_closing()
    return run_simulation(sim, record_trace=False)


@pytest.mark.parametrize("policy", ["threshold", "adaptive"])
def test_controller_outside_the_kernel_gives_the_kernels_closed_loop_bit_for_bit(policy):
    cfg = SHORT.replace(
        tumble=TumbleConfig(rate_deg_s=1.0, axis="los"),
        sensing=SensingConfig(rate_hz=50.0, latency=0.06, sigma_position=0.05,
                              sigma_attitude_deg=2.0, sigma_rate_deg_s=0.2, sigma_velocity=0.02),
        policy=PolicyConfig(kind=policy))
    s = NoiseModel().sample(5)
    inside = run_episode(DESIGN, s, cfg, record_trace=False)
    assert math.isfinite(inside.closing_time)
    assert outcome(_closed_loop_outside(cfg, s)) == outcome(inside)


def test_noise_changes_the_closing_time_and_the_same_seed_gives_the_same_episode():
    s = NoiseModel().sample(5)
    cfg = SHORT.replace(sensing=SensingConfig(rate_hz=50.0, sigma_position=0.3))
    a = run_episode(DESIGN, s, cfg, record_trace=False)
    assert outcome(a) == outcome(run_episode(DESIGN, s, cfg, record_trace=False))
    ideal = run_episode(DESIGN, s, SHORT.replace(sensing=SensingConfig(rate_hz=50.0)),
                        record_trace=False)
    assert a.closing_time != ideal.closing_time


def test_adaptive_waits_for_a_stage_turned_along_the_line_of_sight():
    """A stage whose long axis lies on the line of sight is 10.4 m deep, not 3.9 m: the
    adaptive policy does not close when the net's centre passes d_c beyond the stage's
    centre, as the threshold does, but later: at the net's apex, since the net cannot get
    d_c beyond the stage's far end."""
    tumble = TumbleConfig(rate_deg_s=0.001, axis="flat", phase_deg=90.0)   # at rest, turned
    s = NoiseModel().sample(5)
    times = {}
    for kind in ("threshold", "adaptive"):
        cfg = SHORT.replace(tumble=tumble, policy=PolicyConfig(kind=kind))
        times[kind] = run_episode(DESIGN, s, cfg, record_trace=False).closing_time
    assert math.isfinite(times["adaptive"]) and times["adaptive"] > times["threshold"]


def test_bad_settings_name_the_field_and_range():
    with pytest.raises(ConfigError, match="sensing field 'latency'.*\\[0, 5\\] s"):
        SimConfig.from_dict({"sensing": {"latency": 9}})
    with pytest.raises(ConfigError, match="sensing field 'net_point'"):
        SimConfig.from_dict({"sensing": {"net_point": "middle"}})
    with pytest.raises(ConfigError, match="policy field 'kind'"):
        SimConfig.from_dict({"policy": {"kind": "magic"}})
