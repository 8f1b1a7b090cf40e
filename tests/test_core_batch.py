"""The batched kernel (core/batch.py): each lane gives its episode bit for bit, whatever
the lane count, the refills and the halvings of the batch; lanes of episodes that end in
different ways (success, closing never triggered, different lengths) side by side."""
from __future__ import annotations

import math

import pytest

from tethernet_ros.core.batch import BatchRunner, choose_lanes
from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.core.episode import run_episode
from tethernet_ros.core.noise import NoiseModel
from tethernet_ros.core.sensing import SensingConfig

SHORT = SimConfig(settle_time=2.0, horizon=12.0)


def _outcome(r) -> tuple:
    trace = None if r.trace is None else (tuple(r.trace.cqi), tuple(r.trace.locked_pairs))
    return (r.success, repr(r.settled_cqi), r.locked_pairs, repr(r.closing_time),
            repr(r.completion_time), r.steps, r.failure_reason, repr(r.max_penetration), trace)


@pytest.mark.parametrize("lanes", [1, 2, 4])
def test_every_lane_is_its_single_episode_bit_for_bit(lanes):
    # sub-optimal under a 6 s horizon: some samples close, some never do (T = horizon)
    design = REFERENCE_DESIGNS["suboptimal"]
    cfg = SHORT.replace(horizon=6.0)
    samples = [(i, NoiseModel().sample(40 + i)) for i in range(5)]
    single = {i: run_episode(design, s, cfg, record_trace=True) for i, s in samples}
    kinds = {math.isnan(r.closing_time) for r in single.values()}
    assert kinds == {True, False}, "the samples no longer mix both endings"
    got = {tag: r for tag, r, _ in BatchRunner(design, cfg, lanes=lanes,
                                                record_trace=True).run(samples)}
    assert sorted(got) == sorted(single)
    for i in single:
        assert _outcome(got[i]) == _outcome(single[i]), i


def test_closed_loop_settings_batch_too():
    design = REFERENCE_DESIGNS["time-min"]
    cfg = SHORT.replace(sensing=SensingConfig(rate_hz=20.0, latency=0.1, sigma_position=0.1))
    samples = [(i, NoiseModel().sample(i)) for i in range(3)]
    got = {tag: r for tag, r, _ in BatchRunner(design, cfg, lanes=2).run(samples)}
    for i, s in samples:
        assert _outcome(got[i]) == _outcome(run_episode(design, s, cfg, record_trace=False))


def test_a_lane_count_is_chosen_and_errors_name_the_field():
    assert choose_lanes(SimConfig()) in (1, 2, 4, 8, 16)
    with pytest.raises(ValueError, match="lanes"):
        BatchRunner(REFERENCE_DESIGNS["time-min"], SHORT, lanes=-1)
    assert list(BatchRunner(REFERENCE_DESIGNS["time-min"], SHORT, lanes=2).run([])) == []


def test_lanes_called_early_are_their_single_episodes_bit_for_bit():
    """The exploration fidelity's early call (config.py) ends some lanes at half the settle
    time and lets the others settle on: each lane is still its single episode."""
    from tethernet_ros.core.fidelity import EXPLORATION, at_fidelity

    design = REFERENCE_DESIGNS["time-min"]
    cfg = at_fidelity(SimConfig(settle_time=8.0, horizon=12.0), EXPLORATION)
    samples = [(i, NoiseModel().sample(20 + i)) for i in range(4)]
    single = {i: run_episode(design, s, cfg, record_trace=True) for i, s in samples}
    full = 8.0 / cfg.implicit_dt
    called = {i for i, r in single.items() if r.steps < r.closing_time / cfg.implicit_dt + full - 1}
    assert called, "no sample is called early any more"
    got = {tag: r for tag, r, _ in BatchRunner(design, cfg, lanes=2,
                                                record_trace=True).run(samples)}
    for i in single:
        assert _outcome(got[i]) == _outcome(single[i]), i
