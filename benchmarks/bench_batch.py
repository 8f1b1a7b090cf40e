"""Episodes per core-second: the single-episode kernel against the batched one, side by
side in one run, on the same samples of each reference design.

    .venv/bin/python benchmarks/bench_batch.py [--samples N] [--lanes 4,8,16] [--designs a,b]

For each design: N noise samples run one at a time (``run_episode``, a batch of one lane)
and through :class:`~tethernet_ros.core.batch.BatchRunner` at each lane count (and at the
count :func:`~tethernet_ros.core.batch.choose_lanes` picks on this CPU).  Prints CPU
seconds, episodes per core-second, the ratio to the single kernel, and the real-time
factor per core (simulated seconds per CPU second); then how much of the implicit step's
machine code is packed SIMD arithmetic (``inspect_asm``).  Every batched episode is
checked against its single run bit for bit (settled CQI, locks, closing time, steps).
CPU time (``time.process_time``) is used: it is steadier than wall time on a shared
machine.  Runs on one core.
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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=8)
    ap.add_argument("--lanes", default="4,8,16")
    ap.add_argument("--designs", default="baseline,suboptimal,mass-min,time-min")
    args = ap.parse_args(argv)

    from tethernet_ros.core.batch import BatchRunner, choose_lanes
    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.design import REFERENCE_DESIGNS
    from tethernet_ros.core.episode import run_episode
    from tethernet_ros.core.noise import NoiseModel
    from tethernet_ros.montecarlo.seeds import sample_seed

    cfg = SimConfig()
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
    print("* the lane count choose_lanes picks on this CPU")
    print(simd_share(chosen))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
