"""`tethernet optimize`: reliability-constrained Bayesian optimisation (docs/optimizer.md).

Case 1 (``--case mass``): minimise m_a s.t. P*_s >= 0.98.  Case 2 (``--case time``):
minimise mean T s.t. P*_s >= 0.98 and m_a <= 15 kg.  Every evaluation is checkpointed in
the run directory (``--resume`` continues a killed run); the best feasible design is then
validated with fresh samples and the results table (results.md / results.csv) and the
convergence history (convergence.png) are written next to the checkpoint.  A design's
sampling stops as soon as its feasibility at --samples is decided (--full-sampling: never).
See :mod:`optimizer.run` for the files, the seeds and the sampling, and
:mod:`tethernet_ros.design_problem` for the simulator behind the optimiser.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from optimizer.settings import (EXPLORING_PHASES, NEW_RUN_DEFAULTS, SELECTION_LEVELS,
                                RunSettings, SettingError)

from ..core.fidelity import FIDELITIES, REFERENCE

from .common import (add_backend_arguments, add_config_argument, add_noise_arguments,
                     add_ros_arguments, backend_from_args, check_backend_arguments,
                     check_ros_arguments, config_from_args, controller_config,
                     noise_model_from_args, print_json)

NAME = "optimize"
HELP = ("Bayesian optimisation of the net design and actions: Case 1 (--case mass) or "
        "Case 2 (--case time), with checkpoints, validation and a results table")


def add_arguments(p):
    p.add_argument("--case", default=None, choices=("mass", "time"),
                   help="mass: minimise m_a s.t. P*_s >= 0.98 (Case 1); time: minimise mean T "
                        "s.t. P*_s >= 0.98 and m_a <= 15 kg (Case 2)")
    d = RunSettings()       # the defaults' one home: optimizer/settings.py
    p.add_argument("--iterations", type=int, default=d.iterations, metavar="N",
                   help=f"model-based iterations after the seed points (default {d.iterations})")
    p.add_argument("--seed-points", type=int, default=d.seed_points, metavar="K",
                   help=f"space-filling seed designs (default {d.seed_points})")
    p.add_argument("--samples", type=int, default=d.samples, metavar="M",
                   help="Monte Carlo samples per design during optimisation (default "
                        f"{d.samples})")
    p.add_argument("--validation-samples", type=int, default=d.validation_samples, metavar="V",
                   help="fresh samples to validate the best design with (default "
                        f"{d.validation_samples}; 0: none)")
    p.add_argument("--validation-candidates", type=int, default=d.validation_candidates,
                   metavar="K",
                   help="validate the ranked designs in turn until one meets P*_s >= 0.98, at "
                        "most K of them, ranking again after each failure with its validation "
                        "in the constraint GP's data (default: "
                        f"{NEW_RUN_DEFAULTS['validation_candidates']} for a new run, as "
                        "recorded for a resumed one; may change on --resume, which then "
                        "validates a finished run's further candidates)")
    p.add_argument("--validation-rule", choices=("estimate", "wilson"),
                   default=d.validation_rule,
                   help="how a validation meets P*_s >= 0.98: by the lower end of its Wilson "
                        "95 %% interval (wilson: 989 of 1000) or by its estimate (estimate: "
                        "980 of 1000, the source's test).  Default: wilson for a new run; on "
                        "--resume, as the run recorded it (estimate for runs that predate "
                        "the option); may change on --resume")
    p.add_argument("--validation-stop", action=argparse.BooleanOptionalAction, default=None,
                   help="end a validation at the failure that decides it misses 0.98 (e.g. "
                        "the 21st of 1000; the chosen design always gets every sample). "
                        "Default: on for a new run; on --resume, as the run recorded it (off "
                        "for runs that predate it)")
    p.add_argument("--racing-candidates", type=int, default=d.racing_candidates, metavar="K",
                   help="before validating, race the first K ranked designs on fresh samples "
                        "in rounds, dropping one once its Wilson 95 %% upper bound falls "
                        "below 0.98, until the lightest left clears 0.98 with its lower "
                        "bound or the budget is spent; the validations then skip the dropped "
                        f"ones.  Default: {NEW_RUN_DEFAULTS['racing_candidates']} for a new "
                        "run; on --resume, as the run recorded it (0 for runs that predate "
                        "it); 0: no racing")
    p.add_argument("--racing-round", type=int, default=d.racing_round, metavar="R",
                   help=f"racing samples per candidate and round (default {d.racing_round})")
    p.add_argument("--racing-budget", type=int, default=d.racing_budget, metavar="B",
                   help=f"racing samples in all, at most (default {d.racing_budget})")
    p.add_argument("--racing-seed", type=int, default=d.racing_seed, metavar="S",
                   help=f"base seed of the racing samples (default {d.racing_seed})")
    p.add_argument("--racing-max-samples", type=int, default=d.racing_max_samples,
                   metavar="M",
                   help="racing samples of one candidate, at most, after which it is left "
                        "undecided (default 0: --validation-samples)")
    p.add_argument("--selection-level", choices=SELECTION_LEVELS, default=d.selection_level,
                   help="what the final ranking and the race take the posterior probability "
                        "and the clearing against: 'requirement' (P*_s >= 0.98) or "
                        "'validation' (the P*_s at which the validation passes half the time, "
                        f"0.9884 for 1000 samples by the Wilson rule; default "
                        f"{d.selection_level}; may change on --resume)")
    p.add_argument("--explore-fidelity", choices=FIDELITIES, default=REFERENCE,
                   help="the fidelity of the seed points and the iterations: reference (the "
                        "configuration as given, the default) or exploration (the implicit "
                        "step at 2 ms with 8 sweeps and the early call, at 0.39-0.61 of the "
                        "CPU time; its P*_s "
                        "matched the reference's on the Cases' designs and the reference "
                        "designs: docs/studies/fidelity.md).  Racing and validation always "
                        "run at the reference, so every result the run reports is a "
                        "reference-fidelity one.  Recorded in run.json; --resume needs the "
                        "same")
    p.add_argument("--fresh-samples", action=argparse.BooleanOptionalAction, default=None,
                   help="give every design samples of its own instead of the same samples "
                        "for all (common random numbers), so that the feasibility model's "
                        "observations are independent (then --shared-luck has nothing to "
                        "do).  Default for a new run: on for --case mass (exact objective), "
                        "off for --case time (common samples compare mean T); on --resume, "
                        "as the run recorded it")
    p.add_argument("--shared-luck", action=argparse.BooleanOptionalAction, default=None,
                   help="with common random numbers (--case time's default), let the feasibility "
                        "model take the luck that all designs share on the same samples into "
                        "account instead of taking their estimates as independent.  Default "
                        "for a new run: on; on --resume, as the run recorded it (off for runs "
                        "that predate it)")
    p.add_argument("--full-sampling", action="store_true",
                   help="draw all --samples of every design (default: stop a design's "
                        "sampling as soon as its feasibility at --samples is decided, e.g. "
                        "at the 3rd failure for 100 samples and P*_s >= 0.98)")
    add_backend_arguments(p)
    add_ros_arguments(p)
    p.add_argument("--keep-bags", action="store_true",
                   help="with --via ros: keep every episode's bag (in RUN_DIR/bags)")
    p.add_argument("--run-dir", default=None, metavar="DIR",
                   help="run directory: checkpoint, samples, results (default "
                        "out/optimize/case1-mass or out/optimize/case2-time)")
    p.add_argument("--status", action="store_true",
                   help="print how far the run in --run-dir (or --case's default) has come and "
                        "draw its convergence so far (progress.png); runs nothing")
    p.add_argument("--resume", action="store_true",
                   help="continue the run in --run-dir (same settings; --iterations and "
                        "--validation-samples may change)")
    p.add_argument("--seed", type=int, default=d.seed, metavar="S",
                   help=f"optimiser seed: seed design, acquisition candidates (default {d.seed})")
    p.add_argument("--sample-seed", type=int, default=d.sample_seed, metavar="B",
                   help="Monte Carlo base seed of the optimisation samples, the same for every "
                        f"design (default {d.sample_seed})")
    p.add_argument("--validation-seed", type=int, default=d.validation_seed, metavar="B",
                   help=f"base seed of the validation samples (default {d.validation_seed}, as "
                        "tethernet validate)")
    p.add_argument("--compare-reference", action="store_true",
                   help="also evaluate and validate the case's reference design "
                        "(mass-min / time-min, docs/model.md §9) for the results table")
    add_noise_arguments(p)
    add_config_argument(p)
    p.add_argument("--json", action="store_true", help="print the run summary as JSON")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    # advanced / test settings (not in --help)
    p.add_argument("--settle-time", type=float, default=None, help=argparse.SUPPRESS)
    p.add_argument("--horizon", type=float, default=None, help=argparse.SUPPRESS)
    p.add_argument("--gp-restarts", type=int, default=None, help=argparse.SUPPRESS)
    p.add_argument("--candidates", type=int, default=None, help=argparse.SUPPRESS)


def check_arguments(args) -> None:
    from ..errors import UserError

    if args.case is None and not (args.status and args.run_dir):
        raise UserError("--case: required (mass or time), except with --status --run-dir DIR")

    try:
        run_settings(args)
    except SettingError as exc:
        raise UserError(exc.with_flags()) from None
    check_backend_arguments(args)
    check_ros_arguments(args)
    if args.keep_bags and args.via != "ros":
        raise UserError("--keep-bags only applies with --via ros")
    if args.gp_restarts is not None and args.gp_restarts < 0:
        raise UserError(f"--gp-restarts {args.gp_restarts}: must be an integer >= 0")
    if args.candidates is not None and args.candidates < 1:
        raise UserError(f"--candidates {args.candidates}: must be an integer >= 1")


def run_settings(args) -> RunSettings:
    """The run's :class:`~optimizer.settings.RunSettings` from the command line (checked
    there: SettingError naming the field and its allowed range)."""
    options = {}
    if args.gp_restarts is not None:
        options["n_restarts_gp"] = args.gp_restarts
    if args.candidates is not None:
        options["n_candidates"] = args.candidates
    return RunSettings(
        iterations=args.iterations, seed_points=args.seed_points, samples=args.samples,
        validation_samples=args.validation_samples, seed=args.seed,
        sample_seed=args.sample_seed, validation_seed=args.validation_seed,
        validation_candidates=args.validation_candidates,
        validation_rule=args.validation_rule, validation_stop=args.validation_stop,
        sequential=not args.full_sampling, compare_reference=args.compare_reference,
        optimizer_options=options, fresh_samples=args.fresh_samples,
        shared_luck=args.shared_luck,
        racing_candidates=args.racing_candidates, racing_round=args.racing_round,
        racing_budget=args.racing_budget, racing_seed=args.racing_seed,
        racing_max_samples=args.racing_max_samples, selection_level=args.selection_level,
        fidelity=({p: args.explore_fidelity for p in EXPLORING_PHASES}
                  if args.explore_fidelity != REFERENCE else {}))


class OptimizeProgress:
    """tqdm bars on stderr: designs (advancing per sample, with the best feasible design
    and the estimated time left) and then each validation."""

    def __init__(self, case, disable: bool):
        self.case = case
        self.disable = disable
        self.bar = None
        self.vbar = None
        self.vlabel = None
        self.done = 0
        self.postfix = ""

    def _tqdm(self, **kw):
        from tqdm import tqdm

        return tqdm(file=sys.stderr, dynamic_ncols=True, smoothing=0.05, **kw)

    def __call__(self, ev: dict) -> None:
        if self.disable:
            return
        stage = ev["stage"]
        if stage == "start":
            self.done = ev["done"]
            self.bar = self._tqdm(total=ev["total"], initial=ev["done"],
                                  desc=f"Case {self.case.number} ({self.case.name})",
                                  bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total} "
                                             "designs [{elapsed}<{remaining}{postfix}]")
        elif stage == "sample" and self.bar is not None:
            self.bar.n = self.done + (ev["done"] / ev["samples"] if ev["samples"] else 0)
            self.bar.refresh()
        elif stage == "evaluation" and self.bar is not None:
            self.done = ev["evaluation"]
            self.bar.n = self.done
            unit = self.case.objective_unit
            best = ev.get("best_objective")
            text = (f"iter {ev['evaluation']}/{ev['total']}, best feasible "
                    + (f"{best:.3g} {unit} (P {ev['best_p_success']:.2f})" if best is not None
                       else "none yet")
                    + f", last P {ev['p_success']:.2f}")
            eta = ev.get("eta_s")
            if eta is not None and math.isfinite(eta):
                text += f", ETA incl. validation {_duration(eta)}"
            self.bar.set_postfix_str(text, refresh=True)
        elif stage == "validation":
            if self.bar is not None:
                self.bar.close()
                self.bar = None
            if self.vbar is None or self.vlabel != ev["label"]:
                if self.vbar is not None:
                    self.vbar.close()
                self.vlabel = ev["label"]
                self.vbar = self._tqdm(total=ev["total"], initial=ev["done"],
                                       desc=f"validating {ev['label']}", unit="ep")
            else:
                self.vbar.update(ev["done"] - self.vbar.n)
        elif stage == "done":
            self.close()

    def close(self):
        for b in (self.bar, self.vbar):
            if b is not None:
                b.close()
        self.bar = self.vbar = None


def _duration(s: float) -> str:
    s = int(round(s))
    return f"{s // 3600}h{s % 3600 // 60:02d}m" if s >= 3600 else f"{s // 60}m{s % 60:02d}s"


def _status(args) -> int:
    """``--status``: the run directory's progress (optimizer.status), no episode run."""
    from optimizer.checkpoint import CheckpointError
    from optimizer.run import RunError, default_run_dir
    from optimizer.status import run_status, status_text

    from ..errors import UserError

    run_dir = Path(args.run_dir) if args.run_dir else default_run_dir(args.case)
    try:
        st = run_status(run_dir)
    except (RunError, CheckpointError) as exc:
        raise UserError(str(exc)) from None
    if args.json:
        print_json(st)
    else:
        print(status_text(st))
    return 0


def run(args) -> int:
    from optimizer.cases import get_case
    from optimizer.checkpoint import CheckpointError
    from optimizer.run import RunError, default_run_dir

    from ..design_problem import optimize_design

    from ..errors import UserError

    check_arguments(args)
    if args.status:
        return _status(args)
    case = get_case(args.case)
    model = noise_model_from_args(args)
    over = {k: v for k, v in (("settle_time", args.settle_time), ("horizon", args.horizon))
            if v is not None}
    config = controller_config(args, config_from_args(args, **over))
    if args.explore_fidelity != REFERENCE:
        from ..core.fidelity import at_fidelity

        at_fidelity(config, args.explore_fidelity, field="--explore-fidelity")  # its error
    run_dir = Path(args.run_dir) if args.run_dir else default_run_dir(case)
    if args.resume and (run_dir / "run.json").exists() and not (run_dir / "checkpoint.json").exists():
        print(f"tethernet optimize: {run_dir} was stopped before its first design finished; "
              "resuming from its samples", file=sys.stderr)
    backend = backend_from_args(args, bag_dir=run_dir / "bags" if args.keep_bags else None,
                                keep_bags=args.keep_bags)
    bar = OptimizeProgress(case, args.no_progress)
    t0 = time.perf_counter()
    try:
        summary = optimize_design(
            case, settings=run_settings(args), backend=backend, run_dir=run_dir,
            resume=args.resume, config=config, noise_model=model, progress=bar)
    except SettingError as exc:
        raise UserError(exc.with_flags()) from None
    except (RunError, CheckpointError) as exc:
        raise UserError(str(exc)) from None
    finally:
        bar.close()
        backend.close()
    wall = time.perf_counter() - t0

    if args.json:
        print_json(summary)
        return 0
    md = Path(summary["files"]["results_md"]).read_text(encoding="utf-8")
    print(md.rstrip())
    if summary["sampling"] == "sequential":
        drawn = (f"{summary['evaluations']} designs, {summary['episodes']} of "
                 f"{summary['episodes_full']} samples drawn (sequential sampling saved "
                 f"{summary['episodes_saved']})")
    else:
        drawn = f"{summary['evaluations']} designs x {summary['samples']} samples"
    print(f"\n{drawn} on {summary['backend']}, {wall:.1f} s wall"
          + (f" ({summary['seconds_per_evaluation']:.1f} s per simulated design)"
             if summary.get("seconds_per_evaluation") else ""))
    files = summary["files"]
    print(f"run directory {summary['run_dir']}: results {Path(files['results_md']).name}, "
          f"{Path(files['results_csv']).name}, convergence {Path(files['convergence']).name}, "
          f"history {Path(files['history']).name}")
    hint = next_step_hint(summary)
    if hint:
        print(hint, file=sys.stderr)
    return 0


def next_step_hint(summary: dict) -> str | None:
    """What to do next when a finished run has no design that met its requirements (None
    when it has one): run further, or validate further ranked designs."""
    if summary["best_design"] is None:
        return ("no evaluated design met the constraints; run more iterations (--resume "
                "--iterations N) or relax the problem")
    v = summary["validation"]
    if v and not v["meets_requirement"]:
        k = summary["validation_candidates"]
        return (f"no validated design met C_P = {summary['p_threshold']:g} (up to {k} "
                f"validated); to validate further ranked designs: --resume "
                f"--validation-candidates {k + 5}")
    return None
