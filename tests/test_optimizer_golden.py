"""Optimiser runs recorded before the optimiser was split by job (issue 11) and compared
bit for bit after it: the whole history (designs, objectives, P*_s and their variances,
feasibility, acquisition diagnostics, evaluation info), the optimiser's random state, the
chosen design, its validation and the results table.

Three runs with full sampling (every design gets all its samples; ``sequential=False``
since sequential sampling, issue 10, became the default): Case 1 and Case 2 on the
synthetic episode backend (tests/optimizer_fakes.py, no physics), and a tiny real Case 1
run in-process on the ``spec-text`` model with a 2 s settle time, a 15 s horizon and a
relaxed success rule.  Left out: wall times, and the run key (a hash of the source of
tethernet_ros/core, which changes with every edit of the core).

Regenerate only when the optimiser or the model is meant to change:
    python tests/test_optimizer_golden.py --write
"""
from __future__ import annotations

import json
import os
import sys
import tempfile
from pathlib import Path

import pytest

from golden import exact
from optimizer_fakes import SyntheticBackend
from tethernet_ros.core.config import SimConfig
from tethernet_ros.design_problem import optimize_design
from tethernet_ros.montecarlo import InProcessBackend

GOLDEN = os.path.join(os.path.dirname(__file__), "data", "golden_optimizer.json")
FAST = {"n_restarts_gp": 0, "n_candidates": 2000}
SHORT = {"settle_time": 2.0, "horizon": 15.0, "success_cqi": 1.0e6, "success_locked_pairs": 0}
SUMMARY_FIELDS = ("evaluations", "feasible_evaluations", "selection_rule", "best_design",
                  "best_vector", "best_evaluation", "best_objective", "p_success",
                  "p_success_ci", "successes", "mass", "mean_completion_time", "validation",
                  "table")
RUNS = {
    "synthetic-mass": dict(case="mass", iterations=6, seed_points=6, samples=10,
                           validation_samples=20),
    "synthetic-time": dict(case="time", iterations=4, seed_points=6, samples=10,
                           validation_samples=10),
    "real-mass": dict(case="mass", iterations=1, seed_points=3, samples=2, validation_samples=2),
}


def run_golden(name: str) -> dict:
    kw = dict(RUNS[name])
    if name.startswith("synthetic"):
        backend, config = SyntheticBackend(), SimConfig.preset("spec-text")
    else:
        backend, config = InProcessBackend(), SimConfig.preset("spec-text", **SHORT)
    with tempfile.TemporaryDirectory() as tmp:
        run_dir = Path(tmp) / "run"
        summary = optimize_design(backend=backend, run_dir=run_dir, config=config,
                                  optimizer_options=FAST, sequential=False, **kw)
        state = json.loads((run_dir / "checkpoint.json").read_text())["optimizer"]
        history_csv = [",".join(line.split(",")[:-1])  # last column: wall time
                       for line in (run_dir / "history.csv").read_text().splitlines()]
    for obs in state["history"]:
        obs["info"].pop("wall_time")
        obs["info"].pop("key")
    return exact({"summary": {k: summary[k] for k in SUMMARY_FIELDS},
                  "history": state["history"], "rng_state": state["rng_state"],
                  "initial_design": state["initial_design"], "history_csv": history_csv})


@pytest.mark.parametrize("name", list(RUNS))
def test_optimizer_run_bit_identical_to_golden(name):
    with open(GOLDEN) as f:
        want = json.load(f)[name]
    got = run_golden(name)
    assert got["summary"] == want["summary"]
    assert got["rng_state"] == want["rng_state"]
    assert got["initial_design"] == want["initial_design"]
    assert got["history_csv"] == want["history_csv"]
    assert len(got["history"]) == len(want["history"])
    for i, (o, w) in enumerate(zip(got["history"], want["history"]), 1):
        for k in ("x", "objective", "constraints", "constraint_variances", "feasible",
                  "acquisition"):
            assert o[k] == w[k], (name, i, k)
        # the recorded info is kept whole; keys added later may sit beside it
        assert {k: o["info"].get(k) for k in w["info"]} == w["info"], (name, i)


if __name__ == "__main__" and "--write" in sys.argv:
    data = {name: run_golden(name) for name in RUNS}
    with open(GOLDEN, "w") as f:
        json.dump(data, f, indent=1)
    print("wrote", GOLDEN)
