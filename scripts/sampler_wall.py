"""Is a Case run's search wall time lost to idle workers?  A model of the sequential
sampler's schedule, replayed on a run directory's own records: for each design, in the
order of the run, the batches ``tethernet_ros.montecarlo.evaluate`` draws (``_batch_for``
with the case's stopping rule), each batch's tasks split into groups as the process pool
splits them (``group_size_for``) and taken by the first free of ``--workers`` workers; a
group lasts the sum of its episodes' recorded CPU time (one process, one thread; the
lanes' shares of a batched group are already in that CPU).  The modelled wall is what
the search would take on dedicated cores with no other cost; the recorded evaluation wall
(``wall_time`` of history.csv) beside it says how much went elsewhere (other processes on
the cores, the main process).  ``--max-batch`` replays the same designs with a larger
most-samples-per-batch (samples past a decision are modelled at the run's mean CPU).
Used for docs/cases/README.md ("Case 2 searched at the exploration fidelity").

    .venv/bin/python scripts/sampler_wall.py RUN_DIR [--workers 2] [--lanes 4]
        [--max-batch 16,32,64]

``--lanes``: the lane count the run's processes chose (``core.batch.choose_lanes``,
timed per process and not recorded; it sets the first batch: one sample per lane of
every worker).
"""
from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path
from types import SimpleNamespace

from optimizer.cases import CASES
from tethernet_ros.montecarlo.backends import GROUP_SIZE, group_size_for
from tethernet_ros.montecarlo.evaluate import _batch_for
from tethernet_ros.montecarlo.results_file import ResultsFile


def records(run: Path) -> tuple[list[str], dict, dict]:
    """The design keys in the order of the run, and per key: index -> CPU-s, success."""
    cpu: dict[str, dict[int, float]] = {}
    ok: dict[str, dict[int, bool]] = {}
    for _, r in ResultsFile(run / "samples.jsonl").records():
        cpu.setdefault(r.key, {})[r.index] = float(r.cpu_time)
        ok.setdefault(r.key, {})[r.index] = bool(r.success)
    return list(cpu), cpu, ok


def batch_wall(costs: list[float], workers: int) -> float:
    """Wall time of one batch: its groups taken in order by the first free worker."""
    busy = [0.0] * workers
    size = group_size_for(len(costs), workers, GROUP_SIZE)
    for start in range(0, len(costs), size):
        w = busy.index(min(busy))
        busy[w] += sum(costs[start:start + size])
    return max(busy)


def replay(cpu: dict, ok: dict, rule, backend, workers: int, n: int, fill: float):
    """(modelled wall, samples drawn, samples the estimate rests on, CPU drawn) of one
    design; a sample past the recorded ones is a success at ``fill`` CPU-s (only past a
    decision: the decision never reads it)."""
    succ: list[bool] = []
    wall = cpu_drawn = 0.0
    while len(succ) < n and rule(succ) is None:
        m = len(succ)
        idx = range(m, min(n, m + _batch_for(backend, rule, succ)))
        costs = [cpu.get(i, fill) for i in idx]
        wall += batch_wall(costs, workers)
        cpu_drawn += sum(costs)
        succ.extend(ok.get(i, True) for i in idx)
    decided = rule(succ)
    return wall, len(succ), decided if decided is not None else len(succ), cpu_drawn


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--lanes", type=int, default=4)
    ap.add_argument("--max-batch", default="", help="comma-separated most samples per batch "
                    "to replay besides the pool's (workers x group size)")
    args = ap.parse_args(argv)
    run_json = json.loads((args.run / "run.json").read_text())
    case = CASES[run_json["case"]]
    n = int(run_json["samples"])
    rows = list(csv.DictReader(open(args.run / "history.csv")))
    order, cpu, ok = records(args.run)
    if len(order) < len(rows):
        sys.exit(f"{args.run}: {len(rows)} designs in history.csv, samples of {len(order)}")
    order = order[:len(rows)]                   # a design in flight at a stop: left out
    recorded_wall = sum(float(r["wall_time"]) for r in rows)
    every = [c for k in order for c in cpu[k].values()]
    fill = sum(every) / len(every)
    first = args.workers * min(GROUP_SIZE, args.lanes)
    print(f"{args.run}: {len(order)} designs, {len(every)} episodes recorded, "
          f"{sum(every) / 3600:.2f} CPU-h; recorded evaluation wall {recorded_wall / 60:.1f} "
          f"min, so {sum(every) / (args.workers * recorded_wall):.3f} of {args.workers} "
          f"cores busy with episodes")
    sizes = [args.workers * GROUP_SIZE] + [int(s) for s in args.max_batch.split(",") if s]
    for most in sizes:
        backend = SimpleNamespace(batch_size=first, max_batch_size=max(first, most))
        wall = drawn = used = drawn_cpu = 0.0
        for k in order:
            w, d, u, c = replay(cpu[k], ok[k], case.sequential_rule(n), backend,
                                args.workers, n, fill)
            wall, drawn, used, drawn_cpu = wall + w, drawn + d, used + u, drawn_cpu + c
        print(f"most {most:3d} samples a batch: modelled wall {wall / 60:6.1f} min "
              f"(cores busy {drawn_cpu / (args.workers * wall):.3f}), "
              f"{drawn_cpu / 3600:.2f} CPU-h, {int(drawn)} samples drawn, "
              f"{int(drawn - used)} past a decision")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
