"""A cost model of sequential sampling's batch size, replayed on finished optimisation
histories (an estimate, not a measurement: benchmarks/bench_sequential_batch.py measures).

    .venv/bin/python benchmarks/model_sequential_batch.py [HISTORY.csv ...]

Each design of a history (default: docs/cases/case1-history.csv and case2-history.csv)
becomes a sequence of samples: its decisive samples with its failures at random places
(an infeasible design's last sample its third failure), then 40 more at its observed
rate; each episode lasts its design's mean T at 1 ms steps with a 15 % spread (seed 1).
Two workers of 4 lanes run each batch, a worker's tasks on its lanes, refilled as lanes
end, the batch halving once at most half its lanes are busy and none is left to start; a
batch of k lanes costs the measured per-lane-step times of docs/studies/step.md (K = 1
29.8 us, K = 4 23.6; K = 2 taken as 26.7).  A batch's wall time is its slower worker's.
Prints wall and CPU hours, episodes drawn, and the ratios to 16 per batch.
"""
from __future__ import annotations

import csv
import math
import os
import random
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from optimizer.sequential import SequentialRule  # noqa: E402

COST = {1: 29.8, 2: 2 * 26.7, 4: 4 * 23.6}        # us per batch-step of k lanes
LANES, WORKERS = 4, 2
#: the Case 1 rule (N = 100, C_P = 0.98: F = 2, stopping when feasible) for both histories
RULE = SequentialRule(100, 0.98)
F_MAX = RULE.allowed_failures


def worker_time(steps: list[int]) -> float:
    feed = list(steps)
    if not feed:
        return 0.0
    k = min(LANES, 1 << (len(feed) - 1).bit_length())
    busy = [feed.pop(0) for _ in range(min(k, len(feed)))]
    t = 0.0
    while busy:
        m = min(busy)
        t += m * COST[k]
        busy = [b - m for b in busy if b > m]
        while feed and len(busy) < k:
            busy.append(feed.pop(0))
        while not feed and k > 1 and len(busy) <= k // 2:
            k //= 2
    return t


POLICIES = {   # samples of the next batch, from the successes so far
    "16 per batch": lambda succ: 16,
    "8 per batch": lambda succ: 8,
    "4 per batch": lambda succ: 4,
    "expected, 4 to 16": lambda succ: max(4, min(16, math.ceil(RULE.expected_to_decide(succ)))),
    "expected, 8 to 16": lambda succ: max(8, min(16, math.ceil(RULE.expected_to_decide(succ)))),
}


def replay(designs, policy) -> tuple[float, float, int]:
    wall = cpu = 0.0
    drawn = 0
    for succ, steps in designs:
        m = 0
        while m < len(succ):
            b = min(policy(succ[:m]), len(succ) - m)
            per = math.ceil(b / WORKERS)
            times = [worker_time(steps[i:i + per]) for i in range(m, m + b, per)]
            wall, cpu, drawn, m = wall + max(times), cpu + sum(times), drawn + b, m + b
            if RULE(succ[:m]) is not None:
                break
    return wall / 3.6e9, cpu / 3.6e9, drawn


def designs_of(path: str, rng: random.Random):
    out = []
    with open(path) as f:
        for r in csv.DictReader(f):
            n, s = int(r["samples"]), int(r["successes"])
            t = float(r["mean_completion_time"] or 120.0)
            fails = set(rng.sample(range(n - 1), 2)) | {n - 1} if n - s > F_MAX \
                else set(rng.sample(range(n), n - s))
            succ = [i not in fails for i in range(n)] + [rng.random() < s / n for _ in range(40)]
            out.append((succ, [max(1000, int(rng.gauss(t, 0.15 * t) * 1000)) for _ in succ]))
    return out


def main(argv=None) -> int:
    paths = (argv if argv is not None else sys.argv[1:]) or [
        os.path.join(ROOT, "docs/cases/case1-history.csv"),
        os.path.join(ROOT, "docs/cases/case2-history.csv")]
    for path in paths:
        designs = designs_of(path, random.Random(1))
        print(f"{path}: {len(designs)} designs, {sum(RULE(s) for s, _ in designs)} decisive samples")
        base = None
        for name, policy in POLICIES.items():
            w, c, d = replay(designs, policy)
            base = base or (w, c)
            print(f"  {name:18s} wall {w:5.2f} h  CPU {c:5.2f} h  episodes {d:6d}  "
                  f"wall / 16: {w / base[0]:.3f}  CPU / 16: {c / base[1]:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
