"""Episode benchmark: wall time per nominal episode of each reference design, simulated
time, real-time factor and cost per step, with numba compilation timed apart.

    .venv/bin/python benchmarks/bench_episode.py [--repeats N] [--designs a,b] [--no-trace]

Runs on one core (the kernel is single-threaded).  The first call compiles the kernel or
loads it from numba's on-disk cache (__pycache__); that time is reported separately.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

REFERENCE_CPU_SECONDS = 150.0   # the reference implementation, per episode (issue 2)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--designs", default="baseline,suboptimal,mass-min,time-min")
    ap.add_argument("--no-trace", action="store_true", help="skip the CQI trace (kernel only)")
    args = ap.parse_args(argv)

    t0 = time.perf_counter()
    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.design import REFERENCE_DESIGNS
    from tethernet_ros.core.episode import CaptureSimulation, run_episode
    from tethernet_ros.core.scenario import scenario_for
    t_import = time.perf_counter() - t0

    t0 = time.perf_counter()
    sim = CaptureSimulation(scenario_for(REFERENCE_DESIGNS["time-min"]))
    sim.advance(1)
    sim.cqi()
    t_jit = time.perf_counter() - t0
    print(f"import {t_import:.2f} s; kernel compile / cache load + first step {t_jit:.2f} s")
    print(f"{'design':<11} {'dt (s)':>9} {'steps':>8} {'sim (s)':>8} {'wall (s)':>9} "
          f"{'RTF':>6} {'us/step':>8} {'vs ref':>7}  outcome")
    cfg = SimConfig()
    for name in args.designs.split(","):
        d = REFERENCE_DESIGNS[name]
        walls, res = [], None
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            res = run_episode(d, None, cfg, record_trace=not args.no_trace)
            walls.append(time.perf_counter() - t0)
        wall = statistics.median(walls)
        dt = scenario_for(d, None, cfg).dt
        outcome = "success" if res.success else res.failure_reason
        print(f"{name:<11} {dt:9.3e} {res.steps:8d} {res.completion_time:8.2f} {wall:9.3f} "
              f"{res.completion_time / wall:6.1f} {wall / res.steps * 1e6:8.2f} "
              f"{REFERENCE_CPU_SECONDS / wall:6.0f}x  {outcome}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
