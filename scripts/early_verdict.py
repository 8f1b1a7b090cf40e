"""Would an earlier verdict do for the search?  The success rule read s seconds after
closing starts (s < the 20 s settle time) against the rule at 20 s, on the same episodes:
each design's samples are simulated once, at the reference fidelity and at exploration,
with their CQI / n_L trace (10 Hz), and the verdict at s is read from the trace sample
nearest closing + s.  Used for docs/studies/fidelity.md ("An earlier verdict").

    .venv/bin/python scripts/early_verdict.py OUT_DIR DESIGN [DESIGN ...] [--samples 100]

DESIGN: a reference design's name or a design YAML (its stem names its files).  Results
files OUT_DIR/<stem>_<fidelity>.jsonl are resumed; the table goes to standard output.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import load_design
from tethernet_ros.core.fidelity import FIDELITIES, at_fidelity
from tethernet_ros.core.metrics import cqi_fails, pairs_fail
from tethernet_ros.montecarlo.evaluate import evaluate
from tethernet_ros.montecarlo.process_pool import ProcessPoolBackend
from tethernet_ros.montecarlo.records import SampleResult
from tethernet_ros.studies.files import samples_by_seed
from tethernet_ros.studies.paired import mcnemar_p

#: the reading times compared with the settle time's verdict (s after closing starts)
READ_AT = (6.0, 8.0, 10.0, 12.0, 15.0)
#: half the trace's 0.1 s interval, and round-off
NEAREST = 0.051


def verdict_at(sample: SampleResult, s: float, config: SimConfig) -> bool:
    """The success rule on the trace sample nearest ``s`` s after closing starts: a failure
    when closing never started or the episode diverged by then.  ValueError when the trace
    holds no sample within half its interval of that time."""
    if not math.isfinite(sample.closing_time):
        return False
    t = sample.closing_time + s
    if sample.category == "diverged" and sample.completion_time <= t:
        return False
    times = sample.trace["time"]
    k = min(range(len(times)), key=lambda i: abs(times[i] - t))
    if abs(times[k] - t) > NEAREST:
        raise ValueError(f"sample {sample.seed}: no trace sample within {NEAREST} s of {t:.3f} s")
    return not (cqi_fails(sample.trace["cqi"][k], config.success_cqi)
                or pairs_fail(sample.trace["locked_pairs"][k], config.success_locked_pairs))


def compare(truth: dict[int, SampleResult], early: dict[int, SampleResult], s: float,
            config: SimConfig) -> tuple[int, int, int, float]:
    """(samples, captures lost, captures gained, McNemar's exact p) of the verdict at ``s``
    in ``early`` against the settle time's verdict in ``truth``, over their common seeds."""
    seeds = sorted(set(truth) & set(early))
    lost = gained = 0
    for seed in seeds:
        want, got = truth[seed].success, verdict_at(early[seed], s, config)
        lost += want and not got
        gained += got and not want
    return len(seeds), lost, gained, mcnemar_p(lost, gained)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out_dir", type=Path)
    p.add_argument("designs", nargs="+")
    p.add_argument("--samples", type=int, default=100)
    p.add_argument("--workers", type=int, default=2)
    args = p.parse_args(argv)
    args.out_dir.mkdir(parents=True, exist_ok=True)
    config = SimConfig()
    backend = ProcessPoolBackend(args.workers)
    try:
        for name in args.designs:
            design = load_design(name)
            for fid in FIDELITIES:
                evaluate(design, args.samples, 0, config=at_fidelity(config, fid),
                         backend=backend, record_trace=True,
                         results_path=args.out_dir / f"{Path(name).stem}_{fid}.jsonl")
    finally:
        backend.close()
    for fid in FIDELITIES:
        print(f"\nverdict read at s, simulated at {fid}, against the reference at "
              f"{config.settle_time:g} s: difference in captures (lost / gained), McNemar p")
        print("| design | N | captures at 20 s | "
              + " | ".join(f"s = {s:g} s" for s in READ_AT) + " |")
        print("|---" * (3 + len(READ_AT)) + "|")
        total = {s: [0, 0] for s in READ_AT}
        for name in args.designs:
            stem = Path(name).stem
            truth = samples_by_seed(args.out_dir / f"{stem}_{FIDELITIES[0]}.jsonl")
            early = samples_by_seed(args.out_dir / f"{stem}_{fid}.jsonl")
            cells = []
            for s in READ_AT:
                n, lost, gained, pv = compare(truth, early, s, config)
                total[s][0] += lost
                total[s][1] += gained
                cells.append(f"{gained - lost:+d} ({lost} / {gained}), {pv:.2g}")
            print(f"| {stem} | {n} | {sum(r.success for r in truth.values())} | "
                  + " | ".join(cells) + " |")
        cells = []
        for lost, gained in total.values():
            cells.append(f"{gained - lost:+d} ({lost} / {gained}), {mcnemar_p(lost, gained):.2g}")
        print("| all | | | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
