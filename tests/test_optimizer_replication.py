"""The replication benchmark's problem with a known truth (optimizer.testproblems.
LatentDifficulty) and, in a short form, the benchmark itself (benchmarks/
bench_replication.py; the full one: docs/cases/replication.md)."""
import json

import numpy as np
import pytest
from scipy.stats import norm

from optimizer.sequential import SequentialRule
from optimizer.testproblems import LatentDifficulty
from script_modules import load_script


def test_latent_difficulty_fails_nearby_designs_on_the_same_samples():
    """Sample i fails design x exactly when its difficulty u_i >= P_s(x): the failures of a
    more reliable design are a subset of a less reliable one's (common random numbers),
    fresh base seeds draw other difficulties, and the estimate's fields agree with the
    samples."""
    p = LatentDifficulty()
    lo, hi = np.array([0.33, 0.43]), np.array([0.34, 0.44])
    assert p.success_probability(lo) < p.success_probability(hi)
    u = p.difficulties(5, 400)
    fail_lo = set(np.flatnonzero(u >= p.success_probability(lo)))
    fail_hi = set(np.flatnonzero(u >= p.success_probability(hi)))
    assert fail_hi <= fail_lo
    r = p.evaluate(lo, 400, 5)
    assert (r.successes, r.n_samples) == (400 - len(fail_lo), 400)
    assert r.ci_low <= r.p_success <= r.ci_high and r.cp_low <= r.p_success <= r.cp_high
    assert r.mass == pytest.approx(0.76)                # x1 + x2
    assert u[0] == np.random.default_rng(5 * 1_000_003).random()     # the simulator's seeds
    assert not np.array_equal(p.difficulties(6, 400), u)
    rule = SequentialRule(100, 0.98)
    bad = np.array([0.1, 0.1])                        # P_s far below 0.98
    s = p.evaluate(bad, 100, 5, stop=rule)
    assert s.n_samples - s.successes == 3 and s.n_samples < 100     # decided at failure 3


def test_latent_difficulty_optimum_is_the_least_objective_meeting_the_requirement():
    p = LatentDifficulty()
    x, f = p.reference_optimum()
    assert p.success_probability(x) == pytest.approx(0.98, abs=1e-9)
    rng = np.random.default_rng(0)
    X = rng.random((200_000, 2))
    ok = np.array([p.success_probability(v) >= 0.98 for v in X[X.sum(1) < f + 0.02]])
    assert ok.any() and X[X.sum(1) < f + 0.02][ok].sum(1).min() >= f - 1e-9
    assert p.optimum(0.99) > p.optimum(0.985) > f


def test_latent_difficulty_exploration_flips_verdicts_at_the_stated_rates():
    """The exploration fidelity's discrepancy is the one its docstring states: jitter 0
    and shift 0 give the reference's verdicts; jitter 0.5 leaves P_s where it is and flips
    about 16 % of the verdicts at P_s = 0.61 and 1.9 % at 0.98; a shift > 0 raises the
    P_s it sees; a design's noise is the same however many samples are drawn; the
    estimates carry a key of their own; bad settings name their field."""
    ref = LatentDifficulty()
    same = LatentDifficulty(jitter=0.0).at_fidelity("exploration")
    x = np.array([0.33, 0.43])
    a, b = ref.evaluate(x, 2000, 4), same.evaluate(x, 2000, 4)
    assert a.successes == b.successes and a.key != b.key and "@exploration" in b.key
    explore = ref.at_fidelity("exploration")
    assert np.array_equal(explore.jitters(x, 4, 50), explore.jitters(x, 4, 500)[:50])
    from scipy.optimize import brentq
    n = 40_000
    u = ref.difficulties(9, n)
    for p_target, flips in ((0.61, 0.161), (0.98, 0.019)):
        t = brentq(lambda v, p=p_target: ref.success_probability(np.array([v, 0.43])) - p,
                   0, 1)
        d = np.array([t, 0.43])
        ok_ref = u < ref.success_probability(d)
        e = explore.evaluate(d, n, 9)
        assert abs(e.p_success - ok_ref.mean()) < 4 * np.sqrt(flips / n)   # unbiased
        z = (np.sqrt(0.75) * norm.ppf(u) + 0.5 * explore.jitters(d, 9, n))
        flipped = np.mean(ok_ref != (z < norm.ppf(ref.success_probability(d))))
        assert flipped == pytest.approx(flips, abs=0.01)
        assert e.successes == int((z < norm.ppf(ref.success_probability(d))).sum())
        up = LatentDifficulty(shift=0.3).at_fidelity("exploration").evaluate(d, n, 9)
        assert up.p_success > e.p_success
    for field, bad in (("jitter", 1.0), ("shift", 4.0), ("fidelity", "fast")):
        with pytest.raises(ValueError, match=f"^{field}: got"):
            LatentDifficulty(**{field: bad})
    assert "jitter" not in ref.settings() and explore.settings()["jitter"] == 0.5


def _bench():
    return load_script("bench_replication", "benchmarks")


@pytest.mark.slow
def test_replication_benchmark_short_form(tmp_path, capsys):
    """Two replications of every method on a small budget: each is appended as it
    finishes, its truth recomputed from the closed form agrees, a rerun runs nothing
    again (a line cut short by a kill is skipped), and the table lists every method."""
    bench = _bench()
    out = tmp_path / "rep.jsonl"
    argv = ["--replications", "2", "--seed-points", "6", "--iterations", "6",
            "--validation-samples", "200", "--validation-candidates", "3",
            "--racing-round", "50", "--racing-budget", "600", "--gp-restarts", "0",
            "--candidates", "2000", "--out", str(out)]
    assert bench.main(argv) == 0
    records = [json.loads(line) for line in out.read_text().splitlines()]
    assert len(records) == 2 * len(bench.METHODS)
    problem = LatentDifficulty()
    f_star = problem.optimum(0.98)
    for r in records:
        assert r["episodes_total"] == r["episodes"] + r["episodes_racing"] + r["episodes_validation"]
        if r["x"] is not None:
            assert r["p_true"] == problem.success_probability(r["x"])
            assert r["truly_meets"] == (r["p_true"] >= 0.98)
            assert r["regret"] == pytest.approx(r["objective"] - f_star)
            assert r["objective"] == pytest.approx(sum(r["x"]))
        if r["method"] in ("estimate", "wilson", "fresh", "shared"):
            assert r["episodes_racing"] == 0
        else:
            assert r["episodes_racing"] > 0
    text = capsys.readouterr().out
    for method in bench.METHODS:
        assert f"\n{method} " in text
    with open(out, "a") as fh:
        fh.write('{"method": "new", "replica')                  # a kill mid-line
    assert bench.main(argv) == 0
    assert len(out.read_text().splitlines()) == 2 * len(bench.METHODS) + 1
    table = capsys.readouterr().out
    assert "replication" not in table.split("method")[0]        # nothing was run again
    assert "f*(0.98) = " in table
    # searching at the exploration fidelity: its own records, paired with the reference's
    explore = tmp_path / "rep-explore.jsonl"
    argv_x = [*argv[:-1], str(explore), "--methods", "racing+fresh", "--explore-fidelity",
              "--explore-shift", "0.3", "--pair", str(out)]
    assert bench.main(argv_x) == 0
    got = [json.loads(line) for line in explore.read_text().splitlines()]
    assert [r["config"]["search_fidelity"] for r in got] == [
        {"fidelity": "exploration", "jitter": 0.5, "shift": 0.3}] * 2
    text = capsys.readouterr().out
    assert "paired with" in text and "\nracing+fresh  2 " in text
    with pytest.raises(SystemExit):
        bench.main([*argv, "--explore-shift", "0.3"])     # only with --explore-fidelity
