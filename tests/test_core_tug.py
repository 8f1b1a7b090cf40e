"""The tug test (core/tug.py, docs/model.md §17) and the tether's order (§5): the thrust's
impulse, the verdicts on a held and a lost capture, the refusals, and that nothing changes
while the test is off."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tethernet_ros.core.config import ConfigError, SimConfig
from tethernet_ros.core.design import load_design
from tethernet_ros.core.episode import CaptureSimulation, run_episode, run_simulation
from tethernet_ros.core.scenario import scenario_for
from tethernet_ros.core.tug import TugConfig, TugError, breaking_load

#: short phases: a 2 s settle and a 3 s hold (the protocol's own are 20 s and 10 s)
SHORT = dict(settle_time=2.0, tether_order="chain")


def _tug(peak=4000.0, **kw):
    """The test at one level, ``peak`` (N), with a 3 s hold (no ladder unless asked)."""
    return TugConfig(enabled=True, peak_tension=peak,
                     **{"hold_time": 3.0, "ladder_levels": 0, **kw})


@pytest.fixture(scope="module")
def mass_min():
    return load_design("mass-min")


def test_chain_tether_is_locked_straight(mass_min):
    """At closing the 'chain' tether's rest length is the winch-to-centre distance (its
    masses evenly on the line, in chain order); the 'reversed' one zigzags, each of its
    end segments spanning most of the line."""
    for order in ("chain", "reversed"):
        sc = scenario_for(mass_min, None, SimConfig(settle_time=0.0, tether_order=order))
        sim = CaptureSimulation(sc)
        run_simulation(sim, record_trace=False)
        rest = sc.links.rest[sc.tether.links]
        x = sc.bodies.x
        line = float(np.linalg.norm(x[sc.tether.centre] - x[sc.tether.winch]))
        if order == "chain":
            assert rest.sum() == pytest.approx(line, rel=1e-3)
            assert rest.max() / rest.min() == pytest.approx(1.0, rel=1e-6)
        else:
            assert rest.sum() > 2.0 * line
            assert rest[0] > 0.8 * line and rest[-1] > 0.8 * line


def test_tug_off_changes_nothing(mass_min):
    """Settings of a test that is off change no bit of the episode."""
    base = SimConfig(**SHORT)
    off = base.replace(tug=dataclasses.replace(_tug(), enabled=False))
    a = run_episode(mass_min, None, base, record_trace=False)
    b = run_episode(mass_min, None, off, record_trace=False)
    assert b.tug is None
    for k in ("success", "settled_cqi", "locked_pairs", "closing_time", "completion_time",
              "steps", "max_penetration"):
        assert getattr(a, k) == getattr(b, k), k


def test_thrust_impulse_is_the_momentum_gained(mass_min):
    """The thrust is the only external force during the test: the system's linear momentum
    (every body with mass and the target) gains the impulse the kernel applied, to
    round-off; the pull starts only once the tether is taut, and the verdict of the settle
    time is kept."""
    cfg = SimConfig(**SHORT, tug=_tug(1000.0))
    sc = scenario_for(mass_min, None, cfg)
    sim = CaptureSimulation(sc)
    res = run_simulation(sim, record_trace=False)
    assert res.tug is not None and res.tug["take_up_time"] >= 0
    impulse = sim.data.tug_impulse[:, 0]
    gained = sim.linear_momentum() - sim.tug.start_momentum
    assert np.allclose(gained, impulse, rtol=1e-9, atol=1e-9 * np.linalg.norm(impulse))
    # the thrust acted in every step of the hold, and in some of taking up the slack
    h = sim.dt
    hold = 1000.0 * h * sim.tug.hold_steps
    took = res.tug["take_up_time"]
    assert hold < float(np.linalg.norm(impulse)) <= hold + 1000.0 * (took + 2 * h)
    assert res.completion_time == pytest.approx(res.closing_time + 2.0, abs=2 * h)


def test_held_and_false_capture(mass_min):
    """The nominal mass-min capture holds under 4 kN; a capture the CQI calls a success
    (closing early, ejection slower along the line of sight) lets go: its net slides off and
    the target stays behind (a false capture, the source's warning)."""
    cfg = SimConfig(**SHORT, tug=_tug(4000.0))
    held = run_episode(mass_min, None, cfg, record_trace=False)
    assert held.success and held.tug["held"], held.tug
    assert held.tug["net_offset"] < 5.0 and held.tug["slid_share"] < 0.5
    assert held.tug["take_up_time"] > 0.0            # the net's slack, taken up at creep speed
    assert 0.0 < held.tug["peak_tension"] <= breaking_load(cfg.tug, 0.002) * 1.0
    lost_design = dataclasses.replace(mass_min, d_c=-2.5, V_e=(3.5, 3.5, 5.0))
    lost = run_episode(lost_design, None, cfg, record_trace=False)
    assert lost.success, "the CQI judges this capture a success"
    assert not lost.tug["held"]
    assert "did not follow" in lost.tug["reason"]
    assert lost.tug["take_up_time"] is None           # the pull never found the target
    assert lost.tug["net_offset"] > 10.0
    assert lost.tug["slid_share"] == 1.0 and lost.tug["largest_slip"] > 10.0


def test_tug_refusals():
    """Each bad setting is refused naming its field and what is allowed."""
    with pytest.raises(ConfigError, match="tether_order"):
        SimConfig(tug=_tug())
    with pytest.raises(TugError, match="hold_time"):
        TugConfig(hold_time=0.0)
    with pytest.raises(ConfigError, match="tug field 'max_slid_share'"):
        SimConfig.from_dict({"tug": {"max_slid_share": 2.0}})
    with pytest.raises(ConfigError, match="tug.nope"):
        SimConfig.from_dict({"tug": {"nope": 1}})
    design = load_design("mass-min")
    with pytest.raises(TugError, match="breaking load"):
        scenario_for(design, None, SimConfig(**SHORT, tug=_tug(1e6)))


def test_the_example_config_file_turns_the_test_on():
    """config/tug.yaml (the README's example) is a valid configuration with the test on;
    config/held.yaml one judged by criterion 'held' at 0.05 m/s^2."""
    import pathlib

    import yaml

    path = pathlib.Path(__file__).resolve().parent.parent / "config" / "tug.yaml"
    cfg = SimConfig.from_dict(yaml.safe_load(path.read_text()))
    assert cfg.tug.enabled and cfg.tug.peak_tension == 400.0 and cfg.tether_order == "chain"
    held = SimConfig.from_dict(yaml.safe_load((path.parent / "held.yaml").read_text()))
    assert held.criterion == "held" and held.tug.enabled and held.tether_order == "chain"
    assert (held.tug.peak_tension, held.tug.tow_acceleration) == (0.0, 0.05)


def test_batch_lanes_equal_single_runs_with_the_test(mass_min):
    """The test in the lanes of a batch gives the single runs' verdicts and measures, bit
    for bit (the phases end at the same clock steps; lanes never read each other)."""
    from tethernet_ros.core.batch import BatchRunner
    from tethernet_ros.core.noise import NoiseModel

    cfg = SimConfig(**SHORT, tug=_tug(400.0, ladder_levels=2))
    noise = NoiseModel()
    samples = [(i, noise.sample(i)) for i in (0, 1, 2)]
    single = {i: run_episode(mass_min, s, cfg, record_trace=False) for i, s in samples}
    batch = {tag: r for tag, r, _ in BatchRunner(mass_min, cfg, lanes=2).run(samples)}
    for i, r in single.items():
        assert batch[i].tug == r.tug, i
        assert (batch[i].settled_cqi, batch[i].steps) == (r.settled_cqi, r.steps), i


def test_confusion_counts_false_and_missed_captures():
    """studies/tug.py sorts samples by the source's verdict against the tug's."""
    from types import SimpleNamespace

    from tethernet_ros.studies.tug import confusion, confusion_table

    def s(success, held, peak=1000.0, slid=0.1):
        tug = None if held is None else {"held": held, "reason": "" if held else "x: y",
                                         "peak_tension": peak, "slid_share": slid}
        return SimpleNamespace(success=success, tug=tug)
    samples = [s(True, True), s(True, False, slid=1.0), s(True, False, peak=5e4, slid=1.0),
               s(False, True), s(False, False), s(False, None)]
    c = confusion("cell", samples, breaking=4e4)
    assert (c.n, c.source_success, c.held) == (6, 3, 2)
    assert (c.agree_held, c.false_captures, c.missed_captures, c.agree_lost, c.untested) == \
        (1, 2, 1, 1, 1)
    assert c.hold_share == pytest.approx(1 / 3) and c.over_breaking == 1
    assert c.false_reasons == {"x": 2} and c.slid_median_lost == 1.0
    assert "| cell | 6 | 3 | 2 | 1 | **2** | 1 | 1 | 1 |" in confusion_table([c])


def _at_required_pull(tug: dict) -> dict:
    """A verdict's measures at the required pull (without the ladder above it)."""
    return {k: v for k, v in tug.items() if k not in ("holding_force", "ladder")}


def test_ladder_keeps_the_single_level_verdict(mass_min):
    """With the holding-force ladder on, the verdict and every measure at the required
    pull are those of a single-level test at that pull, bit for bit (the ladder only
    follows it); the holding force is the largest level held, each level the last's
    times the ratio, and a lost capture climbs no ladder."""
    pull = 0.05 * 8300.0
    single = SimConfig(**SHORT, tug=_tug(pull))
    ladder = SimConfig(**SHORT, tug=_tug(pull, ladder_levels=3))
    a = run_episode(mass_min, None, single, record_trace=False)
    b = run_episode(mass_min, None, ladder, record_trace=False)
    assert a.tug["held"] and a.tug["holding_force"] == pull and a.tug["ladder"] == []
    assert _at_required_pull(b.tug) == _at_required_pull(a.tug)
    assert (b.success, b.settled_cqi, b.completion_time) == (a.success, a.settled_cqi,
                                                              a.completion_time)
    levels = [lv["force"] for lv in b.tug["ladder"]]
    assert levels == [pull * 2.0 ** k for k in range(1, len(levels) + 1)] and levels
    held = [lv["force"] for lv in b.tug["ladder"] if lv["held"]]
    assert b.tug["holding_force"] == (held[-1] if held else pull)
    # a level after a lost one is never tried: the levels are held up to the first lost
    flags = [lv["held"] for lv in b.tug["ladder"]]
    assert flags == sorted(flags, reverse=True) and flags.count(False) <= 1
    assert b.steps > a.steps
    lost_design = dataclasses.replace(mass_min, d_c=-2.5, V_e=(3.5, 3.5, 5.0))
    lost = run_episode(lost_design, None, SimConfig(**SHORT, tug=_tug(4000.0, ladder_levels=3)),
                       record_trace=False)
    assert not lost.tug["held"] and lost.tug["holding_force"] == 0.0 and lost.tug["ladder"] == []


def test_ladder_stops_below_the_breaking_load():
    """The ladder's levels never exceed the tether's breaking load."""
    from tethernet_ros.core.tug import pull_ladder

    tug = TugConfig(enabled=True, ladder_levels=10, ladder_ratio=2.0)
    limit = breaking_load(tug, 0.002)
    levels = pull_ladder(tug, 415.0, 0.002)
    assert levels == tuple(415.0 * 2.0 ** k for k in range(1, 7))     # 26.56 kN < 41.5 kN
    assert max(levels) <= limit < 2.0 * max(levels)
    assert pull_ladder(dataclasses.replace(tug, ladder_levels=0), 415.0, 0.002) == ()


def test_required_pull_is_the_towing_acceleration_times_the_target_mass(mass_min):
    """criterion 'held' turns the test on with the straight tether; its pull is
    tow_acceleration times the episode's target mass (the drawn one under mass noise),
    and a thrust given directly (peak_tension, --tug N) stands for it."""
    from tethernet_ros.core.noise import NoiseModel

    cfg = SimConfig.from_dict({"criterion": "held"})
    assert cfg.tug.enabled and cfg.tether_order == "chain" and cfg.tug.tow_acceleration == 0.05
    sc = scenario_for(mass_min, None, cfg)
    m_t = 1.0 / float(sc.target_body.inv_mass)
    assert m_t == 8300.0 and sc.tug_pull == 0.05 * m_t
    sample = NoiseModel(sigma_target_mass=0.05).sample(3)
    drawn = scenario_for(mass_min, sample, cfg)
    m_drawn = 1.0 / float(drawn.target_body.inv_mass)
    assert m_drawn != m_t and drawn.tug_pull == 0.05 * m_drawn
    given = SimConfig.from_dict({"criterion": "held", "tug": {"peak_tension": 400.0}})
    assert scenario_for(mass_min, None, given).tug_pull == 400.0
    with pytest.raises(ConfigError, match="criterion"):
        SimConfig(criterion="held")                    # built directly, the test off


def test_held_criterion_judges_by_the_tug(mass_min):
    """Under criterion 'held' success is the source's success and the tug holding at the
    required pull; the tug runs only on the source's successes; the result records the
    criterion."""
    short = dict(SHORT, tug={"hold_time": 3.0, "ladder_levels": 0})
    held = run_episode(mass_min, None, SimConfig.from_dict({**short, "criterion": "held"}),
                       record_trace=False)
    assert held.success and held.tug["held"] and held.criterion == "held"
    assert held.tug["peak_force"] == 415.0
    # the false capture: the source says success, the tug pulls the net off
    lost_design = dataclasses.replace(mass_min, d_c=-2.5, V_e=(3.5, 3.5, 5.0))
    pulled = {**short, "criterion": "held",
              "tug": {**short["tug"], "tow_acceleration": 4000.0 / 8300.0}}
    lost = run_episode(lost_design, None, SimConfig.from_dict(pulled), record_trace=False)
    assert lost.settled_cqi <= 2.0 and lost.locked_pairs >= 10       # the source's success
    assert not lost.success and lost.failure_reason.startswith("not held under the required pull")
    assert "did not follow" in lost.failure_reason
    # a source failure is not pulled (the same settled state, a stricter CQI threshold)
    strict = SimConfig.from_dict({**short, "criterion": "held", "success_cqi": 0.01})
    failed = run_episode(mass_min, None, strict, record_trace=False)
    assert not failed.success and failed.tug is None and "CQI" in failed.failure_reason
    assert failed.steps < held.steps
    source = run_episode(mass_min, None, SimConfig(**SHORT), record_trace=False)
    assert source.criterion == "source" and source.tug is None
    assert (failed.settled_cqi, failed.locked_pairs) == (held.settled_cqi, held.locked_pairs)


@pytest.mark.parametrize("value", [-0.05, 0.0, float("nan"), float("inf")])
def test_bad_tow_acceleration_is_refused_naming_it(value):
    with pytest.raises(TugError, match=r"tug field 'tow_acceleration': got .*; must be an "
                                       r"acceleration in \[1e-4, 10\] m/s\^2"):
        TugConfig(tow_acceleration=value)
    with pytest.raises(ConfigError, match="tug field 'tow_acceleration'"):
        SimConfig.from_dict({"criterion": "held", "tug": {"tow_acceleration": value}})


def test_a_pull_above_the_breaking_load_and_an_unknown_criterion_are_refused(mass_min):
    cfg = SimConfig.from_dict({"criterion": "held", "tug": {"tow_acceleration": 6.0}})
    with pytest.raises(TugError, match=r"tug field 'tow_acceleration': got 6 m/s\^2, a pull of "
                                       r"4.98e\+04 N .* must be at most 4.996 m/s\^2"):
        scenario_for(mass_min, None, cfg)
    with pytest.raises(ConfigError, match="config field 'criterion': got 'tug'; must be one of "
                                          "'source', 'held'"):
        SimConfig.from_dict({"criterion": "tug"})


def test_explicit_method_runs_the_test_and_conserves_momentum(mass_min):
    """The explicit method runs the tug (its tension is the step's Kelvin-Voigt force of
    a tether segment): the system's momentum gains the thrust's impulse, to round-off,
    and the tether carried the pull (docs/studies/tug-checks.md compares the methods)."""
    cfg = SimConfig(**SHORT, integrator="explicit", tug=_tug(1000.0, hold_time=1.0))
    sc = scenario_for(mass_min, None, cfg)
    sim = CaptureSimulation(sc)
    res = run_simulation(sim, record_trace=False)
    assert res.tug is not None and res.tug["take_up_time"] is not None
    impulse = sim.data.tug_impulse[:, 0]
    gained = sim.linear_momentum() - sim.tug.start_momentum
    assert np.allclose(gained, impulse, rtol=1e-9, atol=1e-9 * np.linalg.norm(impulse))
    assert res.tug["peak_tension"] >= 500.0


def test_exploration_under_the_tug_leaves_the_early_call_off():
    """The exploration fidelity of a configuration with the tug on sets the 2 ms step and
    8 sweeps, not the early call (the test starts from the settle time's state)."""
    from tethernet_ros.core.fidelity import at_fidelity, fidelity_text

    held = SimConfig.from_dict({"criterion": "held"})
    fast = at_fidelity(held, "exploration")
    assert (fast.implicit_dt, fast.implicit_iterations, fast.early_call) == (2e-3, 8, False)
    assert "early_call" not in fidelity_text("exploration", held)
    assert at_fidelity(SimConfig(), "exploration").early_call


def test_the_cinch_keeps_pulling_every_pair(mass_min):
    """lock_model 'cinch' (a winch that keeps reeling the drawstring in): the closing force
    acts on every pair always, so the neck ends tighter than under the source's latch, which
    stops pulling a pair below the lock distance; no rigid limit is added (the ratchet's),
    so every pair still locks."""
    def gaps(lock):
        sc = scenario_for(mass_min, None, SimConfig(settle_time=5.0, lock_model=lock))
        sim = CaptureSimulation(sc)
        res = run_simulation(sim, record_trace=False)
        x, p = sc.bodies.x, sc.drawstring.pairs
        return res, np.sqrt(((x[p[:, 1]] - x[p[:, 0]]) ** 2).sum(axis=1))
    latch, g_latch = gaps("latch")
    cinch, g_cinch = gaps("cinch")
    assert cinch.locked_pairs == 12 and latch.locked_pairs == 12
    assert g_cinch.mean() < 0.8 * g_latch.mean(), (g_cinch.mean(), g_latch.mean())
    assert g_latch.min() > 0.5 * SimConfig().lock_distance
