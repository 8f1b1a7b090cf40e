"""A whole optimisation run of Case 1 or Case 2: optimise, checkpoint, validate, report.

:func:`run_optimization` drives :func:`optimizer.loop.minimize` with a
:class:`~optimizer.evaluator.DesignEvaluator` on a :class:`~optimizer.problem.DesignProblem`
and keeps everything in one run directory::

    run.json          run settings (case, samples, seeds, sampling, the problem's settings)
    checkpoint.json   the optimiser's state, rewritten atomically after every evaluation
    samples.jsonl     every Monte Carlo sample of the optimisation (appended as it finishes)
    validation.jsonl  every validation sample
    history.csv       one row per evaluated design
    results.csv/.md   the results table (docs/model.md §12, docs/optimizer.md §7)
    convergence.png   objective, best feasible so far, P*_s and m_a per evaluation
    summary.json      what :func:`run_optimization` returns

Resuming (``resume=True``) replays the checkpoint into the optimiser (no re-evaluation),
which then asks for exactly the design that was in flight; its samples already in
``samples.jsonl`` are reused, so a run killed at any moment loses at most the samples of
the design in flight that had not finished.  The settings in ``run.json`` must match
(``iterations`` and the validation's settings may change).  Given the same settings a resumed
run reaches the same result as an uninterrupted one (same machine and library versions).

Sampling: ``sequential=True`` (the default) stops a design's sampling as soon as its
feasibility at ``samples`` is decided (:mod:`optimizer.sequential`); ``False`` draws every
sample of every design.  The summary counts the samples the observations rest on
(``episodes``) against full sampling (``episodes_full``).

Seeds: the optimiser's own randomness (seed design, candidates, GP restarts) comes from
``seed``; the optimisation samples are samples ``0..samples-1`` of Monte Carlo base seed
``sample_seed`` (default 1) for every design (common random numbers); the validation
uses ``validation_samples`` samples of base seed ``validation_seed`` (default 0, the
default of ``tethernet validate``, so the validated numbers are directly comparable with a
``tethernet validate --reference`` run of the same size, and are fresh with respect to
the optimisation samples).
"""
from __future__ import annotations

import json
import math
import os
import time
import warnings
from pathlib import Path
from typing import Any
from collections.abc import Callable, Mapping

from .bayesopt import ConstrainedBayesOpt
from .cases import P_SUCCESS, VALIDATION_RULES, Case, get_case
from .checkpoint import CheckpointError, load_checkpoint
from .evaluator import DesignEvaluator
from .finish import finish_run
from .jsonio import atomic_write_json, json_clean
from .loop import minimize
from .observation import Observation
from .problem import DesignProblem
from .report import write_history

__all__ = ["run_optimization", "RunError", "default_run_dir", "read_run_settings", "RUN_FILES"]

RUN_FORMAT = "tethernet_ros.optimizer.run"
RUN_VERSION = 1
RUN_FILES = {
    "settings": "run.json", "checkpoint": "checkpoint.json", "samples": "samples.jsonl",
    "validation": "validation.jsonl", "history": "history.csv", "results_csv": "results.csv",
    "results_md": "results.md", "convergence": "convergence.png", "summary": "summary.json",
}
#: settings that may differ between a run and its resumption
_MUTABLE_SETTINGS = {"iterations", "validation_samples", "validation_candidates",
                     "validation_rule", "validation_stop", "compare_reference"}
#: the value of a setting that a run directory of an older version does not record
_SETTING_DEFAULTS = {"sequential": False, "validation_rule": "estimate",
                     "validation_stop": False}


class RunError(ValueError):
    """A run cannot start or resume as asked (message: one line, says what to do)."""


def default_run_dir(case: str | Case) -> Path:
    return Path("out") / "optimize" / f"case{get_case(case).number}-{get_case(case).name}"


def _check_int(name: str, value, minimum: int) -> int:
    import numbers

    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise RunError(f"{name}: got {value!r}; must be an integer >= {minimum}")
    if int(value) < minimum:
        raise RunError(f"{name}: got {value}; must be an integer >= {minimum}")
    return int(value)


def run_optimization(case: str | Case, problem: DesignProblem, iterations: int = 200,
                     seed_points: int = 50, samples: int = 100,
                     run_dir: str | os.PathLike | None = None, resume: bool = False,
                     validation_samples: int = 1000, *, seed: int = 0, sample_seed: int = 1,
                     validation_seed: int = 0, validation_candidates: int = 1,
                     validation_rule: str = "estimate", validation_stop: bool | None = None,
                     sequential: bool = True,
                     min_probability: float | None = 0.5, compare_reference: bool = False,
                     progress: Callable[[dict], None] | None = None,
                     callback: Callable[[Observation, ConstrainedBayesOpt], Any] | None = None,
                     optimizer_options: Mapping | None = None) -> dict:
    """Optimise ``case`` (``"mass"`` = Case 1, ``"time"`` = Case 2) on ``problem``,
    validate, report.

    Args:
        problem: the design space and its Monte Carlo evaluation (its backend stays open;
            the caller closes it).
        iterations, seed_points: model-based iterations after ``seed_points`` space-filling
            seed designs (the source's setup, docs/optimizer.md §4: 200 and 50).
        samples: Monte Carlo samples per design during optimisation (docs/optimizer.md §2: 100).
        run_dir: the run directory (default ``out/optimize/case<N>-<name>``).
        resume: continue the run in ``run_dir``; without it a run directory that already
            holds a checkpoint is an error.  Resuming a directory with no checkpoint starts
            a new run.
        validation_samples: fresh samples for the final design (0: no validation).
        validation_candidates: validate the ranked designs in turn until one meets C_P,
            at most this many (:func:`optimizer.finish.finish_run`; 1: the first only).
        validation_rule: how a validation meets C_P: "estimate" (its P*_s, the source's
            test) or "wilson" (the lower end of its Wilson 95 % interval).
        validation_stop: end a validation at the failure that decides it misses C_P
            (:func:`optimizer.finish.finish_run`).  None: as the run being resumed
            recorded it (off for runs that predate it), on for a new run.
        seed, sample_seed, validation_seed: see the module docstring.
        sequential: stop sampling a design once its feasibility is decided (module
            docstring); False: every design gets all ``samples``.
        min_probability: posterior-feasibility filter of the final choice
            (:func:`optimizer.selection.select_best`; None: plain observed-feasible rule).
        compare_reference: also evaluate the case's docs/model.md §9 reference design with
            the optimisation and the validation samples (an extra table row).
        progress: ``progress(event)`` with a dict ``event["stage"]`` in ``"start"``,
            ``"sample"`` (``evaluation``, ``done``, ``total``), ``"evaluation"``
            (``evaluation``, ``total``, ``objective``, ``p_success``, ``feasible``,
            ``best_objective``, ``best_p_success``, ``eta_s``, ...), ``"validation"``
            (``label``, ``done``, ``total``) and ``"done"``.
        callback: ``callback(observation, optimizer)`` after every evaluation and its
            checkpoint; a truthy value stops the run early (no validation; status
            ``"stopped"``); an exception propagates (the checkpoint is intact).
        optimizer_options: extra :class:`~optimizer.bayesopt.ConstrainedBayesOpt` settings
            (``n_restarts_gp``, ``n_candidates``, ``active_set``, ``exploration_ratio``...).

    Returns the summary dict also written to ``summary.json``.
    """
    t_start = time.perf_counter()
    case = get_case(case)
    run_dir = Path(run_dir) if run_dir is not None else default_run_dir(case)
    paths = {k: run_dir / v for k, v in RUN_FILES.items()}
    if validation_stop is None:
        validation_stop = (read_run_settings(paths["settings"]).get(
            "validation_stop", _SETTING_DEFAULTS["validation_stop"])
            if resume and paths["settings"].exists() else True)
    settings = _run_settings(case, problem, iterations=iterations, seed_points=seed_points,
                             samples=samples, validation_samples=validation_samples, seed=seed,
                             sample_seed=sample_seed, validation_seed=validation_seed,
                             validation_candidates=validation_candidates,
                             validation_rule=validation_rule,
                             validation_stop=bool(validation_stop), sequential=sequential,
                             optimizer_options=optimizer_options,
                             min_probability=min_probability,
                             compare_reference=compare_reference)
    iterations, seed_points, samples = (settings[k] for k in ("iterations", "seed_points",
                                                              "samples"))
    validation_samples = settings["validation_samples"]
    opt_options = dict(optimizer_options or {})
    previous = _open_run_dir(run_dir, paths, settings, resume)
    total = seed_points + iterations

    def emit(event: dict) -> None:
        if progress is not None:
            progress(event)

    state = {"evaluation": previous + 1, "last": time.perf_counter(), "times": []}

    def sample_progress(done, n):
        emit({"stage": "sample", "evaluation": state["evaluation"], "total": total,
              "done": done, "samples": n})

    evaluator = DesignEvaluator(case, problem, samples, settings["sample_seed"],
                                results_path=paths["samples"], progress=sample_progress,
                                sequential=sequential)
    emit({"stage": "start", "case": case.name, "done": previous, "total": total,
          "samples": samples, "run_dir": str(run_dir), "backend": problem.describe()})

    def on_evaluation(obs: Observation, opt: ConstrainedBayesOpt):
        now = time.perf_counter()
        if obs.info.get("reused_samples", 0) < obs.info.get("samples", samples):
            state["times"].append(now - state["last"])          # a simulated design: time it
        state["last"] = now
        n = len(opt.history)
        write_history(paths["history"], opt.history, problem.variable_names)
        best = opt.best_feasible()
        per_eval = (sum(state["times"]) / len(state["times"])) if state["times"] else math.nan
        remaining = max(total - n, 0) + (validation_samples / samples if validation_samples else 0)
        emit({"stage": "evaluation", "evaluation": n, "total": total,
              "phase": obs.acquisition.get("phase", ""), "objective": obs.objective,
              "p_success": obs.constraints[P_SUCCESS], "feasible": obs.feasible,
              "mass": obs.info.get("mass"),
              "best_objective": best.objective if best is not None else None,
              "best_p_success": best.constraints[P_SUCCESS] if best is not None else None,
              "seconds_per_evaluation": per_eval,
              "eta_s": per_eval * remaining if state["times"] else None})
        state["evaluation"] = n + 1
        return callback(obs, opt) if callback is not None else None

    res = minimize(evaluator, problem.bounds, case.constraints,
                   cheap_constraint=evaluator.cheap_constraint, n_initial=seed_points,
                   n_iterations=iterations, checkpoint_path=paths["checkpoint"],
                   resume=resume, callback=on_evaluation, seed=settings["seed"], **opt_options)
    opt = res.optimizer
    write_history(paths["history"], opt.history, problem.variable_names)
    summary = finish_run(case, opt, res.stopped_by_callback, paths, settings, problem,
                         evaluator, emit, min_probability, compare_reference)
    times = state["times"]
    summary["seconds_per_evaluation"] = sum(times) / len(times) if times else None
    summary["wall_time"] = time.perf_counter() - t_start
    atomic_write_json(paths["summary"], summary)
    emit({"stage": "done", **summary})
    return json_clean(summary)


def _run_settings(case: Case, problem: DesignProblem, *, iterations, seed_points, samples,
                  validation_samples, seed, sample_seed, validation_seed,
                  validation_candidates, validation_rule, validation_stop, sequential,
                  optimizer_options,
                  min_probability, compare_reference) -> dict:
    """The run's settings (run.json) from the arguments of :func:`run_optimization`,
    checked: RunError naming the first bad one."""
    ints = {"iterations": (iterations, 0), "seed_points": (seed_points, 1),
            "samples": (samples, 1), "validation_samples": (validation_samples, 0),
            "seed": (seed, 0), "sample_seed": (sample_seed, 0),
            "validation_seed": (validation_seed, 0),
            "validation_candidates": (validation_candidates, 1)}
    checked = {name: _check_int(name, value, low) for name, (value, low) in ints.items()}
    if validation_rule not in VALIDATION_RULES:
        raise RunError(f"validation_rule: got {validation_rule!r}; must be one of "
                       f"{', '.join(VALIDATION_RULES)}")
    if checked["validation_samples"] and checked["validation_seed"] == checked["sample_seed"]:
        raise RunError(f"validation_seed {validation_seed} equals sample_seed: the validation "
                       "samples must be fresh (use another base seed)")
    opt_options = dict(optimizer_options or {})
    bad = set(opt_options) & {"n_initial", "n_iterations", "seed", "cheap_constraint"}
    if bad:
        raise RunError(f"optimizer_options may not set {sorted(bad)} (use the arguments)")
    return json.loads(json.dumps(json_clean({
        "format": RUN_FORMAT, "version": RUN_VERSION, "case": case.name,
        "iterations": checked["iterations"], "seed_points": checked["seed_points"],
        "samples": checked["samples"], "validation_samples": checked["validation_samples"],
        "seed": checked["seed"], "sample_seed": checked["sample_seed"],
        "validation_seed": checked["validation_seed"],
        "validation_candidates": checked["validation_candidates"],
        "validation_rule": validation_rule, "validation_stop": bool(validation_stop),
        "sequential": bool(sequential), **problem.settings(), "optimizer_options": opt_options,
        "min_probability": min_probability, "compare_reference": bool(compare_reference),
    })))


def _open_run_dir(run_dir: Path, paths: dict, settings: dict, resume: bool) -> int:
    """Check the run directory against ``resume`` and its run.json against ``settings``,
    then write them; returns the evaluations already done (0 for a new run)."""
    previous = 0
    if resume and not paths["checkpoint"].exists() and not paths["settings"].exists():
        raise RunError(f"cannot resume: {str(run_dir)!r} holds no run ({RUN_FILES['settings']} "
                       "missing); start it without --resume")
    if paths["checkpoint"].exists():
        if not resume:
            raise RunError(f"run directory {str(run_dir)!r} already holds a run "
                           f"({RUN_FILES['checkpoint']}); resume it or choose another run "
                           "directory")
        previous = _check_resume(paths, settings)
    run_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_json(paths["settings"], settings)
    return previous


def read_run_settings(path: str | os.PathLike) -> dict:
    """A run directory's settings (its run.json); RunError if missing, corrupt or not one."""
    path = Path(path)
    try:
        saved = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise RunError(f"{path} is missing: the run directory is not a run of "
                       "this tool") from None
    except ValueError:
        raise RunError(f"{path} is corrupt; start a new run in another "
                       "directory") from None
    if not isinstance(saved, dict) or saved.get("format") != RUN_FORMAT:
        raise RunError(f"{path} is not a run settings file of this tool")
    return saved


def _check_resume(paths: dict, settings: dict) -> int:
    """Compare run.json with the requested settings; returns the evaluations done."""
    saved = read_run_settings(paths["settings"])
    for key, value in settings.items():
        if key in _MUTABLE_SETTINGS or key == "model_version":
            continue
        was = saved.get(key, _SETTING_DEFAULTS.get(key))
        if was != value:
            raise RunError(f"cannot resume: setting {key!r} of the run is {was!r}, "
                           f"requested {value!r}; pass the same settings or use another run "
                           "directory")
    if saved.get("model_version") != settings.get("model_version"):
        warnings.warn("the simulator core changed since this run started: its saved samples "
                      "are not reused and later designs are evaluated with the new model",
                      RuntimeWarning, stacklevel=3)
    try:
        return len(load_checkpoint(paths["checkpoint"])["optimizer"]["history"])
    except (KeyError, TypeError) as exc:
        raise CheckpointError(f"checkpoint {str(paths['checkpoint'])!r} lacks the optimiser "
                              f"state ({exc!r})") from exc
