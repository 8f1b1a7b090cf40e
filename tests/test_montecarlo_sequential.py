"""Sequential sampling in the Monte Carlo evaluator (evaluate(..., stop=rule)): batches the
size of the worker pool, a result that rests on the deciding prefix of the samples and is
the same whatever the batch size, and resumption from a results file.  Synthetic episodes
(tests/optimizer_fakes.py), no physics."""
import pytest

from optimizer.sequential import SequentialRule
from optimizer_fakes import SyntheticBackend, synthetic_probability
from tethernet_ros import montecarlo as mc
from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS, Design
from results_lines import sample_lines

CFG = SimConfig.preset("spec-text")
#: true P_s about 0.9: infeasible for C_P = 0.98, decided after some 30 samples
DESIGN = Design(m_c=1.0, L_n=17.2, r_n=0.001, d_L=20.0, V_e=(2.0, 2.0, 5.0), d_c=0.0)
RULE = SequentialRule(100, 0.98)


def _evaluate(backend, **kw):
    return mc.evaluate(DESIGN, 100, 1, config=CFG, backend=backend, stop=RULE, **kw)


def test_stops_at_the_third_failure_with_the_same_result_for_any_batch_size():
    assert 0.85 < synthetic_probability(DESIGN) < 0.95
    full = mc.evaluate(DESIGN, 100, 1, config=CFG, backend=SyntheticBackend())
    first_fails = [r.index for r in full.samples if not r.success][:3]
    results = {}
    for workers in (1, 2, 3, 8):
        be = SyntheticBackend(workers=workers)
        r = _evaluate(be)
        results[workers] = r
        assert r.n_samples == first_fails[2] + 1 and r.failures == 3       # decided at failure 3
        assert [s.outcome() for s in r.samples] == [s.outcome() for s in full.samples[:r.n_samples]]
        assert all(b <= workers for b in be.batches) and be.batches[0] == workers
        assert r.n_samples <= len(be.tasks) < r.n_samples + workers        # past it: < 1 batch
    ref = results[1]
    for r in results.values():
        assert (r.successes, r.n_samples, r.p_success, r.ci_low, r.ci_high,
                r.mean_completion_time) == (ref.successes, ref.n_samples, ref.p_success,
                                            ref.ci_low, ref.ci_high, ref.mean_completion_time)
    # a batch size given explicitly wins over the worker count
    be = SyntheticBackend(workers=2)
    assert _evaluate(be, batch_size=5).n_samples == ref.n_samples and be.batches[0] == 5


def test_a_feasible_design_keeps_its_samples_unless_the_rule_stops_early():
    good = REFERENCE_DESIGNS["suboptimal"]                 # synthetic P_s > 0.999
    assert synthetic_probability(good) > 0.999
    r = mc.evaluate(good, 100, 1, config=CFG, backend=SyntheticBackend(), stop=RULE)
    assert r.n_samples == 98 and r.successes == 98        # 2 failures could not change it
    keep = SequentialRule(100, 0.98, stop_when_feasible=False)
    r = mc.evaluate(good, 100, 1, config=CFG, backend=SyntheticBackend(), stop=keep)
    assert r.n_samples == 100


def test_resumes_from_the_results_file(tmp_path):
    path = tmp_path / "samples.jsonl"
    ref = _evaluate(SyntheticBackend(workers=4), results_path=path)
    lines = sample_lines(path)
    path.write_text("\n".join(lines[:7]) + "\n" + lines[7][:15])  # killed mid-record
    be = SyntheticBackend(workers=4)
    again = _evaluate(be, results_path=path)
    assert [s.outcome() for s in again.samples] == [s.outcome() for s in ref.samples]
    assert again.reused == 7 and {t.index for t in be.tasks}.isdisjoint(range(7))
    be = SyntheticBackend()
    assert _evaluate(be, results_path=path).reused == ref.n_samples and be.tasks == []


def test_progress_and_arguments():
    seen = []
    r = _evaluate(SyntheticBackend(workers=2), progress=lambda d, t, res: seen.append((d, t)))
    assert all(t == 100 for _, t in seen) and max(d for d, _ in seen) >= r.n_samples
    with pytest.raises(ValueError, match="batch_size"):
        _evaluate(SyntheticBackend(), batch_size=0)


def test_groups_spread_over_the_workers():
    assert mc.group_size_for(8, 2) == 4 and mc.group_size_for(3, 2) == 2
    assert mc.group_size_for(1000, 2) == mc.GROUP_SIZE and mc.group_size_for(0, 2) == 1
    assert mc.group_size_for(5, 1, group_size=4) == 4


def test_a_pool_draws_one_sample_per_lane_at_a_time(tmp_path):
    """Real episodes on two worker processes: a design that can only fail (closing never
    triggers within the horizon) is decided at its third sample; the pool draws one batch:
    the 6 samples the rule expects a decision to take at the start (3 failures at rate
    1/2), or one per lane of each worker if that is more, not a refill's worth more."""
    from tethernet_ros.core.batch import choose_lanes

    never = SimConfig(settle_time=2.0, horizon=1.0)
    path = tmp_path / "samples.jsonl"
    with mc.ProcessPoolBackend(2) as be:
        size, most = be.batch_size, be.max_batch_size
        r = mc.evaluate(DESIGN, 100, 1, config=never, backend=be, stop=RULE, results_path=path)
    assert size == 2 * min(mc.GROUP_SIZE, choose_lanes()) and most == 2 * mc.GROUP_SIZE
    assert r.n_samples == 3 and r.failures == 3
    assert len(sample_lines(path)) == max(size, 6)


class RefillingBackend(SyntheticBackend):
    """A synthetic backend of 4 lanes that may take up to 16 samples at a time."""

    @property
    def max_batch_size(self) -> int:
        return 16


def test_batches_follow_the_expected_samples_to_a_decision_and_change_nothing():
    rule = SequentialRule(100, 0.98, stop_when_feasible=False)
    assert rule.expected_to_decide([]) == pytest.approx(6.0)          # p = 1/2: 3 / (1/2)
    assert rule.expected_to_decide([True] * 20) == pytest.approx(66.0)  # 3 / (1/22)
    assert rule.expected_to_decide([False] * 3) == 0.0                  # decided
    assert SequentialRule(100, 0.98).expected_to_decide([True] * 90) == pytest.approx(
        8 / (91 / 92))                                                   # to the 98th success
    good = REFERENCE_DESIGNS["suboptimal"]                 # synthetic P_s > 0.999
    for design in (DESIGN, good):
        fixed, refill = SyntheticBackend(workers=4), RefillingBackend(workers=4)
        a = mc.evaluate(design, 100, 1, config=CFG, backend=fixed, stop=rule)
        b = mc.evaluate(design, 100, 1, config=CFG, backend=refill, stop=rule)
        assert [s.outcome() for s in a.samples] == [s.outcome() for s in b.samples]
        assert set(fixed.batches) <= {4} and max(refill.batches) <= 16
    assert refill.batches[:2] == [6, 16]           # the good design: 6 to start, then 16
    assert len(refill.batches) < len(fixed.batches)
