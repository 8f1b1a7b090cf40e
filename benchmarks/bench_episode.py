"""Episode benchmark: the implicit and the explicit method side by side on each reference
design (nominal launch): wall time per episode, real-time factor, cost per step and the
ratio of the two methods' wall times, in one run.

    .venv/bin/python benchmarks/bench_episode.py [--repeats N] [--designs a,b]
        [--config FILE.yaml] [--iterations K] [--no-trace] [--implicit-only]

Runs on one core (the kernels are single-threaded).  The methods alternate episode by
episode (implicit, explicit, implicit, ...) so that a drift of the machine's speed hits
both alike; the median of the repeats is printed.  Wall time and this process's CPU time
are both given: on a machine shared with other jobs the CPU time is the steadier one.
The first call of each method compiles its kernel or loads it from numba's on-disk cache;
that time is reported apart.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

#: the source's cost of an episode: a full Case Study took it 28 h on 30 threads for
#: 250 designs x 100 samples + 1000 validation samples (26 000 episodes): 116 thread-s each
REFERENCE_CPU_SECONDS = 28 * 3600 * 30 / 26_000


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--designs", default="baseline,suboptimal,mass-min,time-min")
    ap.add_argument("--config", default=None, help="YAML of SimConfig fields (default model otherwise)")
    ap.add_argument("--iterations", type=int, default=None, help="implicit sweeps per step")
    ap.add_argument("--no-trace", action="store_true", help="skip the CQI trace (kernel only)")
    ap.add_argument("--implicit-only", action="store_true", help="skip the explicit method")
    args = ap.parse_args(argv)

    t0 = time.perf_counter()
    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.design import REFERENCE_DESIGNS
    from tethernet_ros.core.episode import CaptureSimulation, run_episode
    from tethernet_ros.core.scenario import scenario_for
    t_import = time.perf_counter() - t0

    data = {}
    if args.config:
        import yaml

        with open(args.config) as f:
            data = yaml.safe_load(f) or {}
    base = SimConfig.from_dict(data)
    implicit = base.replace(integrator="implicit")
    if args.iterations:
        implicit = implicit.replace(implicit_iterations=args.iterations)
    methods = [("implicit", implicit)]
    if not args.implicit_only:
        methods.append(("explicit", base.replace(integrator="explicit")))

    for label, cfg in methods:
        t0 = time.perf_counter()
        sim = CaptureSimulation(scenario_for(REFERENCE_DESIGNS["time-min"], None, cfg))
        sim.advance(1)
        sim.cqi()
        print(f"{label}: kernel compile / cache load + first step {time.perf_counter() - t0:.2f} s")
    print(f"import {t_import:.2f} s; implicit: {implicit.implicit_iterations} sweeps at "
          f"{implicit.implicit_dt:g} s; median of {args.repeats} episode(s) per cell")
    print(f"{'design':<11} {'method':<9} {'dt (s)':>9} {'steps':>8} {'sim (s)':>8} {'wall (s)':>9} "
          f"{'RTF':>6} {'cpu (s)':>8} {'RTF cpu':>8} {'us/step':>8} {'vs ref':>7} {'expl/impl':>9}  outcome")
    for name in args.designs.split(","):
        d = REFERENCE_DESIGNS[name]
        walls = {label: [] for label, _ in methods}
        cpus = {label: [] for label, _ in methods}
        res = {}
        for _ in range(args.repeats):
            for label, cfg in methods:
                t0, c0 = time.perf_counter(), time.process_time()
                res[label] = run_episode(d, None, cfg, record_trace=not args.no_trace)
                walls[label].append(time.perf_counter() - t0)
                cpus[label].append(time.process_time() - c0)
        med = {label: statistics.median(w) for label, w in walls.items()}
        cpu = {label: statistics.median(c) for label, c in cpus.items()}
        for label, cfg in methods:
            r = res[label]
            wall = med[label]
            dt = scenario_for(d, None, cfg).dt
            ratio = (f"{cpu['explicit'] / cpu['implicit']:9.1f}" if "explicit" in cpu and label == "implicit"
                     else f"{'':9s}")
            outcome = "success" if r.success else r.failure_reason
            c = cpu[label]
            print(f"{name:<11} {label:<9} {dt:9.3e} {r.steps:8d} {r.completion_time:8.2f} {wall:9.3f} "
                  f"{r.completion_time / wall:6.1f} {c:8.3f} {r.completion_time / c:8.1f} "
                  f"{c / r.steps * 1e6:8.2f} {REFERENCE_CPU_SECONDS / c:6.0f}x {ratio}  {outcome}",
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
