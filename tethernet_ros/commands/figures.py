"""`tethernet figures`: the PNG figures of docs/model.md §12, one subcommand each.

  cqi          CQI over time of every Monte Carlo sample (grey) and the mean (black)
  snapshots    one capture at four moments, in 3D with the target
  sensitivity  re-plot a `tethernet sensitivity` CSV
"""
from __future__ import annotations

import argparse
import csv
from pathlib import Path

from .common import (add_config_argument, add_noise_arguments, config_from_args,
                     controller_label, noise_model_from_args)
from .validate import (Progress, add_run_arguments, backend_from_args, check_run_arguments,
                       default_results_path, design_label, run_config)

NAME = "figures"
HELP = "PNG figures: CQI traces of a Monte Carlo run, capture snapshots, noise sensitivity"


def _design_arg(p):
    p.add_argument("--design", required=True, metavar="NAME|FILE.yaml",
                   help="reference design (baseline, suboptimal, mass-min, time-min) or a YAML file")


def add_arguments(p):
    sub = p.add_subparsers(dest="figure", metavar="FIGURE")
    sub.required = True
    c = sub.add_parser("cqi", help="CQI over time of every Monte Carlo sample (grey) and the mean (black)")
    _design_arg(c)
    add_run_arguments(c, default_samples=100)
    c.add_argument("--out", default=None, metavar="PATH.png",
                   help="figure path (default out/figures/cqi_<design>.png)")

    s = sub.add_parser("snapshots", help="one capture at four moments in 3D: net fully released, "
                                         "maximum mouth opening, first wrapping, capture settled")
    _design_arg(s)
    g = s.add_mutually_exclusive_group()
    g.add_argument("--seed", type=int, default=None, metavar="N",
                   help="noise sample seed (default: the nominal, noise-free capture)")
    g.add_argument("--nominal", action="store_true", help="no noise (the default)")
    s.add_argument("--state-rate", type=float, default=10.0, metavar="HZ",
                   help="rate of the recorded node positions the moments are picked from (default 10)")
    add_noise_arguments(s)
    add_config_argument(s)
    s.add_argument("--settle-time", type=float, default=None, help=argparse.SUPPRESS)
    s.add_argument("--out", default=None, metavar="PATH.png",
                   help="figure path (default out/figures/snapshots_<design>_<seed>.png)")

    v = sub.add_parser("sensitivity", help="plot P*_s against noise scale from a sensitivity CSV")
    v.add_argument("--csv", required=True, metavar="FILE.csv", help="written by `tethernet sensitivity`")
    v.add_argument("--out", default=None, metavar="PATH.png", help="figure path (default: next to the CSV)")
    v.add_argument("--title", default="", help="figure title")


def run(args) -> int:
    return {"cqi": run_cqi, "snapshots": run_snapshots, "sensitivity": run_sensitivity}[args.figure](args)


def run_cqi(args) -> int:
    from .common import read_design_file
    from ..figures.montecarlo import plot_cqi_traces
    from ..montecarlo import evaluate

    check_run_arguments(args)
    design = read_design_file(args.design)[0]
    label = design_label(args.design)
    config = run_config(args)
    results = Path(args.results) if args.results else default_results_path(label, args.seed, controller_label(args))
    backend = backend_from_args(args)
    bar = Progress(label, args.no_progress)
    try:
        r = evaluate(design, args.samples, args.seed, noise_model_from_args(args), config, backend,
                     results_path=results, record_trace=True, label=label,
                     resume=not args.fresh, progress=bar)
    finally:
        bar.close()
        backend.close()
    out = Path(args.out) if args.out else Path("out") / "figures" / f"cqi_{label}.png"
    plot_cqi_traces(r, out, title=f"{label}: CQI of every sample", success_cqi=config.success_cqi)
    print(f"CQI traces of {label}: {r.n_samples} samples, P*_s = {r.p_success:.3f} "
          f"[{r.ci_low:.3f}, {r.ci_high:.3f}]")
    print(f"  figure        {out}")
    print(f"  results file  {results}")
    return 0


def run_snapshots(args) -> int:
    from ..errors import UserError
    from .common import read_design_file
    from ..core.episode import run_episode
    from ..core.scenario import scenario_for
    from ..figures.snapshots import plot_snapshots

    if args.seed is not None and args.seed < 0:
        raise UserError(f"--seed {args.seed}: must be an integer >= 0")
    if not args.state_rate > 0:
        raise UserError(f"--state-rate {args.state_rate}: must be > 0 Hz")
    design = read_design_file(args.design)[0]
    label = design_label(args.design)
    over = {"state_rate": args.state_rate}
    if args.settle_time is not None:
        over["settle_time"] = args.settle_time
    config = config_from_args(args, **over)
    model = noise_model_from_args(args)
    sample = None if args.seed is None else model.sample(args.seed)
    result = run_episode(design, sample, config, record_trace=True)
    seed_label = "nominal" if args.seed is None else f"seed{args.seed}"
    out = Path(args.out) if args.out else Path("out") / "figures" / f"snapshots_{label}_{seed_label}.png"
    _, moments = plot_snapshots(result, scenario_for(design, sample, config), out,
                                title=f"{label}, {seed_label}")
    print(f"snapshots of {label} ({seed_label}): {'SUCCESS' if result.success else 'FAILURE'}")
    for m in moments:
        print(f"  {m.name:22s} t = {m.time:6.2f} s" + ("" if m.reached else "  (not reached)")
              + (f"  {m.note}" if m.note else ""))
    print(f"  figure        {out}")
    return 0


def run_sensitivity(args) -> int:
    from ..errors import UserError
    from ..figures.sensitivity import plot_sensitivity

    path = Path(args.csv)
    if not path.is_file():
        raise UserError(f"--csv: file {str(path)!r} does not exist")
    with path.open(newline="") as f:
        rows = list(csv.DictReader(f))
    need = {"source", "scale", "p_success", "ci_low", "ci_high"}
    if not rows or not need <= set(rows[0]):
        raise UserError(f"--csv: {str(path)!r} needs the columns {sorted(need)}")
    out = Path(args.out) if args.out else path.with_suffix(".png")
    plot_sensitivity(rows, out, title=args.title)
    print(f"  figure        {out}")
    return 0
