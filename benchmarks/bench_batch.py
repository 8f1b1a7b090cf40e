"""Episodes per core-second: the single-episode kernel against the batched one, the
batched one with the contacts' broad phase off, and with the exploration fidelity, side by
side in one run, on the same samples of each reference design (``make bench``).

    .venv/bin/python benchmarks/bench_batch.py [--samples N] [--lanes 4,8,16] [--designs a,b]

For each design: N noise samples run one at a time (``run_episode``, a batch of one lane)
and through :class:`~tethernet_ros.core.batch.BatchRunner` at each lane count (and at the
count :func:`~tethernet_ros.core.batch.choose_lanes` picks on this CPU).  Prints CPU
seconds, episodes per core-second, the ratio to the single kernel, and the real-time
factor per core (simulated seconds per CPU second); then how much of the implicit step's
machine code is packed SIMD arithmetic (``inspect_asm``).  Every batched episode is
checked against its single run bit for bit (settled CQI, locks, closing time, steps).
Then the contacts' broad phase off against on (``broadphase_cost``; alone with
``--broadphase-only``): episodes, real-time factors, the share of contact tests skipped
and the contact stage's own cost on a wrapped net.  Then an episode against the Zenit-2
as a mesh against the analytic one (``target_cost``; alone with ``--targets-only``).  CPU
time (``time.process_time``) is used: it is steadier than wall time on a shared machine.  Runs on one core.
"""
from __future__ import annotations

import argparse
import collections
import os
import re
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def simd_share(lanes: int) -> str:
    """Packed against scalar float64 arithmetic in fresh (uncached) compilations of
    advance_implicit on a batch of ``lanes`` lanes, with LLVM's loop vectoriser on (numba's
    default) and off (the project's setting, core/__init__.py)."""
    import numba
    from numba import njit

    from tethernet_ros.core import kernel as kn
    from tethernet_ros.core.design import REFERENCE_DESIGNS
    from tethernet_ros.core.scenario import scenario_for

    model, d1 = scenario_for(REFERENCE_DESIGNS["time-min"]).kernel()
    data = kn.empty_like(d1, lanes)
    for lane in range(lanes):
        kn.copy_lane(data, lane, d1, 0)
    scratch = kn.new_scratch(model, lanes)
    words = []
    setting = numba.config.LOOP_VECTORIZE
    try:
        for vec in (True, False):
            numba.config.LOOP_VECTORIZE = vec
            fresh = njit(nogil=True, error_model="numpy")(kn.advance_implicit.py_func)
            fresh(model, data, scratch, 1)
            asm = "\n".join(fresh.inspect_asm().values())
            ops = collections.Counter(re.findall(r"\bv(add|sub|mul|div|min|max|sqrt)([ps])d\b",
                                                 asm))
            packed = sum(n for (op, kind), n in ops.items() if kind == "p")
            scalar = sum(n for (op, kind), n in ops.items() if kind == "s")
            words.append(f"loop vectoriser {'on' if vec else 'off'}: {packed} packed / {scalar} "
                         "scalar float64 arithmetic instructions")
    finally:
        numba.config.LOOP_VECTORIZE = setting
    return "advance_implicit machine code, " + "; ".join(words)


def _stage_timer():
    """A compiled loop that times the implicit step's contact stage of lane 0 (contact
    rows and the clearing of stale friction) ``reps`` times on one frozen state, each
    repetition restoring first what the stage changes; with ``stage`` False the
    restoring alone (to subtract).  The caller times it; the stage needs scr.R set."""
    from numba import njit

    from tethernet_ros.core.kernel.contact_rows import (clear_inactive_contacts,
                                                        prepare_contact_rows)

    @njit(error_model="numpy")
    def loop(model, data, scr, saved, reps, stage):
        v0, pn0, pt0, mask0, pen0, point0, dist0 = saved
        ws = data.warm
        bp = data.broad
        for _ in range(reps):
            data.bodies.v[:] = v0
            ws.contact_pn[:] = pn0
            ws.contact_pt[:] = pt0
            data.bodies.contact_mask[:] = mask0
            data.max_penetration[:] = pen0
            bp.point[:] = point0
            bp.dist[:] = dist0
            if stage:
                prepare_contact_rows(model, data, scr, 0)
                clear_inactive_contacts(data, 0)
        return 0
    return loop


def broadphase_cost(designs, samples: int, wrapped_step: int = 20000, reps: int = 20000,
                    repeats: int = 2, nozzle: bool = True) -> list[str]:
    """The contacts' broad phase (core/kernel/broadphase.py) on and off, implicit method,
    as lines of text, a row per design (and with ``nozzle`` one of time-min's against a
    target with a nozzle, an extra solid of revolution: a costlier exact test).
    Episodes: ``samples`` noise samples of each design run one at a time
    with the broad phase off and on (interleaved), CPU seconds, the ratio on / off and the
    real-time factors (simulated s per CPU s), the share of exact contact tests skipped;
    each episode's CPU time the least of ``repeats`` runs; every run checked bit for bit
    (settled CQI, locks, closing time, steps, penetration).  Stage: the contact stage alone
    (``prepare_contact_rows`` + ``clear_inactive_contacts``) on the nominal episode's state
    at ``wrapped_step`` (the net wrapped), in us per step (least of 3 timings of ``reps``
    repetitions, less the restoring), off and on, and the ratio."""
    import numpy as np

    from tethernet_ros.core import kernel as kn
    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.design import REFERENCE_DESIGNS
    from tethernet_ros.core.episode import CaptureSimulation, run_simulation
    from tethernet_ros.core.noise import NoiseModel
    from tethernet_ros.core.scenario import scenario_for
    from tethernet_ros.core.target import TargetConfig
    from tethernet_ros.montecarlo.seeds import sample_seed

    cases = [(name, name, SimConfig()) for name in designs]
    if nozzle:
        cases.append(("time-min+nz", "time-min", SimConfig(target=TargetConfig(nozzle=True))))

    def episode(design, sample, cfg, mode):
        sc = scenario_for(design, sample, cfg)
        sc.broadphase = mode
        sim = CaptureSimulation(sc)
        t0 = time.process_time()
        r = run_simulation(sim, record_trace=False)
        cpu = time.process_time() - t0
        b = sim.data.broad   # the counts of this (the last) run
        return ((r.settled_cqi, r.locked_pairs, r.closing_time, r.steps, r.max_penetration),
                cpu, r.steps * sim.dt, int(b.tests[0]), int(b.skips[0]))

    # compile / load the kernel before timing (the mode is a value: one compilation)
    run_simulation(CaptureSimulation(scenario_for(REFERENCE_DESIGNS["time-min"], None,
                                                  SimConfig(horizon=1.0))),
                   record_trace=False)
    timer = _stage_timer()
    lines = ["contact broad phase, implicit method: episodes one at a time, off against on; "
             "stage = contact rows alone on the wrapped net",
             f"{'design':<11} {'cpu off':>8} {'cpu on':>8} {'on/off':>7} {'RTF off':>8} "
             f"{'RTF on':>7} {'skipped':>8} {'identical':>9} {'stage off':>10} "
             f"{'stage on':>9} {'on/off':>7}"]
    for label, name, cfg in cases:
        design = REFERENCE_DESIGNS[name]
        cpu = {"off": 0.0, "on": 0.0}
        sim_s = 0.0
        tests = skips = 0
        same = True
        for i in range(samples):
            sample = NoiseModel().sample(sample_seed(0, i))
            runs = [{mode: episode(design, sample, cfg, mode) for mode in ("off", "on")}
                    for _ in range(repeats)]
            out = runs[0]
            same &= all(repr(run[m][0]) == repr(out["off"][0]) for run in runs for m in run)
            for mode in cpu:
                cpu[mode] += min(run[mode][1] for run in runs)
            sim_s += out["on"][2]
            tests += out["on"][3]
            skips += out["on"][4]
        # the stage alone, on the nominal episode's state with the net wrapped
        sim = CaptureSimulation(scenario_for(design, None, cfg))
        sim.advance(min(wrapped_step, sim.end_step()))
        data = kn.take(sim.data, [0])
        scr = kn.new_scratch(sim.model, 1)
        scr.R[:, :, 0] = kn.quat_to_matrix(np.ascontiguousarray(data.target.quat[:, 0]))
        saved = tuple(a.copy() for a in (data.bodies.v, data.warm.contact_pn,
                                          data.warm.contact_pt, data.bodies.contact_mask,
                                          data.max_penetration, data.broad.point,
                                          data.broad.dist))
        stage = {}
        for mode in ("off", "on"):
            model = sim.model._replace(broadphase=kn.BROADPHASE_MODES.index(mode))
            best = {}
            for run_stage in (False, True):
                timer(model, data, scr, saved, 10, run_stage)     # compiled
                best[run_stage] = float("inf")
                for _ in range(3):
                    t0 = time.process_time()
                    timer(model, data, scr, saved, reps, run_stage)
                    best[run_stage] = min(best[run_stage], time.process_time() - t0)
            stage[mode] = max(best[True] - best[False], 0.0) / reps * 1e6
        lines.append(f"{label:<11} {cpu['off']:8.2f} {cpu['on']:8.2f} "
                     f"{cpu['on'] / cpu['off']:7.3f} {sim_s / cpu['off']:8.1f} "
                     f"{sim_s / cpu['on']:7.1f} {skips / (skips + tests):8.1%} {str(same):>9} "
                     f"{stage['off']:10.2f} {stage['on']:9.2f} "
                     f"{stage['on'] / stage['off'] if stage['off'] else float('nan'):7.3f}")
    lines.append(f"skipped: share of the exact contact tests the broad phase skipped; stage: "
                 f"us per step at step {wrapped_step} of the nominal episode; +nz: the "
                 "target with a nozzle")
    return lines


def target_cost(designs, samples: int, repeats: int = 2) -> list[str]:
    """An episode against a mesh target against the analytic Zenit-2 of the same design
    (issue 34: at most 1.5 times), as lines of text: the stage as the catalogue's
    128-sided meshes (``zenit-2-cylinder`` against the default cylinder; ``zenit-2-nozzle``
    against the analytic stage with its nozzle), ``samples`` noise samples each run one
    at a time, interleaved, each episode's CPU time the least of ``repeats`` runs; the
    ratio mesh / analytic, real-time factors per core and the exact contact tests per
    step (the mesh is another shape, so its episodes are not the analytic ones)."""
    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.design import REFERENCE_DESIGNS
    from tethernet_ros.core.episode import CaptureSimulation, run_simulation
    from tethernet_ros.core.noise import NoiseModel
    from tethernet_ros.core.scenario import scenario_for
    from tethernet_ros.core.target import TargetConfig
    from tethernet_ros.montecarlo.seeds import sample_seed

    pairs = [("cylinder", SimConfig(), SimConfig(target=TargetConfig(name="zenit-2-cylinder"))),
             ("+nozzle", SimConfig(target=TargetConfig(nozzle=True)),
              SimConfig(target=TargetConfig(name="zenit-2-nozzle")))]

    def episode(design, sample, cfg):
        sim = CaptureSimulation(scenario_for(design, sample, cfg))
        t0 = time.process_time()
        r = run_simulation(sim, record_trace=False)
        return time.process_time() - t0, r.steps * sim.dt, int(sim.data.broad.tests[0]), r.steps

    for _, a, m in pairs:                       # build, compile and cache before timing
        for cfg in (a, m):
            episode(REFERENCE_DESIGNS["time-min"], None, cfg.replace(horizon=1.0))
    lines = ["mesh target against the analytic Zenit-2: episodes one at a time, implicit "
             "method, broad phase on",
             f"{'design':<11} {'stage':<9} {'cpu an.':>8} {'cpu mesh':>9} {'mesh/an.':>9} "
             f"{'RTF an.':>8} {'RTF mesh':>9} {'tests/step an.':>15} {'mesh':>6}"]
    for name in designs:
        design = REFERENCE_DESIGNS[name]
        for label, ca, cm in pairs:
            tot = {"a": [0.0, 0.0, 0, 0], "m": [0.0, 0.0, 0, 0]}
            for i in range(samples):
                sample = NoiseModel().sample(sample_seed(0, i))
                for key, cfg in (("a", ca), ("m", cm)):
                    runs = [episode(design, sample, cfg) for _ in range(repeats)]
                    best = min(runs)
                    for j in range(4):
                        tot[key][j] += best[j]
            a, m = tot["a"], tot["m"]
            lines.append(f"{name:<11} {label:<9} {a[0]:8.2f} {m[0]:9.2f} {m[0] / a[0]:9.3f} "
                         f"{a[1] / a[0]:8.1f} {m[1] / m[0]:9.1f} {a[2] / a[3]:15.1f} "
                         f"{m[2] / m[3]:6.1f}")
    lines.append("cpu: CPU s of the samples; RTF: simulated s per CPU s; tests/step: exact "
                 "signed-distance queries per step (the broad phase skips the rest)")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=8)
    ap.add_argument("--lanes", default="4,8,16")
    ap.add_argument("--designs", default="baseline,suboptimal,mass-min,time-min")
    ap.add_argument("--broadphase-only", action="store_true",
                    help="only the contact broad phase's table (broadphase_cost)")
    ap.add_argument("--targets-only", action="store_true",
                    help="only the mesh-target table (target_cost)")
    args = ap.parse_args(argv)
    if args.broadphase_only:
        print("\n".join(broadphase_cost(args.designs.split(","), args.samples)))
        return 0
    if args.targets_only:
        print("\n".join(target_cost(args.designs.split(","), args.samples)))
        return 0

    from tethernet_ros.core.batch import BatchRunner, choose_lanes
    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.design import REFERENCE_DESIGNS
    from tethernet_ros.core.episode import run_episode
    from tethernet_ros.core.noise import NoiseModel
    from tethernet_ros.montecarlo.seeds import sample_seed

    from tethernet_ros.core.fidelity import EXPLORATION, at_fidelity

    cfg = SimConfig()
    explore = at_fidelity(cfg, EXPLORATION)
    chosen = choose_lanes(cfg)
    lane_counts = sorted({int(k) for k in args.lanes.split(",")} | {chosen})
    # compile / load every kernel before timing
    run_episode(REFERENCE_DESIGNS["time-min"], None, cfg.replace(horizon=1.0),
                record_trace=False)
    print(f"lanes chosen on this CPU: {chosen}; {args.samples} samples per design (base seed 0)")
    header = (f"{'design':<11} {'kernel':<12} {'cpu (s)':>8} {'ep/core-s':>10} {'ratio':>6} "
              f"{'RTF/core':>9} {'identical':>9}")
    print(header)
    for name in args.designs.split(","):
        design = REFERENCE_DESIGNS[name]
        samples = [(i, NoiseModel().sample(sample_seed(0, i))) for i in range(args.samples)]
        t0 = time.process_time()
        single = {i: run_episode(design, s, cfg, record_trace=False) for i, s in samples}
        cpu_single = time.process_time() - t0
        sim_time = sum(r.steps for r in single.values()) * 1e-3
        rate1 = len(samples) / cpu_single
        print(f"{name:<11} {'single':<12} {cpu_single:8.2f} {rate1:10.3f} {1.0:6.2f} "
              f"{sim_time / cpu_single:9.1f} {'-':>9}")
        for k in lane_counts:
            t0 = time.process_time()
            got = {tag: r for tag, r, _ in BatchRunner(design, cfg, lanes=k).run(samples)}
            cpu = time.process_time() - t0
            same = all((got[i].settled_cqi, got[i].locked_pairs, got[i].closing_time, got[i].steps)
                       == (r.settled_cqi, r.locked_pairs, r.closing_time, r.steps)
                       or (got[i].steps == r.steps and got[i].failure_reason == r.failure_reason)
                       for i, r in single.items())
            label = f"batch K={k}" + ("*" if k == chosen else "")
            print(f"{name:<11} {label:<12} {cpu:8.2f} {len(samples) / cpu:10.3f} "
                  f"{cpu_single / cpu:6.2f} {sim_time / cpu:9.1f} {str(same):>9}")
        # at the chosen lane count: the broad phase off (bit for bit the same episodes), and
        # the exploration fidelity (2 ms, 8 sweeps: other episodes, so no identity check)
        for label, runner, check in (
                ("K* bp off", BatchRunner(design, cfg, lanes=chosen, broadphase="off"), True),
                ("K* explore", BatchRunner(design, explore, lanes=chosen), False)):
            t0 = time.process_time()
            got = {tag: r for tag, r, _ in runner.run(samples)}
            cpu = time.process_time() - t0
            sim = sum(r.completion_time for r in got.values())
            same = all((got[i].settled_cqi, got[i].locked_pairs, got[i].closing_time, got[i].steps)
                       == (r.settled_cqi, r.locked_pairs, r.closing_time, r.steps)
                       or (got[i].steps == r.steps and got[i].failure_reason == r.failure_reason)
                       for i, r in single.items()) if check else "-"
            print(f"{name:<11} {label:<12} {cpu:8.2f} {len(samples) / cpu:10.3f} "
                  f"{cpu_single / cpu:6.2f} {sim / cpu:9.1f} {str(same):>9}")
    print("* the lane count choose_lanes picks on this CPU (broad phase on: the default); "
          "bp off: the contacts' broad phase off; explore: the exploration fidelity "
          "(core/fidelity.py, 2 ms with 8 sweeps), whose RTF counts its own simulated time")
    print(simd_share(chosen))
    print("\n".join(broadphase_cost(args.designs.split(","), args.samples)))
    print("\n".join(target_cost(args.designs.split(","), args.samples)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
