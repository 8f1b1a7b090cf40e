"""The kernel's results for a fixed set of episodes, recorded before a refactoring and
compared bit for bit after it (final state digest, settled CQI, locks, closing time, steps).

Regenerate only when the model itself is meant to change:
    python tests/test_kernel_golden.py --write
"""
from __future__ import annotations

import hashlib
import json
import os
import sys

import numpy as np
import pytest

from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.core.episode import CaptureSimulation, run_simulation
from tethernet_ros.core.noise import NoiseModel
from tethernet_ros.core.scenario import scenario_for

GOLDEN = os.path.join(os.path.dirname(__file__), "data", "golden_episodes.json")
CASES = [(name, seed) for name in ("baseline", "suboptimal", "mass-min", "time-min")
         for seed in (None, 3)]


def golden_config() -> SimConfig:
    """The model the golden file was recorded with."""
    return SimConfig.preset("spec-text")


def state_digest(sim) -> str:
    s = sim.s
    b, t = s.bodies, s.target_body
    h = hashlib.sha256()
    for a in (b.x, b.v, t.pos, t.quat, t.vel, t.omega, s.drawstring.maxdist):
        h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    return h.hexdigest()


def run_case(name, seed) -> dict:
    sample = None if seed is None else NoiseModel().sample(seed)
    sim = CaptureSimulation(scenario_for(REFERENCE_DESIGNS[name], sample, golden_config()))
    r = run_simulation(sim, record_trace=False)
    return dict(design=name, seed=seed, success=r.success, settled_cqi=repr(r.settled_cqi),
                locked_pairs=r.locked_pairs, closing_time=repr(r.closing_time), steps=r.steps,
                digest=state_digest(sim))


def _golden():
    with open(GOLDEN) as f:
        return {(d["design"], d["seed"]): d for d in json.load(f)}


@pytest.mark.parametrize("name,seed", CASES)
def test_episode_bit_identical_to_golden(name, seed):
    assert run_case(name, seed) == _golden()[(name, seed)]


if __name__ == "__main__" and "--write" in sys.argv:
    out = [run_case(n, s) for n, s in CASES]
    with open(GOLDEN, "w") as f:
        json.dump(out, f, indent=1)
    print(f"wrote {GOLDEN}")
