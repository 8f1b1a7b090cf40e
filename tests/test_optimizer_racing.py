"""Racing before validation (optimizer/racing.py) and fresh samples for the feasibility
model (optimizer/evaluator.py), issue 21 points 2 and 3."""
import json
from types import SimpleNamespace

import numpy as np
import pytest

from optimizer.cases import CASE_MASS
from optimizer.evaluator import DesignEvaluator
from optimizer.observation import Observation
from optimizer.racing import race
from optimizer.selection import validation_evidence
from optimizer.settings import RunSettings, fresh_base_seed
from optimizer_fakes import SyntheticBackend
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.design_problem import SimulatorProblem, optimize_design
from tethernet_ros.montecarlo import sample_seed

FAST = {"n_restarts_gp": 0, "n_candidates": 2000}


def _obs(objective):
    return Observation(x=np.array([objective]), objective=objective, constraints={"p": 1.0},
                       constraint_variances={}, feasible=True)


def _sampler(fail_every):
    """Candidate -> its racing samples: sample i fails when i % fail_every[c] == 0 (never
    for None); records every call."""
    calls = []

    def sample(obs, n):
        every = fail_every[obs.objective]
        k = n if every is None else n - len(range(0, n, every))
        calls.append((obs.objective, n))
        return SimpleNamespace(successes=k, n_samples=n)
    return sample, calls


def test_race_drops_the_unreliable_and_clears_the_lightest_reliable():
    """A (10 % failures) is dropped after the first round (90/100: Wilson upper 0.945);
    B (no failure) clears 0.98 at 200/200 (Wilson lower 0.981) in round 2 and wins; C (1 %
    failures) is released then, undecided at 198/200."""
    a, b, c = _obs(1.0), _obs(2.0), _obs(3.0)
    sample, calls = _sampler({1.0: 10, 2.0: None, 3.0: 100})
    r = race([a, b, c], sample, 0.98, round_samples=100, budget=10_000)
    assert [e.status for e in r.entries] == ["dropped", "cleared", "released"]
    assert [e.decided_in_round for e in r.entries] == [1, 2, 0]
    assert r.winner.candidate is b and r.stopped_by == "cleared" and r.rounds == 2
    assert calls == [(1.0, 100), (2.0, 100), (3.0, 100), (2.0, 200), (3.0, 200)]
    assert r.episodes == 500 == sum(e.samples for e in r.entries)
    d = _obs(0.5)                                     # an unraced design ranked first
    assert r.order([d, a, b, c]) == [b, d, c]         # winner first, the dropped one out
    ev = r.evidence()
    assert [(o.info["successes"], o.info["samples"]) for o in ev] == [(90, 100), (200, 200),
                                                                      (198, 200)]
    assert all(not o.feasible for o in ev)
    json.dumps(r.to_dict(lambda o: int(o.objective)))


def test_race_stops_at_its_budget_and_when_all_are_dropped():
    a, b, c = _obs(1.0), _obs(2.0), _obs(3.0)
    sample, _ = _sampler({1.0: 10, 2.0: None, 3.0: 100})
    r = race([a, b, c], sample, 0.98, round_samples=100, budget=350)   # round 2 needs 200
    assert r.stopped_by == "budget" and r.winner is None and r.rounds == 1
    assert r.episodes == 300 and r.order([a, b, c]) == [b, c]
    sample, _ = _sampler({1.0: 10, 2.0: 5})
    r = race([a, b], sample, 0.98, round_samples=100, budget=10_000)
    assert r.stopped_by == "decided" and r.winner is None and r.order([a, b]) == []
    assert race([], sample, 0.98, 100, 1000).stopped_by == "no candidates"


def test_race_validates_a_cleared_candidate_before_a_lighter_undecided_one():
    """A (2 % failures: 98 % exactly) stays between the bounds until its cap of 400
    samples; B (no failure) clears at 200: B wins and goes before A, which is still
    validated after it."""
    a, b = _obs(1.0), _obs(2.0)
    sample, calls = _sampler({1.0: 50, 2.0: None})
    r = race([a, b], sample, 0.98, round_samples=100, budget=10_000, max_samples=400)
    assert [e.status for e in r.entries] == ["undecided", "cleared"]
    assert [e.samples for e in r.entries] == [400, 200]
    assert r.stopped_by == "decided" and r.winner.candidate is b
    assert r.order([a, b]) == [b, a]
    assert max(n for _, n in calls) == 400


def test_fresh_samples_give_every_evaluation_its_own_seeds():
    be = SyntheticBackend()
    ev = DesignEvaluator(CASE_MASS, SimulatorProblem(be), samples=5, base_seed=1, fresh=True,
                         first_evaluation=7)
    x = REFERENCE_DESIGNS["mass-min"].to_vector()
    ev(x)
    ev(x)
    seeds = [t.seed for t in be.tasks]
    assert seeds == ([sample_seed(fresh_base_seed(1, 7), i) for i in range(5)]
                     + [sample_seed(fresh_base_seed(1, 8), i) for i in range(5)])
    assert fresh_base_seed(0, 1) > 999_999          # above every seed a setting may take
    assert ev.next_evaluation == 9


def test_run_races_before_validating_and_counts_the_racing_samples(tmp_path):
    """A new synthetic run (the defaults: racing, Wilson rule, shared luck; here with
    fresh samples): the race's samples are recorded (racing.jsonl) and counted in the
    episodes, no dropped design is validated, the results say how the race went, and
    resuming the finished run draws nothing again."""
    kw = dict(iterations=10, seed_points=8, samples=10, validation_samples=200,
              validation_candidates=4, racing_round=50, optimizer_options=FAST,
              fresh_samples=True)
    be = SyntheticBackend()
    s = optimize_design("mass", backend=be, run_dir=tmp_path / "r", **kw)
    r = s["racing"]
    assert s["fresh_samples"] is True and s["validation_rule"] == "wilson"
    assert r is not None and r["entries"] and r["episodes"] == s["episodes_racing"] > 0
    assert s["episodes_total"] == len(be.tasks) == (s["episodes"] + s["episodes_racing"]
                                                    + s["episodes_validation"])
    racing_lines = (tmp_path / "r" / "racing.jsonl").read_text().splitlines()
    assert sum(1 for line in racing_lines if '"success"' in line) == r["episodes"]
    dropped = {e["evaluation"] for e in r["entries"] if e["status"] == "dropped"}
    assert not dropped & {row["evaluation"] for row in s["table"]}
    rows = s["table"]
    first_validated = rows[1] if len(rows) > 1 and s["validation"]["meets_requirement"] else rows[0]
    if r["winner"] is not None:                       # the winner is validated first
        assert first_validated["evaluation"] == r["winner"]
    assert "raced on fresh samples" in s["selection_rule"]
    md = (tmp_path / "r" / "results.md").read_text()
    assert "Racing on fresh samples before validation" in md
    assert f"= {s['episodes_total']}." in md
    # distinct designs drew distinct samples (fresh), none from the common base seed
    opt_seeds = {t.seed // 1_000_003 for t in be.tasks[:s["episodes"]]}
    assert len(opt_seeds) == s["evaluations"] and 1 not in opt_seeds
    again_be = SyntheticBackend()
    again = optimize_design("mass", backend=again_be, run_dir=tmp_path / "r", resume=True, **kw)
    assert again_be.tasks == [] and again["racing"] == r
    assert again["best_evaluation"] == s["best_evaluation"]
    with pytest.raises(Exception, match="fresh_samples"):
        optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "r",
                        resume=True, **{**kw, "fresh_samples": False})


def test_racing_max_samples_caps_each_candidate(tmp_path):
    """``racing_max_samples``: no candidate is raced past it (one that reaches it
    undecided is left so), the run records it, and 0 (the default) means the
    validation's size."""
    kw = dict(iterations=4, seed_points=6, samples=10, validation_samples=300,
              validation_candidates=2, racing_round=40, optimizer_options=FAST,
              fresh_samples=True, racing_candidates=3)
    s = optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "r",
                        racing_max_samples=80, **kw)
    entries = s["racing"]["entries"]
    assert entries and all(e["samples"] <= 80 for e in entries)
    assert all(e["status"] != "racing" for e in entries)
    run = json.loads((tmp_path / "r" / "run.json").read_text())
    assert run["racing_max_samples"] == 80
    assert RunSettings().racing_max_samples == 0

    class Obs:
        x = None

    calls = []

    def sample(obs, n):                     # always 97.5 %: never decided at 0.98
        calls.append(n)
        return type("E", (), {"successes": int(0.975 * n), "n_samples": n})()
    r = race([Obs()], sample, 0.98, 100, 10_000, max_samples=300)
    assert r.entries[0].status == "undecided" and r.entries[0].samples == 300
    assert calls == [100, 200, 300]


def test_shared_luck_keeps_near_copies_from_making_the_model_sure():
    """Ten near-copies observed at 98/100 on the same samples: taken as independent, the
    constraint GP becomes sure of P_s there (posterior sd far below the 0.014 that 100
    samples can tell); with the shared luck (variance 0.98 x 0.02 / 100) it stays about
    that unsure, and fresh samples (evidence, not sharing the luck) still inform it."""
    from optimizer.bayesopt import ConstrainedBayesOpt
    from optimizer.observation import binomial_observation

    def fitted(shared, evidence=()):
        opt = ConstrainedBayesOpt([(0.0, 1.0)], {"p": 0.98}, n_initial=1, seed=0,
                                  n_restarts_gp=0,
                                  shared_luck={"p": 0.98 * 0.02 / 100} if shared else None)
        for x in np.linspace(0.0, 0.3, 4):
            opt.tell([x], 1.0 + x, {"p": 0.9}, {"p": binomial_observation(90, 100)[1]})
        for x in 0.5 + 0.001 * np.arange(10):
            opt.tell([x], 1.0 + x, {"p": 0.98}, {"p": binomial_observation(98, 100)[1]})
        U, H, obj, cons = opt._fit_models(opt._active_indices(), objective=False,
                                          evidence=evidence)
        mu, sd = cons["p"].predict(np.array([[0.505]]))
        return opt, mu[0] * cons["p"].y_std + cons["p"].y_mean, sd[0] * cons["p"].y_std

    one = binomial_observation(98, 100)[1] ** 0.5      # one estimate's sd: 0.0149
    _, mu_ind, sd_ind = fitted(False)
    opt, mu_sh, sd_sh = fitted(True)
    # independent: ten estimates pool to about one / sqrt(10); shared: no surer than the
    # luck of the common samples, sqrt(0.98 x 0.02 / 100) = 0.014
    assert sd_ind < one / 2 and sd_sh > 0.9 * (0.98 * 0.02 / 100) ** 0.5
    assert abs(mu_ind - 0.98) < 0.005 and abs(mu_sh - 0.98) < 0.01
    lucky = validation_evidence(opt.history[-5], 960, 1000, "p")     # fresh: 96 %
    _, mu_ev, sd_ev = fitted(True, [lucky])
    assert mu_ev < mu_sh - 0.005 and sd_ev < sd_sh
    assert opt.state_dict()["settings"]["shared_luck"] == {"p": 0.98 * 0.02 / 100}
    assert "shared_luck" not in fitted(False)[0].state_dict()["settings"]



def test_race_clears_at_the_selection_level_when_given():
    """With ``clear_level`` a candidate must reach that lower Wilson end, not C_P: B (no
    failure) clears 0.98 at 200/200 (Wilson lower 0.981) but 0.9884 only at 400/400
    (0.9905; 300/300: 0.9874); A (2 % failures) clears neither and races on until the
    budget."""
    a, b = _obs(1.0), _obs(2.0)
    sample, _ = _sampler({1.0: 50, 2.0: None})
    plain = race([b], sample, 0.98, round_samples=100, budget=1000)
    assert plain.winner.samples == 200
    strict = race([a, b], sample, 0.98, round_samples=100, budget=1000, clear_level=0.9884)
    assert strict.winner.candidate is b and strict.winner.samples == 400
    assert strict.entries[0].status == "racing" and strict.stopped_by == "budget"


def test_selection_level_ranks_against_the_validation_s_pass_level(tmp_path):
    """``selection_level`` "validation": the final ranking keeps only designs with
    posterior probability >= 0.5 of P*_s >= the validation's pass level (above C_P), a
    subset of the ranking against C_P; the run records the setting and says the level in
    its rule; a resume may change it."""
    from optimizer.bayesopt import ConstrainedBayesOpt
    from optimizer.cases import P_SUCCESS
    from optimizer.checkpoint import load_checkpoint
    from optimizer.finish import selection_level
    from optimizer.selection import rank_candidates
    from optimizer.sequential import pass_level
    from optimizer.settings import RunSettings
    kw = dict(iterations=10, seed_points=8, samples=10, validation_samples=200,
              optimizer_options=FAST, fresh_samples=True, racing_candidates=0,
              validation_candidates=1)
    s = optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "r",
                        selection_level="validation", **kw)
    level = pass_level(200, 0.98, "wilson")
    assert 0.98 < level < 1.0
    assert s["selection_level"] == "validation" and f"{level:.4g}" in s["selection_rule"]
    settings = RunSettings(selection_level="validation", validation_samples=1000,
                           validation_rule="wilson")
    assert selection_level(CASE_MASS, settings) == pytest.approx(0.98834, abs=1e-4)
    assert selection_level(CASE_MASS, settings.replace(selection_level="requirement")) is None
    run = json.loads((tmp_path / "r" / "run.json").read_text())
    assert run["selection_level"] == "validation"
    again = optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "r",
                            resume=True, selection_level="requirement", **kw)
    assert "the rate a validation passes" not in again["selection_rule"]
    with pytest.raises(Exception, match="selection_level"):
        RunSettings(selection_level="strict")
    state = load_checkpoint(tmp_path / "r" / "checkpoint.json")["optimizer"]
    opt = ConstrainedBayesOpt.from_state_dict(state)
    low = {id(o) for o in opt.ranked_feasible(0.5)}
    assert low and [id(o) for o in rank_candidates(opt, 0.5)[0]] == [
        id(o) for o in opt.ranked_feasible(0.5)]
    sizes = []
    for high in (level, 0.995, 0.9999):
        kept = {id(o) for o in opt.ranked_feasible(0.5, levels={P_SUCCESS: high})}
        assert kept <= low
        sizes.append(len(kept))
    assert sizes == sorted(sizes, reverse=True) and sizes[-1] < len(low)
