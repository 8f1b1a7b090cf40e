"""Paired statistics of two results files over the samples both hold (common random
numbers): each file's P*_s with its Wilson 95 % interval and mean T, the flips, McNemar's
exact p and whether the difference is within the smaller half-width (the criterion of
docs/studies/step.md), and the CPU time per episode.  Used for docs/studies/fidelity.md.

    .venv/bin/python scripts/pair_results.py A.jsonl B.jsonl [--label-a ref --label-b s8]
"""
from __future__ import annotations

import argparse
import math
import sys

from tethernet_ros.studies.files import samples_by_seed
from tethernet_ros.studies.paired import CellStats, PairedStats


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("a")
    p.add_argument("b")
    p.add_argument("--label-a", default="a")
    p.add_argument("--label-b", default="b")
    args = p.parse_args(argv)
    a, b = samples_by_seed(args.a), samples_by_seed(args.b)
    seeds = sorted(set(a) & set(b))
    if not seeds:
        print("the files share no sample seed", file=sys.stderr)
        return 2
    sa, sb = [a[s] for s in seeds], [b[s] for s in seeds]
    ca = CellStats.from_samples(args.label_a, args.a, sa)
    cb = CellStats.from_samples(args.label_b, args.b, sb)
    pair = PairedStats.from_samples(ca, cb, sa, sb)

    def cpu(samples):
        xs = [s.cpu_time for s in samples if math.isfinite(s.cpu_time) and s.cpu_time > 0]
        return sum(xs) / len(xs) if xs else math.nan

    print(f"N = {len(seeds)}")
    for c, s in ((ca, sa), (cb, sb)):
        print(f"{c.label}: P*_s {100 * c.p:.1f} [{100 * c.lo:.1f}, {100 * c.hi:.1f}] %, mean T "
              f"{c.mean_t:.3f} s, CPU {cpu(s):.3f} s per episode")
    print(f"{args.label_b} - {args.label_a}: {100 * pair.p_diff:+.1f} pts, smaller half-width "
          f"{100 * min(ca.half_width, cb.half_width):.1f} pts, within: "
          f"{'yes' if pair.within_half_width else 'no'}; flips {pair.flips} "
          f"({pair.a_only} {args.label_a} only / {pair.b_only} {args.label_b} only), McNemar p "
          f"{pair.mcnemar_p:.2g}; mean T {args.label_b} / {args.label_a} - 1 = "
          f"{100 * pair.t_rel_diff:+.3f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
