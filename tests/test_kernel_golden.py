"""The kernels' results for a fixed set of episodes, recorded before a refactoring and
compared bit for bit after it (final state digest, settled CQI, locks, closing time, steps):
the "spec-text" model on the explicit method (recorded before the kernel got its named
state) and the default model on the implicit method.

Regenerate only when a model itself is meant to change:
    python tests/test_kernel_golden.py --write [spec-text|default]
Each file records the machine facts it was made with ("machine"); the episodes are the
same on every x86-64 machine with the pinned wheels (test_reproducibility.py).
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
from tethernet_ros.core.target import TargetConfig
from tethernet_ros.machine import machine_facts

DATA = os.path.join(os.path.dirname(__file__), "data")
#: golden file per model
GOLDEN = {"spec-text": os.path.join(DATA, "golden_episodes.json"),
          "default": os.path.join(DATA, "golden_episodes_default.json"),
          "mesh": os.path.join(DATA, "golden_episodes_mesh.json")}
CASES = [(name, seed) for name in ("baseline", "suboptimal", "mass-min", "time-min")
         for seed in (None, 3)]
#: the mesh target's goldens: the Zenit-2 with its nozzle as the catalogue's mesh
MESH_CASES = [("time-min", None), ("mass-min", 3)]


def golden_config(model: str) -> SimConfig:
    """The model a golden file was recorded with."""
    if model == "mesh":
        return SimConfig(target=TargetConfig(name="zenit-2-nozzle"))
    return SimConfig.preset("spec-text") if model == "spec-text" else SimConfig()


def cases_of(model: str) -> list:
    return MESH_CASES if model == "mesh" else CASES


def state_digest(sim) -> str:
    s = sim.s
    b, t = s.bodies, s.target_body
    h = hashlib.sha256()
    for a in (b.x, b.v, t.pos, t.quat, t.vel, t.omega, s.drawstring.maxdist):
        h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    return h.hexdigest()


def run_case(model, name, seed) -> dict:
    sample = None if seed is None else NoiseModel().sample(seed)
    sim = CaptureSimulation(scenario_for(REFERENCE_DESIGNS[name], sample, golden_config(model)))
    r = run_simulation(sim, record_trace=False)
    return dict(design=name, seed=seed, success=r.success, settled_cqi=repr(r.settled_cqi),
                locked_pairs=r.locked_pairs, closing_time=repr(r.closing_time), steps=r.steps,
                digest=state_digest(sim))


def _golden(model):
    with open(GOLDEN[model]) as f:
        return {(d["design"], d["seed"]): d for d in json.load(f)["episodes"]}


@pytest.mark.parametrize("model", ["default", "spec-text"])
@pytest.mark.parametrize("name,seed", CASES)
def test_episode_bit_identical_to_golden(model, name, seed):
    assert run_case(model, name, seed) == _golden(model)[(name, seed)]


@pytest.mark.parametrize("name,seed", MESH_CASES)
def test_mesh_target_episode_bit_identical_to_golden(name, seed):
    assert run_case("mesh", name, seed) == _golden("mesh")[(name, seed)]


if __name__ == "__main__" and "--write" in sys.argv:
    for model in [m for m in GOLDEN if m in sys.argv] or list(GOLDEN):
        out = {"machine": machine_facts(),
               "episodes": [run_case(model, n, s) for n, s in cases_of(model)]}
        with open(GOLDEN[model], "w") as f:
            json.dump(out, f, indent=1)
        print(f"wrote {GOLDEN[model]}")
