"""`tethernet cost` / optimizer/cost.py: where a run's CPU goes (issue 33), on run
directories written by the project's own writers, whose sums are known exactly."""
from __future__ import annotations

import dataclasses
import json
import math
import shutil

import numpy as np
import pytest

from optimizer.checkpoint import save_checkpoint
from optimizer.cost import (EPISODE_PHASES, CostError, Draw, cost_tables, draw_episodes,
                            read_run)
from optimizer.jsonio import atomic_write_json
from optimizer.observation import Observation
from optimizer.settings import RUN_FORMAT, fresh_base_seed
from optimizer_fakes import SyntheticBackend
from tethernet_ros import cli
from tethernet_ros.design_problem import optimize_design
from tethernet_ros.montecarlo import SampleResult
from tethernet_ros.montecarlo.backends import Outcome
from tethernet_ros.montecarlo.results_file import ResultsFile
from tethernet_ros.montecarlo.seeds import SEED_STRIDE

FAST = {"n_restarts_gp": 0, "n_candidates": 2000}


def _rows(tables, key):
    return {r["name"]: r for r in tables[key]}


def _sums(tables, key):
    """{row: (CPU s rounded to 1e-9, episodes)}."""
    return {r["name"]: (round(r["cpu_h"] * 3600, 9), r["episodes"]) for r in tables[key]}


# -- a hand-built run directory --------------------------------------------------------

def _obs(phase, feasible, samples, key):
    return Observation(np.zeros(8), 1.0, {"p_success": 1.0 if feasible else 0.0},
                       {"p_success": 0.01}, feasible,
                       info={"samples": samples, "samples_planned": 4, "key": key},
                       acquisition={"phase": phase}).to_dict()


def _record(key, seed, cpu, T=25.0):
    return SampleResult(key=key, index=seed % SEED_STRIDE, seed=seed, success=True,
                        settled_cqi=1.0, locked_pairs=12, closing_time=T - 20.0,
                        completion_time=T, mass=7.0, failure_reason="", category="",
                        cpu_time=cpu)


def _hand_built(run_dir):
    """Four designs of N = 4 samples: A (seed point, infeasible at its 3rd sample), B (seed
    point, feasible), C (iteration, feasible, raced and validated), D (iteration,
    infeasible after all 4); a record of a design not in the history (in flight)."""
    atomic_write_json(run_dir / "run.json", {"format": RUN_FORMAT, "case": "mass", "samples": 4})
    save_checkpoint(run_dir / "checkpoint.json", {"optimizer": {"history": [
        _obs("initial", False, 3, "A"), _obs("initial", True, 4, "B"),
        _obs("ei", True, 4, "C"), _obs("ei", False, 4, "D")]}})
    opt = ResultsFile(run_dir / "samples.jsonl")
    for key, cpus in (("A", [1, 2, 3]), ("B", [1, 1, 1, 1]), ("C", [2, 2, 2, 2]),
                      ("D", [0.5] * 4), ("E", [8])):
        for i, c in enumerate(cpus):
            opt.append(_record(key, SEED_STRIDE + i, c))
    for i in range(3):
        ResultsFile(run_dir / "racing.jsonl").append(_record("C", 2 * SEED_STRIDE + i, 4))
    for i in range(5):
        ResultsFile(run_dir / "validation.jsonl").append(_record("C", i, 3))


def test_hand_built_run_sums_exactly(tmp_path):
    _hand_built(tmp_path)
    t = cost_tables(read_run(tmp_path))
    assert t["source"] == "records" and t["unit"] == "CPU-h"
    stages = _rows(t, "stages")
    assert _sums(t, "stages") == ({
        "seed points": (6 + 4, 7), "BO iterations": (8 + 2, 8), "racing": (12, 3),
        "validation": (15, 5), "not in the history": (8, 1)})
    assert _sums(t, "verdicts") == ({
        "infeasible, decided early": (6, 3), "infeasible at N": (2, 4), "feasible": (4, 4),
        "best: raced or validated": (8 + 12 + 15, 12), "not in the history": (8, 1)})
    assert t["cpu_h"] * 3600 == pytest.approx(55) and t["episodes"] == 24
    assert sum(r["share"] for r in t["stages"]) == pytest.approx(1.0)
    assert stages["racing"]["cpu_s_per_episode"] == pytest.approx(4.0)
    assert t["episode_phases"] is None


def test_episode_phase_estimate_from_measured_shares(tmp_path):
    """Records: each re-simulated episode's shares times the run's recorded CPU."""
    _hand_built(tmp_path)
    run = read_run(tmp_path)
    draws = draw_episodes(run, 4, seed=1)
    assert len(draws) == 4 and all(d.seed is not None for d in draws)
    measured = [{"wait": 0.0, "flight": 1.0, "wrapping": 0.5, "settle": 2.5, "sim_s": 25.0},
                {"wait": 0.0, "flight": 2.0, "wrapping": 1.0, "settle": 5.0, "sim_s": 25.0}] * 2
    t = cost_tables(run, draws, measured)
    ph = _rows(t, "episode_phases")
    assert [ph[p]["share"] for p in EPISODE_PHASES] == pytest.approx([0.0, 0.25, 0.125, 0.625])
    assert ph["settle"]["cpu_h"] * 3600 == pytest.approx(55 * 0.625)
    assert ph["settle"]["cpu_h_se"] == pytest.approx(0.0)
    assert "measured by re-simulating 4" in t["notes"][-1]


def test_history_estimate_uses_simulated_time():
    """A history: CPU = simulated time x the measured CPU per simulated second."""
    from optimizer.cost import RunCost, Unit

    units = [Unit("seed points", "feasible", 2, None, 2 * 100.0, 1, [0.0] * 8, base_seed=1),
             Unit("validation", "best: raced or validated", 10, None, 10 * 25.0, 1, [0.0] * 8,
                  base_seed=0)]
    run = RunCost(None, "history", units)
    draws = [Draw(0, [0.0] * 8, None, 1, 0), Draw(1, [0.0] * 8, None, 0, 3)]
    # 0.02 CPU-s per simulated second in each: 2 s over a 100-s episode, 0.5 s over 25 s
    measured = [{"wait": 0.0, "flight": 2.0, "wrapping": 0.0, "settle": 0.0, "sim_s": 100.0},
                {"wait": 0.0, "flight": 0.1, "wrapping": 0.1, "settle": 0.3, "sim_s": 25.0}]
    t = cost_tables(run, draws, measured)
    stages = _rows(t, "stages")
    assert stages["seed points"]["cpu_h"] * 3600 == pytest.approx(4.0)
    assert stages["validation"]["cpu_h"] * 3600 == pytest.approx(5.0)
    assert "0.0200" in t["basis"]
    no_measure = cost_tables(run)
    assert no_measure["unit"] == "simulated h"
    assert no_measure["cpu_h"] * 3600 == pytest.approx(450.0)


# -- a run of tethernet optimize on the synthetic backend ------------------------------

class TimedBackend(SyntheticBackend):
    """Records a CPU time that says which stage an episode is of: validation (base seed 0)
    1 s, racing (base seed 2) 2 s, seed points 0.5 s, iterations 0.25 s."""

    seed_points = 4

    def cpu(self, seed):
        base = seed // SEED_STRIDE
        if base in (0, 2):
            return float(base or 1)
        return 0.5 if base - fresh_base_seed(1, 0) <= self.seed_points else 0.25

    def map(self, tasks, max_in_flight=None):
        for o in super().map(tasks, max_in_flight):
            yield Outcome(o.task, dataclasses.replace(o.result, cpu_time=self.cpu(o.task.seed)))


@pytest.fixture(scope="module")
def synthetic_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("cost") / "run"
    be = TimedBackend()
    summary = optimize_design("mass", backend=be, run_dir=d, iterations=3, seed_points=4,
                              samples=10, validation_samples=20, validation_rule="estimate",
                              racing_candidates=2, racing_round=10, racing_budget=40,
                              optimizer_options=FAST)
    return d, be, summary


def test_a_synthetic_run_sums_to_its_backends_tasks(synthetic_run):
    d, be, summary = synthetic_run
    t = cost_tables(read_run(d))
    stages = _rows(t, "stages")
    want = {}
    for task in be.tasks:
        base = task.seed // SEED_STRIDE
        name = ("validation" if base == 0 else "racing" if base == 2 else "seed points"
                if base - fresh_base_seed(1, 0) <= 4 else "BO iterations")
        cpu, n = want.get(name, (0.0, 0))
        want[name] = (cpu + be.cpu(task.seed), n + 1)
    assert _sums(t, "stages") == {k: (round(c, 9), n) for k, (c, n) in want.items()}
    assert stages["racing"]["episodes"] == summary["episodes_racing"] > 0
    assert t["episodes"] == len(be.tasks)
    best = {e["evaluation"] for e in summary["racing"]["entries"]}
    best |= {r["evaluation"] for r in summary["table"] if r["validation"]}
    n_best_opt = sum(1 for task in be.tasks if task.seed // SEED_STRIDE not in (0, 2)
                     and task.seed // SEED_STRIDE - fresh_base_seed(1, 0) in best)
    assert _rows(t, "verdicts")["best: raced or validated"]["episodes"] == (
        n_best_opt + want["racing"][1] + want["validation"][1])


def test_the_history_of_a_run_counts_its_samples(synthetic_run, tmp_path):
    """docs/cases/ keeps a run as PREFIX-history.csv and PREFIX-results.md."""
    d, _be, summary = synthetic_run
    shutil.copy(d / "history.csv", tmp_path / "caseX-history.csv")
    shutil.copy(d / "results.md", tmp_path / "caseX-results.md")
    t = cost_tables(read_run(tmp_path / "caseX-history.csv"))
    stages = _rows(t, "stages")
    assert t["source"] == "history"
    assert stages["seed points"]["episodes"] + stages["BO iterations"]["episodes"] == \
        summary["episodes"]
    assert stages["racing"]["episodes"] == summary["episodes_racing"]
    assert stages["validation"]["episodes"] == summary["episodes_validation"]
    rows = [ln.split(",") for ln in (d / "history.csv").read_text().splitlines()]
    head = rows[0]
    sim = sum(int(r[head.index("samples")]) * float(r[head.index("mean_completion_time")])
              for r in rows[1:])
    assert (stages["seed points"]["cpu_h"] + stages["BO iterations"]["cpu_h"]) * 3600 == \
        pytest.approx(sim)


def test_the_command_resimulates_episodes_for_the_phase_split(synthetic_run, capsys):
    d, _be, _summary = synthetic_run
    assert cli.main(["cost", str(d), "--phases", "1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    phases = {r["name"]: r for r in out["episode_phases"]}
    assert set(phases) == set(EPISODE_PHASES)
    assert sum(r["share"] for r in phases.values()) == pytest.approx(1.0)
    assert math.isclose(sum(r["cpu_h"] for r in phases.values()), out["cpu_h"], rel_tol=1e-9)
    assert cli.main(["cost", str(d), "--phases", "0"]) == 0
    text = capsys.readouterr().out
    assert "optimiser stage" in text and "episode phase: not measured" in text


# -- bad run directories ---------------------------------------------------------------

def _error(capsys, argv):
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err


def test_missing_or_garbled_run_directories_name_the_path(tmp_path, capsys):
    assert str(tmp_path / "none") in _error(capsys, ["cost", str(tmp_path / "none")])
    empty = tmp_path / "empty"
    empty.mkdir()
    assert f"{empty}: not a run directory" in _error(capsys, ["cost", str(empty)])

    run = tmp_path / "run"
    run.mkdir()
    _hand_built(run)
    (run / "checkpoint.json").write_text("{ truncated")
    assert str(run / "checkpoint.json") in _error(capsys, ["cost", str(run), "--phases", "0"])
    _hand_built(run)
    (run / "run.json").write_text("not json")
    assert str(run / "run.json") in _error(capsys, ["cost", str(run), "--phases", "0"])
    _hand_built(run)
    with (run / "racing.jsonl").open("a") as fh:
        fh.write('{"key": "C", "seed": 7, "cpu_time": "slow"}\n')
    err = _error(capsys, ["cost", str(run), "--phases", "0"])
    assert str(run / "racing.jsonl") in err and "'cpu_time'" in err

    (tmp_path / "x-history.csv").write_text("evaluation,phase\n1\n")
    assert str(tmp_path / "x-history.csv") in _error(capsys, ["cost", str(tmp_path / "x-history.csv")])
    with pytest.raises(CostError, match="--phases|history"):
        read_run(tmp_path / "x-history.csv")
    assert "--phases -1" in _error(capsys, ["cost", str(run), "--phases", "-1"])
