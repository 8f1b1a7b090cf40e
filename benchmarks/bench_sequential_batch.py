"""Sequential sampling: samples drawn per batch against episodes, wall and CPU time.

    .venv/bin/python benchmarks/bench_sequential_batch.py [--history CSV] [--designs N]
        [--workers K] [--batches B,B,...] [--seed S]

Evaluates the first N designs of an optimisation history (default: the 50 seed designs
of docs/cases/case1-history.csv, Case 1's space-filling start, of which most are decided
infeasible by their third failure) as the optimiser does: the Case's sequential rule
(N_MC = 100, C_P = 0.98, stop when decided), fresh results files, on a warm process pool of
K workers, once per batch size (a fixed number of samples per batch, e.g. 16 = 2 x 8, the
default before this benchmark; 0: the default now, as many as the rule expects its
decision to take, between one per lane of every worker and 8 per worker).  Every batch
size gives the same successes and samples for every design (checked: the designs that
differ are printed and the exit status is 1); what changes is the samples drawn past each
decision, the CPU time they cost and the wall time.  Prints, per batch size: episodes
drawn, decisive samples, CPU-s, wall s, and the ratios to the first.
"""
from __future__ import annotations

import argparse
import csv
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--history", default=os.path.join(ROOT, "docs/cases/case1-history.csv"))
    ap.add_argument("--designs", type=int, default=50, help="first N designs (default 50)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--batches", default="16,0",
                    help="batch sizes, comma-separated; 0: the default rule (16,0)")
    ap.add_argument("--seed", type=int, default=1, help="base seed of the samples (default 1)")
    args = ap.parse_args(argv)

    from optimizer.sequential import SequentialRule
    from tethernet_ros import montecarlo as mc
    from tethernet_ros.core.design import Design
    from tethernet_ros.core.noise import NoiseModel
    from tethernet_ros.core.config import SimConfig

    names = ("m_c", "L_n", "r_n", "d_L", "V_x", "V_y", "V_z", "d_c")
    with open(args.history) as f:
        rows = list(csv.DictReader(f))[: args.designs]
    designs = [Design.from_vector([float(r[k]) for k in names]) for r in rows]
    rule = SequentialRule(100, 0.98)
    batches = [int(b) for b in args.batches.split(",")]
    print(f"sequential sampling: {len(designs)} designs of {args.history}, {args.workers} "
          f"workers, base seed {args.seed}; load average "
          f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}")
    out, verdicts = [], {}
    with mc.ProcessPoolBackend(args.workers) as be:
        be.start()
        print(f"default rule: {be.batch_size} to {be.max_batch_size} samples per batch")
        for b in batches:
            with tempfile.TemporaryDirectory() as tmp:
                path = os.path.join(tmp, "samples.jsonl")
                t0 = time.perf_counter()
                decisive, results = 0, []
                for d in designs:
                    r = mc.evaluate(d, 100, args.seed, NoiseModel(), SimConfig(), be, stop=rule,
                                    results_path=path, batch_size=b or None)
                    decisive += r.n_samples
                    results.append((r.successes, r.n_samples))
                wall = time.perf_counter() - t0
                drawn = cpu = 0
                for _raw, rec in mc.ResultsFile(path).records():
                    drawn += 1
                    cpu += rec.cpu_time or 0.0
            verdicts[b] = results
            label = f"{b:3d} per batch" if b else "default rule"
            out.append((label, drawn, decisive, cpu, wall))
            print(f"  {label}: {drawn:5d} episodes drawn for {decisive} decisive, "
                  f"{cpu:8.1f} CPU-s, {wall:8.1f} s wall", flush=True)
    first = out[0]
    print("ratios to the first batch size (episodes, CPU, wall):")
    for label, drawn, _, cpu, wall in out:
        print(f"  {label}: {drawn / first[1]:.3f}  {cpu / first[3]:.3f}  {wall / first[4]:.3f}")
    ref = verdicts[batches[0]]
    differ = [i + 1 for b in batches for i, (v, r) in enumerate(zip(verdicts[b], ref)) if v != r]
    print("every batch size gave the same successes and samples per design:", not differ)
    if differ:
        print("designs that differ (history rows):", sorted(set(differ)))
    return 1 if differ else 0


if __name__ == "__main__":
    raise SystemExit(main())
