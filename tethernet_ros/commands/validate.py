"""`tethernet validate`: Monte Carlo reliability of a design (P*_s, mean T, failures).

Prints a row of the docs/model.md §12 results table per design; ``--reference`` runs the four
reference designs.  Every finished sample is appended to a results file (default
``out/montecarlo/<design>_seed<BASE>.jsonl``), so an interrupted run resumes when it is
run again and a finished one is read back instead of simulated (``--fresh`` ignores it).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from ..core.design import REFERENCE_DESIGNS
from ..core.fidelity import REFERENCE, fidelity_text
from .common import (add_backend_arguments, add_config_argument, add_fidelity_argument,
                     add_noise_arguments, add_ros_arguments, backend_from_args,
                     check_backend_arguments, check_ros_arguments, config_from_args,
                     controller_config, controller_label, fidelity_config,
                     noise_model_from_args, print_json, read_design_file)

NAME = "validate"
HELP = "Monte Carlo validation of a design: P*_s with a 95 % interval, mean T, failures"


def add_arguments(p):
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--design", metavar="NAME|FILE.yaml",
                   help="reference design (baseline, suboptimal, mass-min, time-min) or a YAML "
                        "file with keys m_c, L_n, r_n, d_L, V_e, d_c")
    g.add_argument("--reference", action="store_true", help="all four reference designs")
    add_run_arguments(p, default_samples=1000)
    add_fidelity_argument(p)
    p.add_argument("--json", action="store_true", help="print JSON (one object, or a list with --reference)")
    p.add_argument("--per-sample", action="store_true", help="with --json: include every sample's result")


def add_run_arguments(p, default_samples: int) -> None:
    """Options shared by the Monte Carlo commands (validate, sensitivity, figures cqi)."""
    p.add_argument("--samples", type=int, default=default_samples, metavar="N",
                   help=f"Monte Carlo samples per design (default {default_samples})")
    p.add_argument("--seed", type=int, default=0, metavar="BASE",
                   help="base seed: sample i uses noise seed BASE*1000003+i (default 0)")
    add_backend_arguments(p)
    add_ros_arguments(p)
    p.add_argument("--results", default=None, metavar="FILE.jsonl",
                   help="per-sample results file to append to and resume from "
                        "(default out/montecarlo/<design>_seed<BASE>.jsonl)")
    p.add_argument("--fresh", action="store_true",
                   help="ignore results already in the results file (simulate every sample)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_noise_arguments(p)
    add_config_argument(p)
    # advanced / test settings (not in --help)
    p.add_argument("--settle-time", type=float, default=None, help=argparse.SUPPRESS)
    p.add_argument("--horizon", type=float, default=None, help=argparse.SUPPRESS)


def check_run_arguments(args) -> None:
    from ..errors import UserError

    if args.samples is None or args.samples < 1:
        raise UserError(f"--samples {args.samples}: must be an integer >= 1")
    if args.seed < 0:
        raise UserError(f"--seed {args.seed}: must be an integer >= 0")
    check_backend_arguments(args)
    check_ros_arguments(args)


def run_config(args, **extra):
    over = dict(extra)
    if args.settle_time is not None:
        over["settle_time"] = args.settle_time
    if args.horizon is not None:
        over["horizon"] = args.horizon
    return controller_config(args, config_from_args(args, **over))


def design_label(name_or_path: str) -> str:
    return name_or_path if name_or_path in REFERENCE_DESIGNS else Path(name_or_path).stem


def default_results_path(label: str, seed: int, suffix: str = "") -> Path:
    return Path("out") / "montecarlo" / f"{label}{suffix}_seed{seed}.jsonl"


class Progress:
    """tqdm bar on stderr with ETA, fed by the evaluator's progress callback."""

    def __init__(self, desc: str, disable: bool):
        self.desc = desc
        self.disable = disable
        self.bar = None

    def __call__(self, done, total, result):
        if self.disable:
            return
        if self.bar is None:
            from tqdm import tqdm

            self.bar = tqdm(total=total, initial=done, desc=self.desc, unit="ep", file=sys.stderr,
                            dynamic_ncols=True, smoothing=0.1)
            return
        self.bar.update(done - self.bar.n)
        if result is not None and not result.success:
            self.bar.set_postfix_str(result.category[:30], refresh=False)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def run(args) -> int:
    from ..montecarlo import RunSpec, evaluate_many
    from ..montecarlo.results_file import ResultsFile

    check_run_arguments(args)
    model = noise_model_from_args(args)
    # --fidelity exploration: another config, so its samples have run keys of their own
    # and are never mixed with the reference's in a results file
    config = fidelity_config(args, run_config(args))
    if args.reference:
        labels = list(REFERENCE_DESIGNS)
        designs = [REFERENCE_DESIGNS[k] for k in labels]
    else:
        designs = [read_design_file(args.design)[0]]
        labels = [design_label(args.design)]
    specs = [RunSpec(d, model, config, lab) for d, lab in zip(designs, labels)]
    if args.results:
        paths = {lab: Path(args.results) for lab in labels}
    else:
        paths = {lab: default_results_path(lab, args.seed, controller_label(args))
                 for lab in labels}

    backend = backend_from_args(args)
    results = []
    t0 = time.perf_counter()
    try:
        # one batch per results file (a shared --results file: one batch for all designs)
        groups: dict[Path, list] = {}
        for spec in specs:
            groups.setdefault(paths[spec.label], []).append(spec)
        by_label = {}
        for path, group in groups.items():
            desc = group[0].label if len(group) == 1 else f"{len(group)} designs"
            bar = Progress(desc, args.no_progress)
            try:
                for r in evaluate_many(group, args.samples, args.seed, backend, results_path=path,
                                       resume=not args.fresh, progress=bar):
                    by_label[r.label] = (r, path)
            finally:
                bar.close()
        results = [by_label[lab] for lab in labels]
    finally:
        backend.close()
    wall = time.perf_counter() - t0

    spun = not config.tumble.at_rest
    design_by_label = dict(zip(labels, designs))
    if args.json:
        out = []
        for r, path in results:
            d = r.to_dict(with_samples=args.per_sample)
            d["results_file"] = str(path)
            d["fidelity"] = args.fidelity
            if spun:
                d["by_attitude"] = by_attitude(r, design_by_label[r.label], config, model)
                d["by_attitude_at_closing"] = by_attitude(r, design_by_label[r.label], config,
                                                          model, at="closing")
            d["machines"] = ResultsFile(path).machine_counts({r.key})
            out.append(d)
        print_json(out if args.reference else out[0])
        return 0
    print(results_table([r for r, _ in results]))
    from ..studies.tug import criterion_text

    held = [t for t in (criterion_text(r.label, r.samples) for r, _ in results) if t]
    if held:
        print("\n" + "\n".join(held))
    if spun:
        print("\n" + attitude_text(results, design_by_label, config, model))
    errs = sum(r.failures_by_reason.get("worker error", 0) for r, _ in results)
    files = sorted({str(p) for _, p in results})
    reused = sum(r.reused for r, _ in results)
    print(f"\n{args.samples} samples per design, base seed {args.seed}, "
          f"{backend.describe()}, {wall:.1f} s wall"
          + (f" ({reused} samples read back from the results file)" if reused else ""))
    print("P*_s interval: Wilson 95 %; mean T over all samples (closing never triggered: T = horizon)")
    if args.fidelity != REFERENCE:
        print(f"fidelity {fidelity_text(args.fidelity, config)}: not a reference-fidelity result "
              "(docs/studies/step.md; docs/model.md, fidelities)")
    print("results file" + ("s" if len(files) > 1 else "") + ": " + ", ".join(files))
    for f in files:
        line = ResultsFile(f).machine_summary({r.key for r, p in results if str(p) == f})
        if line:
            print(line)
    if errs:
        print(f"WARNING: {errs} sample(s) failed with a worker error (see the results file)",
              file=sys.stderr)
    return 0


def fmt(v, digits=2):
    return "n/a" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.{digits}f}"


def failures_text(r) -> str:
    if not r.failures_by_reason:
        return "-"
    return ", ".join(f"{k}: {v}" for k, v in r.failures_by_reason.items())


def results_table(results) -> str:
    """Rows like the results table of docs/model.md §12: design, m_a, mean T, P*_s [CI], N, failures."""
    head = ["design", "m_a (kg)", "mean T (s)", "P*_s [95% CI]", "N", "failures"]
    rows = [[r.label, fmt(r.mass), fmt(r.mean_completion_time),
             f"{fmt(r.p_success, 3)} [{fmt(r.ci_low, 3)}, {fmt(r.ci_high, 3)}]",
             str(r.n_samples), failures_text(r)] for r in results]
    widths = [max(len(h), *(len(row[i]) for row in rows)) for i, h in enumerate(head)]
    right = {1, 2, 4}

    def line(cells):
        return "  ".join(c.rjust(w) if i in right else c.ljust(w)
                         for i, (c, w) in enumerate(zip(cells, widths))).rstrip()

    return "\n".join([line(head), line(["-" * w for w in widths])] + [line(r) for r in rows])


def by_attitude(result, design, config, model, at: str = "launch") -> list[dict]:
    """A tumbling run's successes per bin of |a_z| (the cosine between the stage's long
    axis and the line of sight, ``montecarlo.attitude.long_axis_los``) at launch, or at each
    sample's closing time (``at="closing"``, the stage turned free of torque; a last
    entry, a_z None, for the samples whose closing never started)."""
    from ..montecarlo.attitude import ATTITUDE_BINS, attitude_counts, closing_attitude_counts

    if at == "closing":
        ok, n = closing_attitude_counts(design, config, model,
                                        ((s.seed, s.success, float(s.closing_time))
                                         for s in result.samples))
    else:
        ok, n = attitude_counts(design, config, model,
                                ((s.seed, s.success) for s in result.samples))
    k = len(ATTITUDE_BINS) - 1
    return [{"a_z_from": ATTITUDE_BINS[j] if j < k else None,
             "a_z_to": ATTITUDE_BINS[j + 1] if j < k else None,
             "samples": n[j], "successes": ok[j]} for j in range(len(n))]


def attitude_text(results, design_by_label: dict, config, model) -> str:
    """Markdown: each design's successes per bin of |a_z| at launch, then at closing."""
    from ..montecarlo.attitude import attitude_heads

    out = []
    for at, heads, what in (
            ("launch", attitude_heads(), "at launch (a_z: |cos| of the angle between its long "
                                         "axis and the line of sight; 1: end-on)"),
            ("closing", attitude_heads() + ["closing never started"],
             "at closing (turned free of torque from launch to the sample's closing time)")):
        rows = []
        for r, _path in results:
            bins = by_attitude(r, design_by_label[r.label], config, model, at)
            rows.append(f"| {r.label} | " + " | ".join(f"{b['successes']}/{b['samples']}"
                                                       for b in bins) + " |")
        out.append(f"successes by the stage's attitude {what}\n\n| design | "
                   + " | ".join(heads) + " |\n|---|" + "---|" * len(heads) + "\n"
                   + "\n".join(rows))
    return "\n\n".join(out)
