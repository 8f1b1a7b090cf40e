"""Case 1 / Case 2 on the Monte Carlo evaluator (optimizer.cases, optimizer.evaluator,
optimizer.run through tethernet_ros.design_problem) and `tethernet optimize`.

Fast checks run on a synthetic episode backend (tests/optimizer_fakes.py: the
EpisodeBackend interface with a smooth success probability, no physics).  The end-to-end
checks simulate for real, in-process, on a short scenario (settle time 2 s, horizon 15 s)
whose success rule is relaxed (any settled CQI, any n_L) so that a 5-design run finds a
feasible design: 3 seed points + 2 iterations x 3 samples, 3 validation samples.  The
module takes about a minute here (2 cores).
"""
import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from optimizer import binomial_observation
from optimizer.bayesopt import ConstrainedBayesOpt
from optimizer.cases import CASE_MASS, CASE_TIME, get_case
from optimizer.evaluator import DesignEvaluator
from optimizer.run import RunError
from optimizer.selection import rank_candidates, select_best, validation_evidence
from optimizer_fakes import SyntheticBackend
from tethernet_ros import cli
from tethernet_ros.commands.optimize import next_step_hint
from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import (DESIGN_BOUNDS, REFERENCE_DESIGNS, VARIABLE_NAMES, Design,
                                       system_mass)
from tethernet_ros.design_problem import SimulatorProblem, optimize_design
from tethernet_ros.montecarlo import EpisodeBackend, InProcessBackend, sample_seed
from results_lines import sample_lines
from script_modules import load_script

ROOT = Path(__file__).resolve().parent.parent
FAST = {"n_restarts_gp": 0, "n_candidates": 2000}
SHORT = {"settle_time": 2.0, "horizon": 15.0, "success_cqi": 1.0e6, "success_locked_pairs": 0}
#: the procedure before racing and the shared-luck model (issue 21), for tests of what
#: it does
OLD = dict(racing_candidates=0, fresh_samples=False, shared_luck=False)
TINY = dict(seed_points=3, iterations=2, samples=3, validation_samples=3,
            validation_rule="estimate", **OLD)


# ----------------------------------------------------------------- case definitions
def test_case_definitions():
    assert get_case("mass") is CASE_MASS and get_case("1") is CASE_MASS
    assert get_case("time") is CASE_TIME and get_case("2") is CASE_TIME
    with pytest.raises(ValueError, match="allowed cases"):
        get_case("speed")
    problem = SimulatorProblem(SyntheticBackend())
    assert problem.bounds == [DESIGN_BOUNDS[n] for n in VARIABLE_NAMES]
    assert len(problem.bounds) == 8
    for case in (CASE_MASS, CASE_TIME):
        assert case.constraints == {"p_success": 0.98}
    assert CASE_MASS.cheap_constraint(problem.mass) is None
    ok = CASE_TIME.cheap_constraint(problem.mass)
    tm = REFERENCE_DESIGNS["time-min"]
    assert tm.mass() < 15.0 and ok(tm.to_vector())
    heavy = Design(m_c=3.9, L_n=20.0, r_n=0.002, d_L=20.0, V_e=(2, 2, 5), d_c=0.0)
    assert heavy.mass() > 15.0 and not ok(heavy.to_vector())
    # the limit is exactly m_a <= 15 kg with the configured density
    x = np.array([3.0, 20.0, 0.001, 20, 2, 2, 5, 0])
    rho = (15.0 - 12.0) / (38 * 20.0 * math.pi * 0.001**2)

    def mass_at(density):
        return SimulatorProblem(SyntheticBackend(), SimConfig(density=density)).mass

    assert CASE_TIME.cheap_constraint(mass_at(rho))(x)
    assert not CASE_TIME.cheap_constraint(mass_at(rho * 1.001))(x)


def test_optimizer_package_does_not_import_the_simulator():
    code = ("import pkgutil, importlib, sys, optimizer\n"
            "for m in pkgutil.iter_modules(optimizer.__path__):\n"
            "    importlib.import_module('optimizer.' + m.name)\n"
            "print(sorted(m for m in sys.modules if m.startswith('tethernet_ros')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == "[]"


def test_evaluator_observation_common_random_numbers():
    be = SyntheticBackend()
    cfg = SimConfig(**SHORT)
    ev = DesignEvaluator(CASE_MASS, SimulatorProblem(be, cfg), samples=20, base_seed=4)
    x1 = REFERENCE_DESIGNS["mass-min"].to_vector()
    x2 = REFERENCE_DESIGNS["suboptimal"].to_vector()
    obj, cons, var, info = ev(x1)
    assert obj == system_mass(*x1[:3], cfg.density)              # exact objective
    k = info["successes"]
    assert cons == {"p_success": k / 20}
    assert var == {"p_success": binomial_observation(k, 20)[1]}
    ev(x2)
    seeds = [t.seed for t in be.tasks]
    assert seeds[:20] == seeds[20:] == [sample_seed(4, i) for i in range(20)]  # CRN
    assert ev.calls == 2 and len(be.tasks) == 40
    # Case 2: objective is the mean completion time over the samples
    ev2 = DesignEvaluator(CASE_TIME, SimulatorProblem(SyntheticBackend(), cfg), samples=5,
                          base_seed=0)
    obj2, _, _, info2 = ev2(REFERENCE_DESIGNS["time-min"].to_vector())
    assert obj2 == pytest.approx(info2["mean_completion_time"])


def test_mass_constraint_is_never_simulated(tmp_path):
    be = SyntheticBackend()
    ev = DesignEvaluator(CASE_TIME, SimulatorProblem(be), samples=4, base_seed=0)
    heavy = np.array([4.0, 22.0, 0.01, 20, 2, 2, 5, 0])
    with pytest.raises(ValueError, match="must not be simulated"):
        ev(heavy)
    assert be.tasks == []
    s = optimize_design("time", iterations=6, seed_points=10, samples=4, backend=be,
                        run_dir=tmp_path / "run", validation_samples=0, optimizer_options=FAST)
    assert s["evaluations"] == 16 and s["sampling"] == "sequential"
    assert len(be.tasks) == s["episodes"] <= 16 * 4   # one simulation per sample, nothing else
    masses = {t.key: t.design.mass(t.config.density) for t in be.tasks}
    assert len(masses) == 16 and max(masses.values()) <= 15.0


def test_select_best_needs_pooled_evidence():
    """A lucky 'feasible' observation among infeasible neighbours loses to a consistently
    feasible design with a worse objective; with no filter it would win."""
    opt = ConstrainedBayesOpt([(0.0, 1.0)], {"p_success": 0.98}, n_initial=1, seed=0,
                              n_restarts_gp=0)
    for x in np.linspace(0.0, 0.5, 11):               # infeasible region, one lucky point
        p = 1.0 if x == 0.25 else 0.9
        opt.tell([x], 1.0 + x, {"p_success": p}, {"p_success": binomial_observation(round(p * 100), 100)[1]})
    for x in np.linspace(0.7, 1.0, 7):                 # feasible region
        opt.tell([x], 2.0 + x, {"p_success": 1.0}, {"p_success": binomial_observation(100, 100)[1]})
    best, rule = select_best(opt, min_probability=None)
    assert best.x[0] == 0.25
    best, rule = select_best(opt, 0.5)
    assert best.x[0] == pytest.approx(0.7) and "posterior" in rule
    empty = ConstrainedBayesOpt([(0.0, 1.0)], {"p_success": 0.98}, n_initial=1)
    empty.tell([0.5], 1.0, {"p_success": 0.5})
    assert select_best(empty) == (None, "no evaluated design met the constraints")


def test_failed_validation_demotes_its_near_copies():
    """Two near-copies observed feasible (99 of 100) rank first; once the lighter fails a
    1000-sample validation (95 %), that evidence in the constraint GP drops the other below
    the filter, and the next design to validate comes from the consistently feasible region
    instead of the failed one's neighbour."""
    opt = ConstrainedBayesOpt([(0.0, 1.0)], {"p_success": 0.98}, n_initial=1, seed=0,
                              n_restarts_gp=0)
    for x in np.linspace(0.0, 0.2, 5):                  # infeasible region
        opt.tell([x], 1.0 + x, {"p_success": 0.9}, {"p_success": binomial_observation(90, 100)[1]})
    for x in (0.400, 0.401):                            # the near-copies
        opt.tell([x], 1.0 + x, {"p_success": 0.99}, {"p_success": binomial_observation(99, 100)[1]})
    for x in np.linspace(0.7, 1.0, 7):                  # feasible region
        opt.tell([x], 2.0 + x, {"p_success": 1.0}, {"p_success": binomial_observation(100, 100)[1]})
    ranked, _ = rank_candidates(opt, 0.5)
    assert [round(o.x[0], 3) for o in ranked[:3]] == [0.4, 0.401, 0.7]
    failed = validation_evidence(ranked[0], 950, 1000, "p_success")
    assert failed.constraints["p_success"] == 0.95 and not failed.feasible
    again, rule = rank_candidates(opt, 0.5, [failed])
    assert again[0].x[0] == pytest.approx(0.7) and "posterior" in rule
    assert all(o.x[0] >= 0.7 for o in again)            # the near-copies are filtered out
    assert len(opt.history) == 14                       # evidence is not added to the history


def test_next_candidate_replays_the_runs_choice_from_its_checkpoint(tmp_path, capsys):
    """scripts/next_candidate.py (docs/cases/README.md, the tumbling Case 1 with the
    predictive launch) replays optimizer.finish.choose_design on a checkpoint with recorded
    counts: with nothing recorded the next design is the ranking's first (a near-copy);
    with that one's failed validation, the feasible region's, as rank_candidates gives it
    with the evidence; after a race, never a dropped design; records in another order than
    the replay's are an error that names both."""
    from optimizer.checkpoint import save_checkpoint

    opt = ConstrainedBayesOpt([(0.0, 1.0)], {"p_success": 0.98}, n_initial=1, seed=0,
                              n_restarts_gp=0)
    for x in np.linspace(0.0, 0.2, 5):                  # evaluations 1-5, infeasible
        opt.tell([x], 1.0 + x, {"p_success": 0.9}, {"p_success": binomial_observation(90, 100)[1]})
    for x in (0.400, 0.401):                            # evaluations 6 and 7, near-copies
        opt.tell([x], 1.0 + x, {"p_success": 0.99}, {"p_success": binomial_observation(99, 100)[1]})
    for x in np.linspace(0.7, 1.0, 7):                  # evaluations 8-14, feasible
        opt.tell([x], 2.0 + x, {"p_success": 1.0}, {"p_success": binomial_observation(100, 100)[1]})
    path = tmp_path / "checkpoint.json"
    save_checkpoint(path, {"optimizer": opt.state_dict()})
    script = load_script("next_candidate")

    def next_evaluation(*args):
        assert script.main([str(path), *args]) == 0
        return json.loads(capsys.readouterr().out.splitlines()[-1])["evaluation"]

    assert next_evaluation() == 6
    assert next_evaluation("--failed", "6:950:1000") == 8
    after_race = next_evaluation("--race", "6:90:100:dropped,7:99:100:undecided")
    assert after_race != 6 and after_race in (7, 8)
    with pytest.raises(SystemExit, match=r"validates evaluations \[\] before 6; the records name \[7\]"):
        script.main([str(path), "--failed", "7:950:1000"])
    with pytest.raises(SystemExit, match=r"races evaluations \[6\]; the records name \[8\]"):
        script.main([str(path), "--race", "8:90:100:dropped"])


# ----------------------------------------------------------------- runs, resume
def _history(run_dir):
    return (Path(run_dir) / "history.csv").read_text().splitlines()


def _strip_wall(lines):
    return [",".join(line.split(",")[:-1]) for line in lines]  # last column: wall time


def test_a_non_default_scenario_is_stated_in_the_results(tmp_path):
    """A run for a tumbling target says so in its summary and results.md; the default
    scenario adds nothing."""
    from tethernet_ros.core.policies import PolicyConfig
    from tethernet_ros.core.tumble import TumbleConfig

    assert SimulatorProblem(SyntheticBackend()).scenario() == ""
    cfg = SimConfig().replace(tumble=TumbleConfig(rate_deg_s=2.0, axis="transverse"),
                              policy=PolicyConfig(kind="adaptive"))
    kw = dict(iterations=1, seed_points=3, samples=10, validation_samples=0,
              optimizer_options=FAST)
    got = optimize_design("mass", backend=SyntheticBackend(), config=cfg, run_dir=tmp_path, **kw)
    words = "tumble: rate_deg_s 2, axis transverse; policy: kind adaptive"
    assert got["scenario"] == words
    assert f"Scenario: {words}." in (tmp_path / "results.md").read_text()


def test_a_run_resumes_from_its_settings_and_checkpoint_alone(tmp_path):
    """run.json and checkpoint.json are a run's whole state: a killed run's directory
    carried to another machine or session without its samples files (results files stay
    out of git) resumes to the uninterrupted result, drawing again only the samples of
    the design in flight, the racing and the validation."""
    kw = dict(iterations=6, seed_points=6, samples=10, validation_samples=20,
              optimizer_options=FAST, validation_rule="estimate")
    full_be = SyntheticBackend()
    full = optimize_design("mass", backend=full_be, run_dir=tmp_path / "full", **kw)
    per_design = np.cumsum([int(line.split(",")[13])
                            for line in _history(tmp_path / "full")[1:]])
    kill_after = (per_design[5] + per_design[-1]) // 2          # mid model-based phase
    d = tmp_path / "killed"
    with pytest.raises(KeyboardInterrupt):
        optimize_design("mass", backend=SyntheticBackend(fail_after=kill_after), run_dir=d, **kw)
    carried = tmp_path / "carried"
    carried.mkdir()
    for name in ("run.json", "checkpoint.json"):
        shutil.copy(d / name, carried / name)
    be = SyntheticBackend()
    resumed = optimize_design("mass", backend=be, run_dir=carried, resume=True, **kw)
    assert _strip_wall(_history(carried)) == _strip_wall(_history(tmp_path / "full"))
    for key in ("best_design", "best_objective", "p_success", "evaluations", "validation",
                "selection_rule", "episodes"):
        assert resumed[key] == full[key], key
    finished = int(per_design[per_design <= kill_after][-1])     # designs done before the kill
    assert len(be.tasks) == len(full_be.tasks) - finished


@pytest.mark.parametrize("sequential", [True, False])
def test_synthetic_run_kill_and_resume_matches_uninterrupted(tmp_path, sequential):
    kw = dict(iterations=6, seed_points=6, samples=10, validation_samples=20,
              optimizer_options=FAST, sequential=sequential, validation_rule="estimate")
    full_be = SyntheticBackend()
    full = optimize_design("mass", backend=full_be, run_dir=tmp_path / "full", **kw)
    assert full["best_design"] is not None and full["validation"]["samples"] == 20
    per_design = np.cumsum([int(line.split(",")[13])
                            for line in _history(tmp_path / "full")[1:]])
    assert full["racing"]["episodes"] > 0                                # the new defaults
    assert full["episodes_total"] == len(full_be.tasks) == (
        full["episodes"] + full["episodes_racing"] + full["episodes_validation"])
    assert per_design[-1] == full["episodes"]
    mid_model_phase = (per_design[5] + per_design[-1]) // 2
    assert 25 < per_design[5] < mid_model_phase < per_design[-1]
    for kill_after in (25, mid_model_phase):     # mid seed phase, mid model-based phase
        d = tmp_path / f"killed{kill_after}"
        with pytest.raises(KeyboardInterrupt):
            optimize_design("mass", backend=SyntheticBackend(fail_after=kill_after), run_dir=d,
                            **kw)
        with pytest.raises(RunError, match="already holds a run"):
            optimize_design("mass", backend=SyntheticBackend(), run_dir=d, **kw)
        with pytest.raises(RunError, match="'samples'"):
            optimize_design("mass", backend=SyntheticBackend(), run_dir=d, resume=True,
                            **{**kw, "samples": 11})
        with pytest.raises(RunError, match="'sequential'"):
            optimize_design("mass", backend=SyntheticBackend(), run_dir=d, resume=True,
                            **{**kw, "sequential": not sequential})
        be = SyntheticBackend()
        resumed = optimize_design("mass", backend=be, run_dir=d, resume=True, **kw)
        with pytest.raises(RunError, match="holds no run"):
            optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "typo",
                            resume=True, **kw)
        # nothing simulated twice: the in-flight design's finished samples were reused
        assert kill_after + len(be.tasks) == len(full_be.tasks)
        assert _strip_wall(_history(d)) == _strip_wall(_history(tmp_path / "full"))
        for key in ("best_design", "best_objective", "p_success", "evaluations", "validation",
                    "selection_rule"):
            assert resumed[key] == full[key], key
    # resuming a finished run re-does nothing (and may extend the budget)
    be = SyntheticBackend()
    again = optimize_design("mass", backend=be, run_dir=tmp_path / "full", resume=True, **kw)
    assert be.tasks == [] and again["best_design"] == full["best_design"]
    more = optimize_design("mass", backend=be, run_dir=tmp_path / "full", resume=True,
                           **{**kw, "iterations": 8})
    # 2 designs x 10 samples (+ validation and racing if the ranking moved)
    assert more["evaluations"] == 14 and 0 < len(be.tasks) <= 40 + more["episodes_racing"]


def test_candidates_validated_in_turn_until_one_meets_the_requirement(tmp_path):
    """With 3 samples per design the lightest designs observed feasible are truly
    unreliable: the first ranked fails a 200-sample validation, and with K = 6 the run
    validates the next ones in order of m_a until one meets C_P (here the fifth).
    Resuming the K = 1 run with K = 6 reuses its validation and gives the same result."""
    kw = dict(iterations=12, seed_points=8, samples=3, validation_samples=200,
              optimizer_options=FAST, validation_stop=False, validation_rule="estimate", **OLD)
    one = optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "one",
                          validation_candidates=1, **kw)
    assert one["validation"]["p_success"] < 0.98 and len(one["table"]) == 1
    assert one["validation"]["meets_requirement"] is False and one["p_threshold"] == 0.98
    assert "does NOT meet the requirement C_P = 0.98" in (tmp_path / "one" / "results.md").read_text()
    assert next_step_hint(one) == ("no validated design met C_P = 0.98 (up to 1 validated); to "
                                   "validate further ranked designs: --resume "
                                   "--validation-candidates 6")
    be = SyntheticBackend()
    six = optimize_design("mass", backend=be, run_dir=tmp_path / "six", validation_candidates=6,
                          **kw)
    rows = six["table"]
    assert 2 <= len(rows) <= 6 and rows[0]["design"] == "best (Case 1)"
    failed, chosen = rows[1:], rows[0]
    assert all(r["validation"]["p_success"] < 0.98 for r in failed)
    assert chosen["validation"]["p_success"] >= 0.98 or len(rows) == 6
    assert chosen["validation"]["meets_requirement"] == (chosen["validation"]["p_success"] >= 0.98)
    assert not any(r["validation"]["meets_requirement"] for r in failed)
    assert next_step_hint(six) is None or len(rows) == 6
    assert next_step_hint({"best_design": None}).startswith("no evaluated design met")
    # validated in order of the objective: every failed candidate is lighter than the chosen
    assert [r["mass"] for r in failed] == sorted(r["mass"] for r in failed)
    assert all(r["mass"] <= chosen["mass"] for r in failed)
    assert failed[0]["evaluation"] == one["best_evaluation"]
    assert six["best_evaluation"] == chosen["evaluation"] != one["best_evaluation"]
    assert "validated in turn" in six["selection_rule"]
    assert len(be.tasks) == six["episodes"] + 200 * len(rows)
    md = (tmp_path / "six" / "results.md").read_text()
    assert md.count("failed validation") == 2 * len(failed)   # results and variables tables
    be = SyntheticBackend()
    resumed = optimize_design("mass", backend=be, run_dir=tmp_path / "one", resume=True,
                              validation_candidates=6, **kw)
    assert resumed["best_evaluation"] == six["best_evaluation"]
    assert resumed["validation"]["p_success"] == six["validation"]["p_success"]
    assert len(be.tasks) == 200 * (len(rows) - 1)     # the first candidate's validation reused
    with pytest.raises(RunError, match="validation_candidates"):
        optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "bad",
                        validation_candidates=0, **kw)


def test_validation_rule_wilson_demands_the_interval_above_the_requirement(tmp_path):
    """With the Wilson rule a validation meets C_P only if the lower end of its Wilson
    95 % interval does: at 200 samples that takes 200/200 (199/200 gives 0.972).  Resuming
    a run chosen by the estimate rule with the Wilson rule reuses every validation done,
    rejects a chosen design whose interval reaches below C_P and validates further ones."""
    kw = dict(iterations=12, seed_points=8, samples=3, validation_samples=200,
              optimizer_options=FAST, validation_candidates=6, validation_stop=False,
              validation_rule="estimate", **OLD)
    est = optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "r", **kw)
    assert est["validation_rule"] == "estimate"
    be = SyntheticBackend()
    wil = optimize_design("mass", backend=be, run_dir=tmp_path / "r", resume=True,
                          **{**kw, "validation_candidates": 12, "validation_rule": "wilson"})
    assert wil["validation_rule"] == "wilson" and "Wilson" in wil["selection_rule"]
    rows = wil["table"]
    for r in rows:
        v = r["validation"]
        assert v["meets_requirement"] == (v["wilson"][0] >= 0.98)
    assert not any(r["validation"]["meets_requirement"] for r in rows[1:])
    chosen = rows[0]["validation"]
    assert chosen["meets_requirement"] or len(rows) == 12
    # the estimate run's validations were reused; only the further candidates were drawn
    assert len(be.tasks) == 200 * (len(rows) - len(est["table"]))
    if est["validation"]["wilson"][0] < 0.98:
        assert wil["best_evaluation"] != est["best_evaluation"]
    text = (tmp_path / "r" / "results.md").read_text()
    assert "by the lower end of its Wilson 95 % interval" in text
    with pytest.raises(RunError, match="validation_rule"):
        optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "bad",
                        **{**kw, "validation_rule": "lower"})


def test_validation_stops_at_the_failure_that_decides_it(tmp_path):
    """With validation_stop (the default for a new run) a validation that misses C_P ends
    at its (F + 1)-th failure, F = 4 for 200 samples at 98 %: the first candidate gets the
    verdict of its full validation from the same samples' prefix, a design that meets C_P
    gets every sample, and the table says where a validation stopped.  A run recorded
    without it (older runs) keeps its full validations on resume."""
    kw = dict(iterations=12, seed_points=8, samples=3, validation_samples=200,
              optimizer_options=FAST, validation_candidates=6, validation_rule="estimate", **OLD)
    full = optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "full",
                           validation_stop=False, **kw)
    stop = optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "stop", **kw)
    assert stop["validation_stop"] is True and full["validation_stop"] is False
    # the first candidate (ranked before any validation, so the same in both runs) failed
    # its full validation; stopped, it fails at the 5th failure of the same samples
    assert len(full["table"]) > 1
    first_eval = full["table"][1]["evaluation"]
    rows = {r["evaluation"]: r for r in stop["table"]}
    first_stop = rows[first_eval]["validation"]
    records = {}
    for line in sample_lines(tmp_path / "full" / "validation.jsonl"):
        rec = json.loads(line)
        if rec["design"] == full_design(full, first_eval):
            records[rec["index"]] = rec["success"]
    successes = [records[i] for i in range(200)]
    failures_at = [i + 1 for i, ok in enumerate(successes) if not ok]
    assert len(failures_at) >= 5
    assert first_stop["stopped"] and not first_stop["meets_requirement"]
    assert first_stop["samples"] == failures_at[4]
    assert first_stop["successes"] == failures_at[4] - 5
    for r in stop["table"]:
        v = r["validation"]
        if v["meets_requirement"]:
            assert v["samples"] == 200 and not v["stopped"]
        else:
            assert v["stopped"] and v["samples"] - v["successes"] == 5 and v["samples"] < 200
    assert any(r["validation"]["stopped"] for r in stop["table"])
    assert "stopped at the failure that decided it" in (tmp_path / "stop" / "results.md").read_text()
    # resuming a run recorded without the stop (here: from before the setting existed)
    # keeps every validation whole
    settings_file = tmp_path / "full" / "run.json"
    saved = json.loads(settings_file.read_text())
    del saved["validation_stop"]
    settings_file.write_text(json.dumps(saved))
    be = SyntheticBackend()
    again = optimize_design("mass", backend=be, run_dir=tmp_path / "full", resume=True, **kw)
    assert again["validation_stop"] is False and be.tasks == []
    assert [r["validation"]["samples"] for r in again["table"]] == [200] * len(again["table"])


def test_wilson_rule_is_the_default_for_new_runs_only(tmp_path):
    """A new run validates by the Wilson rule unless told otherwise, and a failing
    validation then stops at the failure that decides it by that rule (at 200 samples and
    98 %: the first); a run recorded with the estimate rule, or from before the rule was
    recorded, keeps the estimate rule when resumed; too few validation samples for the
    Wilson rule are refused, naming the least that can meet it."""
    kw = dict(iterations=4, seed_points=6, samples=3, validation_samples=200,
              optimizer_options=FAST, validation_candidates=3)
    new = optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "new", **kw)
    assert new["validation_rule"] == "wilson"
    assert json.loads((tmp_path / "new" / "run.json").read_text())["validation_rule"] == "wilson"
    for r in new["table"]:
        v = r["validation"]
        assert v["meets_requirement"] == (v["wilson"][0] >= 0.98)
        if not v["meets_requirement"]:
            assert v["stopped"] and v["samples"] - v["successes"] == 1
    est = optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "est",
                          validation_rule="estimate", **kw)
    assert est["validation_rule"] == "estimate"
    again = optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "est",
                            resume=True, **kw)
    assert again["validation_rule"] == "estimate"
    assert again["best_evaluation"] == est["best_evaluation"]
    settings_file = tmp_path / "new" / "run.json"        # a run from before the setting
    saved = json.loads(settings_file.read_text())
    del saved["validation_rule"]
    settings_file.write_text(json.dumps(saved))
    old = optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "new",
                          resume=True, **kw)
    assert old["validation_rule"] == "estimate"
    with pytest.raises(RunError, match="validation_samples: got 188; must be 0 or at least 189"):
        optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "few",
                        **{**kw, "validation_samples": 188})
    assert optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "few",
                           **{**kw, "validation_samples": 189})["validation_rule"] == "wilson"


def test_help_names_the_default_validation_rule(capsys):
    with pytest.raises(SystemExit):
        cli.main(["optimize", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "Default: wilson for a new run; on --resume, as the run recorded it" in text


def full_design(summary, evaluation):
    """The design dict of ``evaluation`` in a run's table."""
    return next(r["x"] for r in summary["table"] if r["evaluation"] == evaluation)


class KillAfter(EpisodeBackend):
    """Wraps a backend; raises KeyboardInterrupt (a kill) once ``n`` tasks have run."""

    def __init__(self, inner, n):
        self.inner, self.n, self.count = inner, n, 0

    def map(self, tasks, max_in_flight=None):
        for out in self.inner.map(tasks, max_in_flight):
            if self.count >= self.n:
                raise KeyboardInterrupt("simulated kill")
            self.count += 1
            yield out


@pytest.fixture(scope="module")
def short_yaml(tmp_path_factory):
    p = tmp_path_factory.mktemp("cfg") / "short.yaml"
    p.write_text("".join(f"{k}: {v}\n" for k, v in SHORT.items()))
    return p


@pytest.fixture(scope="module")
def cli_run(tmp_path_factory, short_yaml):
    """`tethernet optimize --json` on a tiny real run (in-process simulation)."""
    run_dir = tmp_path_factory.mktemp("opt") / "cli"
    out = subprocess.run(
        [sys.executable, "-m", "tethernet_ros.cli", "optimize", "--case", "mass",
         "--seed-points", "3", "--iterations", "2", "--samples", "3", "--validation-samples", "3",
         "--validation-rule", "estimate", "--racing-candidates", "0", "--no-fresh-samples", "--no-shared-luck",
         "--workers", "0", "--config", str(short_yaml), "--run-dir", str(run_dir),
         "--gp-restarts", "0", "--candidates", "2000", "--json"],
        capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    return run_dir, json.loads(out.stdout), out.stderr


def test_cli_optimize_json_tiny_real_run(cli_run):
    run_dir, d, stderr = cli_run
    for key in ("best_design", "best_objective", "p_success", "mass", "mean_completion_time",
                "evaluations"):
        assert key in d, key
    assert d["evaluations"] == 5 and d["case"] == "mass" and d["status"] == "complete"
    assert d["best_design"] is not None, "relaxed success rule: some design must be feasible"
    best = Design.from_dict(d["best_design"])
    assert best.within_bounds()
    assert d["best_objective"] == d["mass"] == best.mass()
    assert d["p_success"] >= 0.98
    v = d["validation"]
    assert v["samples"] == 3 and v["base_seed"] == 0
    assert v["wilson"][0] <= v["p_success"] <= v["wilson"][1]
    assert "designs" in stderr and "ETA" in stderr            # tqdm progress on stderr
    for name in ("results.csv", "results.md", "convergence.png", "checkpoint.json",
                 "samples.jsonl", "validation.jsonl", "history.csv", "run.json", "summary.json"):
        assert (run_dir / name).is_file(), name
    assert (run_dir / "convergence.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    md = (run_dir / "results.md").read_text()
    assert "validated P*_s (N=3)" in md and "best (Case 1)" in md and "m_a (kg)" in md
    # the source's Table 4 row of the case's reference design stands beside the result
    assert d["published"] == {"design": "mass-min", "mass": 7.53, "mean_completion_time": 27.4,
                              "p_success_optimisation": 0.98, "p_success_validated": 0.983}
    assert "| source's mass-min (Table 4) | 7.53 | 27.4 | 0.98 | 0.983 |" in md
    rows = (run_dir / "results.csv").read_text().splitlines()
    assert rows[0].startswith("case,design,evaluation,m_c") and len(rows) == 2
    # sequential sampling (the default): a sample record for every sample the observations
    # rest on, and for those drawn past a decision within a batch (the backend's lanes)
    assert d["sampling"] == "sequential" and d["episodes_full"] == 15
    samples_column = [int(line.split(",")[13]) for line in _history(run_dir)[1:]]
    assert sum(samples_column) == d["episodes"] <= 15
    assert d["episodes"] <= len(sample_lines(run_dir / "samples.jsonl")) <= 15


def test_cli_status_reads_the_run_directory(cli_run):
    run_dir, d, _ = cli_run
    out = subprocess.run([sys.executable, "-m", "tethernet_ros.cli", "optimize", "--status",
                          "--run-dir", str(run_dir), "--json"],
                         capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    st = json.loads(out.stdout)
    assert st["evaluations"] == st["planned"] == d["evaluations"] == 5
    assert st["episodes"] == d["episodes"] and st["episodes_full"] == d["episodes_full"]
    assert st["best"]["evaluation"] == d["best_evaluation"]
    assert st["best"]["objective"] == d["best_objective"]
    assert st["summary"]["best_evaluation"] == d["best_evaluation"]
    assert (run_dir / "progress.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = subprocess.run([sys.executable, "-m", "tethernet_ros.cli", "optimize", "--status",
                           "--run-dir", str(run_dir)],
                          capture_output=True, text=True, cwd=ROOT, timeout=120).stdout
    v = d["validation"]
    assert (f"chosen after validation: evaluation {d['best_evaluation']}, objective "
            f"{d['best_objective']:.4g}, validated P*_s {v['successes']}/{v['samples']}") in text
    bad = subprocess.run([sys.executable, "-m", "tethernet_ros.cli", "optimize", "--status",
                          "--run-dir", str(run_dir / "nowhere")],
                         capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert bad.returncode == 2 and "run.json is missing" in bad.stderr


def test_real_run_killed_mid_design_resumes_to_the_same_result(cli_run, tmp_path):
    cli_dir, d, _ = cli_run
    cfg = SimConfig.from_dict(SHORT)
    kw = dict(TINY, config=cfg, optimizer_options=FAST)
    run_dir = tmp_path / "killed"
    with pytest.raises(KeyboardInterrupt):           # killed after 10 samples
        optimize_design("mass", backend=KillAfter(InProcessBackend(), 10), run_dir=run_dir, **kw)
    per_design = np.cumsum([int(line.split(",")[13]) for line in _history(cli_dir)[1:]])
    assert len(_history(run_dir)) == 1 + int(np.sum(per_design <= 10))
    be = KillAfter(InProcessBackend(), 10**9)
    s = optimize_design("mass", backend=be, run_dir=run_dir, resume=True, **kw)
    assert be.count == d["episodes"] - 10 + 3        # rest of the run + validation only
    assert _strip_wall(_history(run_dir)) == _strip_wall(_history(cli_dir))
    for key in ("best_design", "best_objective", "p_success", "mass", "validation"):
        assert s[key] == d[key], key


# ----------------------------------------------------------------- CLI errors
@pytest.mark.parametrize("argv, message", [
    (["--samples", "0"], "--samples 0: must be an integer >= 1"),
    (["--seed-points", "0"], "--seed-points 0: must be an integer >= 1"),
    (["--iterations", "-1"], "--iterations -1: must be an integer >= 0"),
    (["--via", "ros", "--scheduler", "local"], "cannot be combined with --scheduler"),
    (["--controller", "example_controller"], "--controller needs --via ros"),
    (["--via", "ros", "--node-param", "capture_node.horizon=5"], "capture_node.horizon"),
    (["--workers", "-3"], "--workers -3"),
    (["--validation-seed", "1"], "must differ from --sample-seed"),
    (["--keep-bags"], "--keep-bags only applies with --via ros"),
    (["--config", "/nonexistent/x.yaml"], "does not exist"),
    (["--noise-scale", "speed"], "expected SOURCE=FACTOR"),
    (["--validation-samples", "100"],
     "--validation-samples 100: must be 0 or at least 189 under --validation-rule 'wilson'"),
])
def test_cli_bad_arguments_one_line(argv, message, capsys, tmp_path):
    code = cli.main(["optimize", "--case", "time", "--run-dir", str(tmp_path / "r"), *argv])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and message in err, err
    assert not (tmp_path / "r").exists()


def test_cli_existing_run_and_changed_settings(cli_run, capsys, tmp_path, short_yaml):
    cli_dir, _, _ = cli_run
    run_dir = tmp_path / "copy"
    shutil.copytree(cli_dir, run_dir)
    base = ["optimize", "--case", "mass", "--run-dir", str(run_dir), "--workers", "0",
            "--config", str(short_yaml), "--seed-points", "3", "--iterations", "2",
            "--gp-restarts", "0", "--candidates", "2000", "--no-progress"]
    assert cli.main(base + ["--samples", "3"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "already holds a run" in err
    assert cli.main(base + ["--samples", "4", "--resume"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "setting 'samples'" in err
    # the finished run resumes without simulating and prints the table
    assert cli.main(base + ["--samples", "3", "--validation-samples", "3", "--resume"]) == 0
    out = capsys.readouterr().out
    assert "best (Case 1)" in out and "validated P*_s" in out
