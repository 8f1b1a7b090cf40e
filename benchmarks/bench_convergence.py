"""Statistical time-step convergence: the reliability of a design at the default step and
at half of it, over the same noise samples.

    .venv/bin/python benchmarks/bench_convergence.py [--design mass-min] [--samples 40] [--workers 2]

Single trajectories after closing are chaotic (README, Numerical method), so the quantity
compared is the Monte Carlo estimate: P*_s with its Wilson interval, mean settled CQI,
mean completion time, and how many samples agree on success between the two steps.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--design", default="mass-min")
    ap.add_argument("--samples", type=int, default=40)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)

    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.design import load_design
    from tethernet_ros.montecarlo import ProcessPoolBackend, evaluate

    design = load_design(args.design)
    base = SimConfig()
    rows = []
    with ProcessPoolBackend(workers=args.workers) as backend:
        for safety in (base.dt_safety, base.dt_safety / 2):
            t0 = time.perf_counter()
            r = evaluate(design, args.samples, args.seed, config=base.replace(dt_safety=safety),
                         backend=backend)
            rows.append((safety, r, time.perf_counter() - t0))
    print(f"design {args.design}, {args.samples} samples, base seed {args.seed}")
    print(f"{'dt_safety':>9} {'P*_s':>6} {'Wilson 95%':>16} {'mean CQI':>9} {'mean T (s)':>10} {'wall (s)':>9}")
    for safety, r, wall in rows:
        cqis = [s.settled_cqi for s in r.samples if math.isfinite(s.settled_cqi)]
        print(f"{safety:9.3f} {r.p_success:6.3f} [{r.ci_low:.3f}, {r.ci_high:.3f}] "
              f"{sum(cqis) / max(len(cqis), 1):9.3f} {r.mean_completion_time:10.2f} {wall:9.1f}")
    a, b = rows[0][1].samples, rows[1][1].samples
    agree = sum(1 for x, y in zip(a, b) if x.success == y.success)
    same_nl = sum(1 for x, y in zip(a, b) if x.locked_pairs == y.locked_pairs)
    print(f"samples with the same verdict at both steps: {agree}/{len(a)}; "
          f"same locked-pair count: {same_nl}/{len(a)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
