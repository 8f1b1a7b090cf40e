"""Monte Carlo results for a fixed set of runs, recorded before the montecarlo package was
split by job (issue 11) and compared bit for bit after it: every deterministic field of
every sample (CQI / n_L traces included) and of each run's summary.

The model is the ``spec-text`` preset (today's model, kept bit for bit whatever the
default becomes) with a 2 s settle time.  The run key is left out: it hashes the source of
tethernet_ros/core, which changes with every edit of the core.

Regenerate only when the model itself is meant to change:
    python tests/test_montecarlo_golden.py --write
"""
from __future__ import annotations

import json
import os
import sys

from golden import exact
from tethernet_ros import montecarlo as mc
from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.core.noise import NoiseModel
from tethernet_ros.machine import machine_facts

GOLDEN = os.path.join(os.path.dirname(__file__), "data", "golden_montecarlo.json")
SAMPLES, BASE_SEED = 4, 2
SAMPLE_FIELDS = ("index", "seed", "success", "settled_cqi", "locked_pairs", "closing_time",
                 "completion_time", "mass", "failure_reason", "category", "steps",
                 "max_penetration", "attempts", "trace")
RUN_FIELDS = ("label", "n_samples", "base_seed", "successes", "p_success", "ci_low", "ci_high",
              "cp_low", "cp_high", "mean_completion_time", "mean_completion_time_success",
              "mass", "failures_by_reason", "reused", "noise_scales")


def golden_specs() -> list:
    """Four runs that between them meet every failure category but worker errors."""
    cfg = SimConfig.preset("spec-text", settle_time=2.0)
    r = REFERENCE_DESIGNS
    return [mc.RunSpec(r["time-min"], NoiseModel(), cfg, "time-min"),
            mc.RunSpec(r["suboptimal"], NoiseModel().with_scales(speed=3.0), cfg,
                       "suboptimal x3 speed"),
            mc.RunSpec(r["baseline"], NoiseModel(), cfg.replace(horizon=15.0),
                       "baseline 15 s horizon"),
            mc.RunSpec(r["mass-min"], NoiseModel(), cfg.replace(success_locked_pairs=1),
                       "mass-min n_L >= 1")]


def run_golden() -> list:
    results = mc.evaluate_many(golden_specs(), SAMPLES, BASE_SEED, backend=mc.InProcessBackend(),
                               record_trace=True)
    return [exact({**{k: getattr(r, k) for k in RUN_FIELDS},
                   "per_sample": [{k: getattr(s, k) for k in SAMPLE_FIELDS} for s in r.samples]})
            for r in results]


def test_montecarlo_runs_bit_identical_to_golden():
    with open(GOLDEN) as f:
        golden = json.load(f)["runs"]
    got = run_golden()
    assert [g["label"] for g in got] == [g["label"] for g in golden]
    for run, want in zip(got, golden):
        for k in RUN_FIELDS:
            assert run[k] == want[k], (run["label"], k)
        for s, w in zip(run["per_sample"], want["per_sample"], strict=True):
            assert s == w, (run["label"], s["index"])


if __name__ == "__main__" and "--write" in sys.argv:
    with open(GOLDEN, "w") as f:
        json.dump({"machine": machine_facts(), "runs": run_golden()}, f, indent=1)
    print("wrote", GOLDEN)
