"""`tethernet sensitivity`: P*_s of a design while one noise source's spread is scaled.

Each (source, scale) point is a Monte Carlo run of the same samples (common random
numbers: the same seeds, hence the same underlying random numbers, at every scale and for
every source); the other sources keep their nominal spread.  Scale 1 is the same run for
every source and is simulated once.  All points go to the workers as one batch.  Writes
``<out>/sensitivity_<design>.csv`` and ``.png``; per-sample results go to a results file
(default ``out/montecarlo/<design>_sensitivity_seed<BASE>.jsonl``) so that a killed study
resumes.
"""
from __future__ import annotations

import csv
import time
from pathlib import Path

from ..core.noise import NOISE_SOURCES, check_scale
from .common import controller_label, noise_model_from_args, print_json
from .validate import (Progress, add_run_arguments, backend_from_args, check_run_arguments,
                       default_results_path, design_label, run_config)

NAME = "sensitivity"
HELP = "P*_s of a design against the scale of one noise source at a time (CSV and PNG)"

DEFAULT_SOURCES = ("speed", "polar", "distance", "closing")
CSV_COLUMNS = ("source", "scale", "samples", "successes", "p_success", "ci_low", "ci_high",
               "cp_low", "cp_high", "mean_completion_time", "failures_by_reason")


def add_arguments(p):
    p.add_argument("--design", required=True, metavar="NAME|FILE.yaml",
                   help="reference design (baseline, suboptimal, mass-min, time-min) or a YAML file")
    p.add_argument("--scales", default="0.1,0.2,0.5,1,2,5,10", metavar="LIST",
                   help="comma-separated scale factors of a source's spread, each in [0, 100] "
                        "(default 0.1,0.2,0.5,1,2,5,10)")
    p.add_argument("--sources", default=",".join(DEFAULT_SOURCES), metavar="LIST",
                   help=f"noise sources to vary, from {', '.join(NOISE_SOURCES)} "
                        f"(default {','.join(DEFAULT_SOURCES)})")
    add_run_arguments(p, default_samples=100)
    p.add_argument("--out", default="out/sensitivity", metavar="DIR",
                   help="folder of the CSV and PNG (default out/sensitivity)")
    p.add_argument("--json", action="store_true", help="also print the rows as JSON")


def parse_list(text: str, what: str, conv):
    from ..errors import UserError

    items = [t.strip() for t in text.split(",") if t.strip()]
    if not items:
        raise UserError(f"--{what}: empty list")
    out = []
    for t in items:
        try:
            out.append(conv(t))
        except ValueError as exc:
            raise UserError(f"--{what} {t!r}: {exc}") from None
    return out


def _scale(t: str) -> float:
    return check_scale(float(t), "a scale factor")


def _source(t: str) -> str:
    if t not in NOISE_SOURCES:
        raise ValueError(f"unknown noise source; allowed {list(NOISE_SOURCES)}")
    return t


def run(args) -> int:
    from .common import read_design_file
    from ..figures.sensitivity import plot_sensitivity
    from ..montecarlo import RunSpec, evaluate_many

    check_run_arguments(args)
    scales = parse_list(args.scales, "scales", _scale)
    sources = parse_list(args.sources, "sources", _source)
    design = read_design_file(args.design)[0]
    label = design_label(args.design)
    base = noise_model_from_args(args)
    config = run_config(args)
    points = [(src, s) for src in sources for s in scales]
    specs = [RunSpec(design, base.with_scales(**{src: s}), config, f"{label} {src}x{s:g}")
             for src, s in points]
    results_path = Path(args.results) if args.results else \
        default_results_path(label, args.seed, "_sensitivity" + controller_label(args))
    backend = backend_from_args(args)
    bar = Progress(f"{label} sensitivity", args.no_progress)
    t0 = time.perf_counter()
    try:
        results = evaluate_many(specs, args.samples, args.seed, backend, results_path=results_path,
                                resume=not args.fresh, progress=bar)
    finally:
        bar.close()
        backend.close()
    wall = time.perf_counter() - t0

    rows = []
    for (src, s), r in zip(points, results):
        rows.append({"source": src, "scale": s, "samples": r.n_samples, "successes": r.successes,
                     "p_success": r.p_success, "ci_low": r.ci_low, "ci_high": r.ci_high,
                     "cp_low": r.cp_low, "cp_high": r.cp_high,
                     "mean_completion_time": r.mean_completion_time,
                     "failures_by_reason": "; ".join(f"{k}: {v}" for k, v in r.failures_by_reason.items())})
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / f"sensitivity_{label}.csv"
    with csv_path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=CSV_COLUMNS)
        w.writeheader()
        for row in rows:
            w.writerow({k: (repr(v) if isinstance(v, float) else v) for k, v in row.items()})
    png = plot_sensitivity(rows, csv_path.with_suffix(".png"),
                           title=f"{label}: noise sensitivity of P*_s")
    if args.json:
        print_json(rows)
    else:
        print(f"noise sensitivity of {label}: {args.samples} samples per point, base seed {args.seed}")
        print(f"{'source':10s} " + " ".join(f"{s:>7g}" for s in scales))
        for src in sources:
            ps = [row["p_success"] for row in rows if row["source"] == src]
            print(f"{src:10s} " + " ".join(f"{p:7.3f}" for p in ps))
        print(f"  CSV           {csv_path}\n  figure        {png}\n  results file  {results_path}"
              f"\n  wall time     {wall:.1f} s ({backend.describe()})")
    return 0
