"""Monte Carlo evaluator: statistics, seeds, failure categories, retries, results file and
resume (in-process; the other backends are in test_montecarlo_backends.py)."""
import json
import math

import pytest
from scipy.stats import binomtest

from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.core.metrics import clopper_pearson_interval, wilson_interval
from tethernet_ros.core.noise import NoiseModel
from tethernet_ros import montecarlo as mc
from results_lines import sample_lines

SHORT = SimConfig(settle_time=2.0)
DESIGN = REFERENCE_DESIGNS["time-min"]


# ---------------------------------------------------------------- statistics
def test_wilson_and_clopper_pearson_known_values():
    lo, hi = wilson_interval(98, 100)
    assert lo == pytest.approx(0.92999, abs=1e-5) and hi == pytest.approx(0.99450, abs=1e-5)
    lo, hi = clopper_pearson_interval(98, 100)
    assert lo == pytest.approx(0.92961, abs=1e-5) and hi == pytest.approx(0.99757, abs=1e-5)
    assert clopper_pearson_interval(0, 10) == (0.0, pytest.approx(1 - 0.025 ** 0.1))
    assert clopper_pearson_interval(10, 10) == (pytest.approx(0.025 ** 0.1), 1.0)
    for k, n in [(0, 7), (3, 7), (50, 100), (981, 1000), (1000, 1000)]:
        ci = binomtest(k, n).proportion_ci(0.95, method="exact")
        assert clopper_pearson_interval(k, n) == (pytest.approx(ci.low, abs=1e-9), pytest.approx(ci.high, abs=1e-9))
        ci = binomtest(k, n).proportion_ci(0.95, method="wilson")
        assert wilson_interval(k, n) == (pytest.approx(ci.low, abs=1e-9), pytest.approx(ci.high, abs=1e-9))


def _sample(i, success, T=30.0, category="", key="k"):
    return mc.SampleResult(key=key, index=i, seed=i, success=success, settled_cqi=1.0,
                           locked_pairs=12 if success else 3, closing_time=10.0, completion_time=T,
                           mass=11.0, failure_reason="" if success else category,
                           category=category)


def test_result_statistics_from_samples():
    samples = [_sample(i, True, T=20.0 + i) for i in range(98)]
    samples.append(_sample(98, False, T=120.0, category="closing never triggered"))
    w = mc.worker_error_result(mc.EpisodeTask("k", 99, 99, DESIGN, NoiseModel(), SHORT), "boom")
    samples.append(w)
    r = mc.MonteCarloResult.from_samples(DESIGN, samples[::-1], 0, "k", SHORT)
    assert r.n_samples == 100 and r.successes == 98 and r.p_success == 0.98
    assert (r.ci_low, r.ci_high) == wilson_interval(98, 100)
    assert (r.cp_low, r.cp_high) == clopper_pearson_interval(98, 100)
    assert r.failures_by_reason == {"closing never triggered": 1, "worker error": 1}
    assert sum(r.failures_by_reason.values()) == r.failures == 2
    # mean T over the 99 samples with a finite T (the worker error has none)
    assert r.mean_completion_time == pytest.approx((sum(20.0 + i for i in range(98)) + 120.0) / 99)
    assert r.mean_completion_time_success == pytest.approx(sum(20.0 + i for i in range(98)) / 98)
    assert [s.index for s in r.samples] == list(range(100))
    assert r.mass == pytest.approx(DESIGN.mass())
    d = r.to_dict()
    for k in ("p_success", "ci_low", "ci_high", "mean_completion_time", "mass", "samples",
              "failures_by_reason"):
        assert k in d
    assert w.failure_reason == "worker error: boom" and w.attempts == 1 and not w.success


def test_failure_categories():
    c = SimConfig()
    f = mc.failure_category
    assert f("", c) == ""
    assert f("closing never triggered within the 120 s horizon", c) == "closing never triggered"
    assert f("simulation diverged: body speed 600 m/s", c) == "diverged"
    assert f("settled CQI 2.345 > 2", c) == "settled CQI > 2"
    assert f("3 locked pairs < 10", c) == "locked pairs < 10"
    assert f("settled CQI 2.3 > 2; 3 locked pairs < 10", c) == "settled CQI > 2 and locked pairs < 10"
    assert f("worker error: RuntimeError: x", c) == "worker error"
    # the numbers decide when given, whatever the wording
    assert f("anything", c, settled_cqi=2.5, locked_pairs=11, closing_time=3.0) == "settled CQI > 2"
    assert f("anything", c, settled_cqi=1.0, locked_pairs=9, closing_time=3.0) == "locked pairs < 10"
    assert f("anything", c, settled_cqi=math.nan, locked_pairs=0, closing_time=math.nan) == \
        "closing never triggered"


def test_seed_mapping_common_random_numbers():
    assert [mc.sample_seed(0, i) for i in range(3)] == [0, 1, 2]
    assert mc.sample_seed(2, 5) == 2 * 1_000_003 + 5
    # the key depends on design, noise and config; seeds never do
    k1 = mc.run_key(DESIGN, NoiseModel(), SHORT)
    assert k1 == mc.run_key(DESIGN, NoiseModel(), SimConfig(settle_time=2.0))
    assert k1 != mc.run_key(REFERENCE_DESIGNS["baseline"], NoiseModel(), SHORT)
    assert k1 != mc.run_key(DESIGN, NoiseModel().with_scales(speed=2.0), SHORT)
    assert k1 != mc.run_key(DESIGN, NoiseModel(), SimConfig(settle_time=3.0))


# ---------------------------------------------------------------- retry logic (no simulation)
class FakeBackend(mc.EpisodeBackend):
    """Yields scripted outcomes: seeds in ``die`` crash (every try, or the first only if
    in ``die_once``), seeds in ``raise_`` raise; records the concurrency of each map."""

    def __init__(self, die=(), die_once=(), raise_=()):
        self.die, self.die_once, self.raise_ = set(die), set(die_once), set(raise_)
        self.calls = []

    def map(self, tasks, max_in_flight=None):
        tasks = list(tasks)
        self.calls.append(([t.seed for t in tasks], max_in_flight))
        for t in tasks:
            if t.seed in self.die or (t.seed in self.die_once and t.attempt == 0):
                yield mc.Outcome(t, error="worker process died", crashed=True)
            elif t.seed in self.raise_:
                yield mc.Outcome(t, error="RuntimeError: bad")
            else:
                yield mc.Outcome(t, mc.SampleResult(t.key, t.index, t.seed, True, 1.0, 12, 1.0, 2.0,
                                                    1.0, "", "", attempts=t.attempt + 1))


def test_run_tasks_retries_once_then_reports_worker_error():
    tasks = [mc.EpisodeTask("k", i, i, DESIGN, NoiseModel(), SHORT) for i in range(6)]
    be = FakeBackend(die={1}, die_once={2}, raise_={3})
    out = {r.seed: r for r in mc.run_tasks(be, tasks)}
    assert sorted(out) == list(range(6))                       # nothing dropped
    assert out[1].category == "worker error" and "died" in out[1].failure_reason
    assert out[1].attempts == 2
    assert out[2].success and out[2].attempts == 2             # died once, retry succeeded
    assert out[3].failure_reason == "worker error: RuntimeError: bad" and out[3].attempts == 2
    assert all(out[i].success and out[i].attempts == 1 for i in (0, 4, 5))
    # first pass concurrent; raised task retried with the others, crashed ones alone
    assert be.calls[0] == (list(range(6)), None)
    assert ([3], None) in be.calls and ([1, 2], 1) in be.calls
    assert len(be.calls) == 3


# ---------------------------------------------------------------- results file
def test_results_file_repairs_partial_last_line(tmp_path):
    p = tmp_path / "r.jsonl"
    rf = mc.ResultsFile(p)
    for i in range(3):
        rf.append(_sample(i, i != 1, category="" if i != 1 else "locked pairs < 10"))
    text = p.read_text()
    p.write_text(text + text.splitlines()[0][:37])          # killed mid-write
    got = rf.load()
    assert sorted(got) == [("k", 0), ("k", 1), ("k", 2)]
    assert p.read_text() == text                              # partial tail cut off
    rf.append(_sample(3, True))
    assert len(rf.load()) == 4 and rf.skipped_lines == 0
    assert all(json.loads(line)["v"] == mc.RECORD_VERSION for line in sample_lines(p))


@pytest.fixture(scope="module")
def reference_run(tmp_path_factory):
    """4 short samples in-process with traces, written to a results file."""
    path = tmp_path_factory.mktemp("mc") / "ref.jsonl"
    r = mc.evaluate(DESIGN, 4, 0, NoiseModel(), SHORT, mc.InProcessBackend(), results_path=path,
                    record_trace=True, label="time-min")
    return r, path


def test_evaluate_in_process(reference_run):
    r, path = reference_run
    assert r.n_samples == 4 and [s.seed for s in r.samples] == [0, 1, 2, 3]
    assert r.successes + sum(r.failures_by_reason.values()) == 4
    assert all(s.trace and len(s.trace["cqi"]) == len(s.trace["time"]) > 10 for s in r.samples)
    assert len(sample_lines(path)) == 4
    # the sample equals a direct run of the core with the same seed (common random numbers)
    from tethernet_ros.core.episode import run_episode

    e = run_episode(DESIGN, NoiseModel().sample(2), SHORT, record_trace=False)
    s = r.samples[2]
    assert (s.settled_cqi, s.locked_pairs, s.completion_time, s.success) == \
        (e.settled_cqi, e.locked_pairs, e.completion_time, e.success)


def test_resume_after_truncation_gives_same_result(reference_run, tmp_path):
    r, path = reference_run
    lines = sample_lines(path, keepends=True)
    cut = tmp_path / "cut.jsonl"
    cut.write_text("".join(lines[:2]) + lines[2][: len(lines[2]) // 2])   # killed mid-line
    progress = []
    r2 = mc.evaluate(DESIGN, 4, 0, NoiseModel(), SHORT, mc.InProcessBackend(), results_path=cut,
                     record_trace=True, progress=lambda d, t, s: progress.append((d, t)))
    assert r2.reused == 2 and progress[0] == (2, 4) and progress[-1] == (4, 4)
    assert [s.outcome() for s in r2.samples] == [s.outcome() for s in r.samples]
    assert (r2.p_success, r2.mean_completion_time, r2.failures_by_reason) == \
        (r.p_success, r.mean_completion_time, r.failures_by_reason)
    assert len(sample_lines(cut)) == 4
    # a complete file: nothing left to simulate, and a larger N reuses the first samples
    r3 = mc.evaluate(DESIGN, 4, 0, NoiseModel(), SHORT, mc.InProcessBackend(), results_path=cut,
                     record_trace=True)
    assert r3.reused == 4 and [s.outcome() for s in r3.samples] == [s.outcome() for s in r.samples]


def test_in_process_raise_is_retried_then_counted(monkeypatch):
    monkeypatch.setenv(mc.FAULT_ENV, "raise-once:0,raise:1")
    cfg = SimConfig(settle_time=2.0, horizon=2.0)   # fast: closing never triggers
    r = mc.evaluate(DESIGN, 3, 0, NoiseModel(), cfg, mc.InProcessBackend())
    s0, s1, s2 = r.samples
    assert s0.attempts == 2 and s0.category == "closing never triggered"
    assert s1.category == "worker error" and "injected fault" in s1.failure_reason
    assert s2.attempts == 1
    assert r.failures_by_reason == {"closing never triggered": 2, "worker error": 1}


def test_evaluate_many_shares_identical_runs():
    cfg = SimConfig(horizon=1.0)
    be = FakeBackend()
    nm = NoiseModel()
    specs = [mc.RunSpec(DESIGN, nm.with_scales(speed=s), cfg, f"x{s}") for s in (0.5, 1.0)]
    specs.append(mc.RunSpec(DESIGN, nm.with_scales(closing=1.0), cfg, "closing x1"))
    res = mc.evaluate_many(specs, 3, 0, be)
    assert len(be.calls) == 1 and len(be.calls[0][0]) == 6    # scale-1 run simulated once
    assert [r.label for r in res] == ["x0.5", "x1.0", "closing x1"]
    assert res[1].key == res[2].key and res[0].key != res[1].key
    with pytest.raises(ValueError):
        mc.evaluate(DESIGN, 0, 0, backend=be)
    with pytest.raises(ValueError):
        mc.evaluate(DESIGN, 2, -1, backend=be)


class ControllerBackend(mc.InProcessBackend):
    """The in-process backend as if a user's controller (``source``) decided the episodes."""

    def __init__(self, source):
        super().__init__()
        self.episode_source = source


def test_resume_never_mixes_samples_of_another_controller(tmp_path):
    cfg = SimConfig(settle_time=2.0, horizon=1.0)      # fast: closing never triggers
    path = tmp_path / "r.jsonl"
    plain = mc.run_key(DESIGN, NoiseModel(), cfg)
    assert mc.run_key(DESIGN, NoiseModel(), cfg, episode_source=None) == plain
    assert mc.run_key(DESIGN, NoiseModel(), cfg, episode_source="a:Ctl sha256:1") != plain
    first = mc.evaluate(DESIGN, 2, 0, NoiseModel(), cfg, ControllerBackend("a:Ctl sha256:1"),
                        results_path=path)
    edited = mc.evaluate(DESIGN, 2, 0, NoiseModel(), cfg, ControllerBackend("a:Ctl sha256:2"),
                         results_path=path)
    assert first.reused == 0 and edited.reused == 0 and edited.key != first.key
    again = mc.evaluate(DESIGN, 2, 0, NoiseModel(), cfg, ControllerBackend("a:Ctl sha256:1"),
                        results_path=path)
    assert again.reused == 2 and again.key == first.key
    library = mc.evaluate(DESIGN, 2, 0, NoiseModel(), cfg, mc.InProcessBackend(),
                          results_path=path)
    assert library.reused == 0 and library.key == plain
