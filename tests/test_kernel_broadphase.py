"""The contacts' broad phase (core/kernel/broadphase.py): with it on, off or in its check
mode an episode ends in the same result and the same final state bit for bit, on both
step methods, the four reference designs, a tumbling target and a target with a nozzle
(an extra solid of revolution); it skips most exact tests
of a wrapped net; and its bound is conservative (no skipped body was within reach, by the
kernel's check mode and by exact distances recomputed here on the episode's states)."""
from __future__ import annotations

import numpy as np
import pytest

from tethernet_ros.core import kernel as kn
from tethernet_ros.core.batch import BatchRunner
from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.core.episode import CaptureSimulation, run_simulation
from tethernet_ros.core.kernel.broadphase import SLACK
from tethernet_ros.core.noise import NoiseModel
from tethernet_ros.core.scenario import scenario_for
from tethernet_ros.core.target import TargetConfig
from tethernet_ros.core.tumble import TumbleConfig

from golden import exact

#: 4 s of the wrapped net after closing starts (the default settles for 20 s): the broad
#: phase skips and tests all through it, at a quarter of make test's cost
SETTLE = 4.0
IMPLICIT = SimConfig(settle_time=SETTLE)
EXPLICIT = SimConfig.preset("spec-text").replace(settle_time=SETTLE)
TUMBLING = SimConfig(settle_time=SETTLE, tumble=TumbleConfig(rate_deg_s=8.0, axis="flat"))
NOZZLE = SimConfig(settle_time=SETTLE, target=TargetConfig(nozzle=True))   # a second solid
RESULT = ("success", "settled_cqi", "locked_pairs", "closing_time", "completion_time",
          "failure_reason", "steps", "max_penetration")


def _episode(name, seed, cfg, mode):
    """(result fields, final Data arrays but the broad phase's, broad phase counts) of one
    episode with the broad phase in ``mode``."""
    sample = None if seed is None else NoiseModel().sample(seed)
    sc = scenario_for(REFERENCE_DESIGNS[name], sample, cfg)
    sc.broadphase = mode
    sim = CaptureSimulation(sc)
    r = run_simulation(sim, record_trace=False)
    d = sim.data
    state = {f: getattr(d, f) for f in d._fields if f != "broad"}
    b = d.broad
    counts = {"tests": int(b.tests[0]), "skips": int(b.skips[0]), "misses": int(b.misses[0])}
    return exact({k: getattr(r, k) for k in RESULT}), state, counts


def _same_arrays(a, b) -> bool:
    """Whether two (nested named tuples of) arrays hold the same bits."""
    if isinstance(a, np.ndarray):
        return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    return all(_same_arrays(x, y) for x, y in zip(a, b))


CASES = ([("implicit", IMPLICIT, name, seed) for name in REFERENCE_DESIGNS for seed in (None, 3)]
         # the explicit path's one case (its broad phase is the same code for every design;
         # the baseline's explicit case took 34 s of make test's budget)
         + [("explicit", EXPLICIT, "time-min", None)]
         + [("tumbling", TUMBLING, "time-min", 5), ("tumbling", TUMBLING, "mass-min", None)]
         + [("nozzle", NOZZLE, "time-min", None), ("nozzle", NOZZLE, "baseline", 3)])


@pytest.mark.parametrize("label,cfg,name,seed", CASES,
                         ids=[f"{c[0]}-{c[2]}-{c[3]}" for c in CASES])
def test_on_off_and_check_give_the_same_bits(label, cfg, name, seed):
    res_off, state_off, c_off = _episode(name, seed, cfg, "off")
    res_on, state_on, c_on = _episode(name, seed, cfg, "on")
    res_chk, state_chk, c_chk = _episode(name, seed, cfg, "check")
    assert res_on == res_off and res_chk == res_off
    for f in state_off:
        assert _same_arrays(state_on[f], state_off[f]), f
        assert _same_arrays(state_chk[f], state_off[f]), f
    # off tests every body; on skips some of those tests and makes the rest; check makes
    # them all and finds the same ones skippable, none of them within reach
    assert c_off["skips"] == 0 and c_off["tests"] > 0
    assert c_on["skips"] > 0
    assert c_on["tests"] + c_on["skips"] == c_off["tests"]
    assert c_chk["tests"] == c_off["tests"] and c_chk["skips"] == c_on["skips"]
    assert c_chk["misses"] == 0


def test_a_wrapped_net_skips_most_tests():
    # time-min, nominal: from the net's wrap to the end most bodies lie inside the
    # stage's bounding sphere yet far from its surface
    _, _, c = _episode("time-min", None, IMPLICIT, "on")
    share = c["skips"] / (c["skips"] + c["tests"])
    assert share > 0.5, share


def test_batched_lanes_give_the_same_bits_on_and_off():
    design = REFERENCE_DESIGNS["mass-min"]
    cfg = SimConfig(settle_time=2.0, horizon=12.0)
    samples = [(i, NoiseModel().sample(20 + i)) for i in range(3)]
    runs = {}
    for mode in ("off", "on"):
        got = BatchRunner(design, cfg, lanes=2, broadphase=mode).run(samples)
        runs[mode] = {tag: exact({k: getattr(r, k) for k in RESULT}) for tag, r, _ in got}
    assert sorted(runs["on"]) == [0, 1, 2]
    assert runs["on"] == runs["off"]


@pytest.mark.parametrize("cfg", [IMPLICIT, TUMBLING, NOZZLE], ids=["at-rest", "tumbling",
                                                                   "nozzle"])
def test_the_bound_holds_on_recomputed_distances(cfg):
    # along an episode, for every body with a cached test: its cached distance is the
    # exact signed distance at the cached point, and its exact distance now is at least
    # the cached one less its motion relative to the target since (the bound skipping
    # rests on), recomputed here from the state, not by the kernel
    sc = scenario_for(REFERENCE_DESIGNS["time-min"], NoiseModel().sample(7), cfg)
    sim = CaptureSimulation(sc)
    tg = sim.model.target
    radius = sim.model.bodies.radius
    d = sim.data
    checked = proven = 0
    while sim.step < sim.end_step():
        sim.advance(min(500, sim.end_step() - sim.step))
        R = kn.quat_to_matrix(np.ascontiguousarray(d.target.quat[:, 0]))
        for i in np.flatnonzero(d.broad.dist[:, 0] != 0.0):
            point = np.ascontiguousarray(d.broad.point[i, :, 0])
            cached, _ = kn.target_signed_distance(point, tg.geometry)
            assert abs(cached - d.broad.dist[i, 0]) <= 1e-12
            b = R.T @ (d.bodies.x[i, :, 0] - d.target.pos[:, 0])
            now, _ = kn.target_signed_distance(b, tg.geometry)
            moved = float(np.linalg.norm(b - point))
            assert now >= cached - moved - 1e-9, (sim.step, i)
            checked += 1
            # a body the bound proves apart from the surface is apart from it
            if cached - moved - radius[i] - SLACK > 0.0:
                proven += 1
                assert now > radius[i], (sim.step, i)
    assert checked > 1000 and proven > 100
