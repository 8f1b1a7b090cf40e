"""The tumbling target (core/tumble.py, kernel/rigid.py): settings, the torque-free
symmetric top against its closed form, angular momentum with the net in contact."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from tethernet_ros.core import kernel as kn
from tethernet_ros.core.config import ConfigError, SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.core.episode import CaptureSimulation, run_episode
from tethernet_ros.core.noise import NoiseModel
from tethernet_ros.core.scenario import scenario_for
from tethernet_ros.core.tumble import TumbleConfig, TumbleError

DEG = math.pi / 180.0


def _far_target(cfg: SimConfig):
    """A scenario whose target is out of the net's reach (d_L = 1000 m), spinning."""
    return scenario_for(replace(REFERENCE_DESIGNS["time-min"], d_L=1000.0), None, cfg)


def _body_axis_world(sim) -> np.ndarray:
    return kn.quat_to_matrix(sim.s.target_body.quat)[:, 0]


def test_settings_name_the_field_and_its_range():
    with pytest.raises(TumbleError, match="rate_deg_s.*61.*\\[0, 60\\] deg/s"):
        TumbleConfig(rate_deg_s=61.0)
    with pytest.raises(TumbleError, match="axis.*zero vector"):
        TumbleConfig(rate_deg_s=1.0, axis=(0.0, 0.0, 0.0))
    with pytest.raises(TumbleError, match="axis.*'diagonal'"):
        TumbleConfig(axis="diagonal")
    with pytest.raises(ConfigError, match="tumble.rate"):
        SimConfig.from_dict({"tumble": {"rate": 2.0}})
    cfg = SimConfig.from_dict({"tumble": {"rate_deg_s": 2.0, "axis": [0, 3, 4]}})
    assert cfg.tumble.axis == (0.0, 3.0, 4.0) and cfg.tumble.rate_deg_s == 2.0


def test_torque_free_symmetric_top_keeps_its_momentum_and_precesses_as_the_closed_form():
    """A spin about the long axis plus a transverse component: the stage (a symmetric top,
    I_y = I_z) keeps its world angular momentum L to the bit and its long axis precesses
    about L at |L| / I_t (Landau and Lifshitz, Mechanics, section 33) over 60 s."""
    cfg = SimConfig(tumble=TumbleConfig(rate_deg_s=8.0, axis=(1.0, 0.5, 0.2), phase_deg=30.0),
                    horizon=120.0)
    sim = CaptureSimulation(_far_target(cfg))
    t = sim.s.target_body
    I = t.inertia
    assert I[1] == I[2] and I[0] != I[1]
    L0 = t.ang_mom.copy()
    e0 = _body_axis_world(sim)
    rate = np.linalg.norm(L0) / I[1]
    lhat = L0 / np.linalg.norm(L0)
    worst = 0.0
    for k in range(1, 7):
        sim.advance(10_000)                     # 10 s
        assert np.array_equal(sim.s.target_body.ang_mom, L0)
        # L from the state's attitude and angular velocity agrees to round-off
        R = kn.quat_to_matrix(sim.s.target_body.quat)
        L = R @ (I * (R.T @ sim.s.target_body.omega))
        assert np.allclose(L, L0, rtol=0, atol=1e-12 * np.linalg.norm(L0))
        a = rate * 10.0 * k
        closed = (e0 * math.cos(a) + np.cross(lhat, e0) * math.sin(a)
                  + lhat * np.dot(lhat, e0) * (1 - math.cos(a)))
        worst = max(worst, float(np.linalg.norm(_body_axis_world(sim) - closed)))
    assert worst < 1e-6   # rad, after 60 000 steps


def test_flat_spin_turns_the_long_axis_at_the_set_rate():
    cfg = SimConfig(tumble=TumbleConfig(rate_deg_s=2.0, axis="flat"))
    sim = CaptureSimulation(_far_target(cfg))
    sim.advance(45_000)                         # 45 s at 2 deg/s: 90 deg about body y
    a = _body_axis_world(sim)
    assert abs(abs(a[2]) - 1.0) < 1e-9          # the long axis now on the line of sight


def test_at_rest_changes_nothing_and_noise_only_acts_on_a_tumble():
    d = REFERENCE_DESIGNS["time-min"]
    s = NoiseModel().sample(3)
    assert s.spin_rate_offset != 0.0 and s.spin_phase != 0.0
    base = scenario_for(d, s, SimConfig())
    assert np.array_equal(base.target_body.ang_mom, np.zeros(3))
    spun = scenario_for(d, s, SimConfig(tumble=TumbleConfig(rate_deg_s=2.0, axis="transverse")))
    L = spun.target_body.ang_mom
    assert np.linalg.norm(L) > 0
    R = kn.quat_to_matrix(spun.target_body.quat)
    w_body = R.T @ spun.target_body.omega
    assert abs(w_body[0]) < 0.2 * np.linalg.norm(w_body)   # mostly transverse (axis tilt 5 deg)
    rate = np.linalg.norm(w_body) / DEG
    assert rate == pytest.approx(2.0 * (1 + s.spin_rate_offset), rel=1e-12)


def test_angular_momentum_of_the_whole_system_is_kept_with_the_net_in_contact():
    """After the winch locks (closing started) the system target + net + corner masses +
    tether + chaser is closed: contact impulses act at the bodies' centres with equal and
    opposite moments on the target, threads and drawstring pull along their lines.  Its
    total angular momentum about the origin stays within round-off over 2 s of contact."""
    cfg = SimConfig(tumble=TumbleConfig(rate_deg_s=4.0, axis="los"))
    d = REFERENCE_DESIGNS["time-min"]
    sim = CaptureSimulation(scenario_for(d, NoiseModel().sample(1), cfg))
    while not sim.closing_active:
        sim.advance(100)
    sim.advance(1000)
    assert sim.contact_count > 0

    def total():
        b, t = sim.s.bodies, sim.s.target_body
        dyn = b.w > 0
        assert dyn[sim.s.tether.nodes].all() and dyn[sim.s.tether.winch]
        orbital = (b.mass[dyn, None] * np.cross(b.x[dyn], b.v[dyn])).sum(axis=0)
        return orbital + cfg.target.mass * np.cross(t.pos, t.vel) + t.ang_mom

    L0 = total()
    c0 = sim.contact_count
    sim.advance(2000)
    assert sim.contact_count > c0 + 1000       # in contact throughout
    scale = np.abs(sim.s.bodies.mass[:, None] * np.cross(sim.s.bodies.x, sim.s.bodies.v)).sum()
    assert np.abs(total() - L0).max() < 1e-11 * scale


def test_a_tumbling_capture_runs_and_differs_from_the_static_one():
    d = REFERENCE_DESIGNS["time-min"]
    s = NoiseModel().sample(3)
    cfg = SimConfig(tumble=TumbleConfig(rate_deg_s=8.0, axis="flat"), settle_time=5.0)
    static = run_episode(d, s, SimConfig(settle_time=5.0), record_trace=False)
    spun = run_episode(d, s, cfg, record_trace=False)
    assert spun.failure_reason == "" or "diverged" not in spun.failure_reason
    assert spun.settled_cqi != static.settled_cqi
