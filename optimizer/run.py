"""A whole optimisation run of Case 1 or Case 2: optimise, checkpoint, validate, report.

:func:`run_optimization` drives :func:`optimizer.loop.minimize` with a
:class:`~optimizer.evaluator.DesignEvaluator` on a :class:`~optimizer.problem.DesignProblem`
and keeps everything in one run directory::

    run.json          run settings (case, samples, seeds, sampling, the problem's settings)
    checkpoint.json   the optimiser's state, rewritten atomically after every evaluation
    samples.jsonl     every Monte Carlo sample of the optimisation (appended as it finishes)
    validation.jsonl  every validation sample
    racing.jsonl      every racing sample (optimizer/racing.py)
    history.csv       one row per evaluated design
    results.csv/.md   the results table (docs/model.md §12, docs/optimizer.md §7)
    convergence.png   objective, best feasible so far, P*_s and m_a per evaluation
    summary.json      what :func:`run_optimization` returns

Resuming (``resume=True``) replays the checkpoint into the optimiser (no re-evaluation),
which then asks for exactly the design that was in flight; its samples already in
``samples.jsonl`` are reused, so a run killed at any moment loses at most the samples of
the design in flight that had not finished.  The settings in ``run.json`` must match
(``iterations``, the racing's and the validation's settings may change;
:mod:`optimizer.settings`).  Given the same settings a resumed
run reaches the same result as an uninterrupted one (same machine and library versions).

Sampling: ``sequential=True`` (the default) stops a design's sampling as soon as its
feasibility at ``samples`` is decided (:mod:`optimizer.sequential`); ``False`` draws every
sample of every design.  The summary counts the samples the observations rest on
(``episodes``) against full sampling (``episodes_full``), and the racing's and the
validations' samples (``episodes_racing``, ``episodes_validation``; all:
``episodes_total``).

Fidelity (``fidelity``, :mod:`optimizer.settings`): the seed points and the iterations may
run at another fidelity of the problem (``problem.at_fidelity``; for the simulator the 2 ms
implicit step with 8 sweeps, docs/optimizer.md); racing and validation always run at the reference, on
samples of their own.  Each observation's ``info["fidelity"]`` (checkpoint.json, and a
``fidelity`` column of history.csv when not all are at the reference) records its
fidelity; run.json records the setting, and a resume under another one is refused.

Seeds: the optimiser's own randomness (seed design, candidates, GP restarts) comes from
``seed``; the optimisation samples are samples ``0..samples-1`` of Monte Carlo base seed
``sample_seed`` (default 1) for every design (common random numbers), or with
``fresh_samples`` of a base seed of each evaluation's own
(:func:`optimizer.settings.fresh_base_seed`); the racing (:mod:`optimizer.racing`) uses
base seed ``racing_seed`` (default 2); the validation
uses ``validation_samples`` samples of base seed ``validation_seed`` (default 0, the
default of ``tethernet validate``, so the validated numbers are directly comparable with a
``tethernet validate --reference`` run of the same size, and are fresh with respect to
the optimisation samples).
"""
from __future__ import annotations

import importlib.metadata
import json
import math
import os
import platform
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from collections.abc import Callable

from .bayesopt import ConstrainedBayesOpt
from .cases import P_SUCCESS, Case, get_case
from .checkpoint import CheckpointError, load_checkpoint
from .evaluator import DesignEvaluator
from .finish import finish_run
from .jsonio import atomic_write_json, json_clean
from .loop import minimize
from .observation import Observation
from .problem import DesignProblem
from .report import write_history
from .sequential import allowed_failures
from .settings import (MUTABLE, RECORDED_DEFAULTS, RUN_FORMAT, RunError, RunSettings,
                       SettingError, check_problem_fidelity)

__all__ = ["run_optimization", "RunError", "RunSettings", "default_run_dir",
           "read_run_settings", "RUN_FILES"]

RUN_FILES = {
    "settings": "run.json", "checkpoint": "checkpoint.json", "samples": "samples.jsonl",
    "validation": "validation.jsonl", "racing": "racing.jsonl", "history": "history.csv", "results_csv": "results.csv",
    "results_md": "results.md", "convergence": "convergence.png", "summary": "summary.json",
}


#: the libraries whose versions decide the optimiser's own arithmetic (its Gaussian process,
#: acquisition and L-BFGS-B polish use numpy's SIMD functions and OpenBLAS), recorded in
#: run.json beside the problem's machine facts
OPTIMIZER_LIBRARIES = ("numpy", "scipy", "scikit-learn", "scikit-optimize")


def machine_record(problem: DesignProblem) -> dict:
    """The machine facts a run directory records (run.json ``machine``): the problem's
    (``problem.machine_facts()`` where it has one: the simulator's CPU features, BLAS kernel
    and library versions), the optimiser's libraries and the architecture."""
    facts = dict(problem.machine_facts()) if hasattr(problem, "machine_facts") else {}
    facts.setdefault("arch", platform.machine())
    for lib in OPTIMIZER_LIBRARIES:
        try:
            facts.setdefault(lib, importlib.metadata.version(lib))
        except importlib.metadata.PackageNotFoundError:
            facts.setdefault(lib, "unknown")
    return facts


def machine_notice(recorded: dict | None, here: dict) -> str:
    """One line when this machine's facts differ from those ``recorded`` in a run's
    run.json ('' when they agree or the run recorded none)."""
    if not recorded:
        return ""
    diff = [f"{k}: {recorded.get(k)!r} -> {here.get(k)!r}"
            for k in sorted(set(recorded) | set(here)) if recorded.get(k) != here.get(k)]
    if not diff:
        return ""
    return ("resuming on a machine whose facts differ from the run's (" + "; ".join(diff)
            + "): the designs proposed from here on may differ in their last bits from an "
            "uninterrupted run's (docs/optimizer.md#s7)")


def default_run_dir(case: str | Case) -> Path:
    return Path("out") / "optimize" / f"case{get_case(case).number}-{get_case(case).name}"


def run_optimization(case: str | Case, problem: DesignProblem,
                     settings: RunSettings | None = None, *,
                     run_dir: str | os.PathLike | None = None, resume: bool = False,
                     progress: Callable[[dict], None] | None = None,
                     callback: Callable[[Observation, ConstrainedBayesOpt], Any] | None = None,
                     **fields) -> dict:
    """Optimise ``case`` (``"mass"`` = Case 1, ``"time"`` = Case 2) on ``problem``,
    validate, report.

    Args:
        problem: the design space and its Monte Carlo evaluation (its backend stays open;
            the caller closes it).
        settings: what the run does (:class:`~optimizer.settings.RunSettings`: budget,
            samples, seeds, sampling, validation, selection); default ``RunSettings()``.
        run_dir: the run directory (default ``out/optimize/case<N>-<name>``).
        resume: continue the run in ``run_dir``; without it a run directory that already
            holds a checkpoint is an error.  Resuming a directory with no checkpoint starts
            a new run.
        progress: ``progress(event)`` with a dict ``event["stage"]`` in ``"start"``,
            ``"sample"`` (``evaluation``, ``done``, ``total``), ``"evaluation"``
            (``evaluation``, ``total``, ``objective``, ``p_success``, ``feasible``,
            ``best_objective``, ``best_p_success``, ``eta_s``, ...), ``"validation"``
            (``label``, ``done``, ``total``) and ``"done"``.
        callback: ``callback(observation, optimizer)`` after every evaluation and its
            checkpoint; a truthy value stops the run early (no validation; status
            ``"stopped"``); an exception propagates (the checkpoint is intact).
        fields: fields of :class:`~optimizer.settings.RunSettings` given one by one
            (``iterations=20, samples=50``), applied over ``settings``.

    Returns the summary dict also written to ``summary.json``.  RunError (one line) when
    a setting is out of range or the run directory does not fit ``resume``.
    """
    t_start = time.perf_counter()
    case = get_case(case)
    settings = _settings_from(settings, fields)
    run = open_run(case, problem, settings, run_dir, resume)
    tracker = _Progress(run, progress, callback)
    if run.notice:
        warnings.warn(run.notice, RuntimeWarning, stacklevel=2)
    evaluator = DesignEvaluator(case, problem, run.settings.samples, run.settings.sample_seed,
                                results_path=run.paths["samples"], progress=tracker.on_sample,
                                sequential=run.settings.sequential,
                                fresh=run.settings.fresh_samples,
                                first_evaluation=run.previous + 1,
                                fidelity=dict(run.settings.fidelity),
                                seed_points=run.settings.seed_points)
    tracker.start(problem.describe())
    res = minimize(evaluator, problem.bounds, case.constraints,
                   cheap_constraint=evaluator.cheap_constraint,
                   n_initial=run.settings.seed_points, n_iterations=run.settings.iterations,
                   checkpoint_path=run.paths["checkpoint"], resume=resume,
                   callback=tracker.on_evaluation, seed=run.settings.seed,
                   **run.settings.optimizer_options, **_constraint_model(case, run.settings))
    write_history(run.paths["history"], res.optimizer.history, problem.variable_names)
    summary = finish_run(case, res.optimizer, res.stopped_by_callback, run.paths, run.settings,
                         problem, evaluator, tracker.emit)
    summary["seconds_per_evaluation"] = tracker.seconds_per_evaluation()
    summary["wall_time"] = time.perf_counter() - t_start
    atomic_write_json(run.paths["summary"], summary)
    tracker.emit({"stage": "done", **summary})
    return json_clean(summary)


def _constraint_model(case: Case, settings: RunSettings) -> dict:
    """The optimiser's options for the constraint model: the luck shared by estimates on
    common random numbers (``shared_luck``: variance C_P (1 - C_P) / N at the
    threshold, the spread of the empirical success rate of N common samples there)."""
    if settings.shared_luck and not settings.fresh_samples:
        p = case.p_threshold
        return {"shared_luck": {P_SUCCESS: p * (1.0 - p) / settings.samples}}
    return {}


def _settings_from(settings: RunSettings | None, fields: dict) -> RunSettings:
    """``settings`` (default ``RunSettings()``) with ``fields`` applied."""
    unknown = sorted(set(fields) - set(RunSettings.field_names()))
    if unknown:
        raise TypeError(f"run_optimization: unknown settings {unknown}; the settings are "
                        f"{', '.join(RunSettings.field_names())}")
    if settings is None:
        return RunSettings(**fields)
    return settings.replace(**fields) if fields else settings


@dataclass(frozen=True)
class OpenRun:
    """A run directory opened for a run: the case, the problem, the settings resolved
    against what the directory recorded, the paths of its files (:data:`RUN_FILES`),
    ``record`` (its run.json as written), ``previous`` (evaluations already done) and
    ``notice`` (:func:`machine_notice` of a resumed run; '' otherwise)."""

    case: Case
    problem: DesignProblem
    settings: RunSettings
    paths: dict
    record: dict
    previous: int
    notice: str = ""

    @property
    def total(self) -> int:
        """Evaluations planned: seed points + iterations."""
        return self.settings.seed_points + self.settings.iterations


def open_run(case: Case, problem: DesignProblem, settings: RunSettings,
             run_dir: str | os.PathLike | None, resume: bool) -> OpenRun:
    """Resolve ``settings`` against the run directory, check the directory against
    ``resume`` and its run.json against the settings, then write run.json."""
    run_dir = Path(run_dir) if run_dir is not None else default_run_dir(case)
    paths = {k: run_dir / v for k, v in RUN_FILES.items()}
    recorded = (read_run_settings(paths["settings"])
                if resume and paths["settings"].exists() else None)
    settings = settings.resolved(recorded, case)
    _check_validation_size(case, settings)
    check_problem_fidelity(settings, problem)
    record = json.loads(json.dumps(json_clean(settings.record(case.name, problem.settings()))))
    here = machine_record(problem)
    notice = ""
    if recorded is not None and recorded.get("machine"):
        # the facts of the machine that started the run stay; a resume on other facts
        # is noted beside them
        notice = machine_notice(recorded["machine"], here)
        record["machine"] = recorded["machine"]
        record["resumed_on"] = list(recorded.get("resumed_on", []))
        if notice and here not in record["resumed_on"]:
            record["resumed_on"].append(here)
    else:
        record["machine"] = here
    previous = _open_run_dir(run_dir, paths, record, resume)
    return OpenRun(case, problem, settings, paths, record, previous, notice)


def _check_validation_size(case: Case, settings: RunSettings) -> None:
    """SettingError when the validations could never meet C_P by the run's rule (the
    Wilson rule needs 189 samples at 98 %: fewer, all successes, leave the interval's
    lower end below it)."""
    n = settings.validation_samples
    if n and allowed_failures(n, case.p_threshold, settings.validation_rule) < 0:
        least = next(m for m in range(n, 100 * n + 1000)
                     if allowed_failures(m, case.p_threshold, settings.validation_rule) >= 0)
        raise SettingError("validation_samples", n,
                           f"be 0 or at least {least} under validation_rule "
                           f"{settings.validation_rule!r} (fewer can never meet C_P = "
                           f"{case.p_threshold:g})")


class _Progress:
    """The run's progress events (``progress`` of :func:`run_optimization`) and the
    timing of the simulated designs, for the estimate of the time left."""

    def __init__(self, run: OpenRun, progress, callback):
        self.run, self.progress, self.callback = run, progress, callback
        self.evaluation = run.previous + 1
        self.last = time.perf_counter()
        self.times: list[float] = []

    def emit(self, event: dict) -> None:
        if self.progress is not None:
            self.progress(event)

    def start(self, backend: str) -> None:
        s = self.run.settings
        self.emit({"stage": "start", "case": self.run.case.name, "done": self.run.previous,
                   "total": self.run.total, "samples": s.samples,
                   "run_dir": str(self.run.paths["settings"].parent), "backend": backend})

    def on_sample(self, done: int, n: int) -> None:
        self.emit({"stage": "sample", "evaluation": self.evaluation, "total": self.run.total,
                   "done": done, "samples": n})

    def seconds_per_evaluation(self) -> float | None:
        """Mean wall time of the designs simulated in this session (None: none was)."""
        return sum(self.times) / len(self.times) if self.times else None

    def on_evaluation(self, obs: Observation, opt: ConstrainedBayesOpt):
        s, run = self.run.settings, self.run
        now = time.perf_counter()
        if obs.info.get("reused_samples", 0) < obs.info.get("samples", s.samples):
            self.times.append(now - self.last)          # a simulated design: time it
        self.last = now
        n = len(opt.history)
        write_history(run.paths["history"], opt.history, run.problem.variable_names)
        best = opt.best_feasible()
        per_eval = self.seconds_per_evaluation()
        per_eval = math.nan if per_eval is None else per_eval
        remaining = (max(run.total - n, 0)
                     + (s.validation_samples / s.samples if s.validation_samples else 0))
        self.emit({"stage": "evaluation", "evaluation": n, "total": run.total,
                   "phase": obs.acquisition.get("phase", ""), "objective": obs.objective,
                   "p_success": obs.constraints[P_SUCCESS], "feasible": obs.feasible,
                   "mass": obs.info.get("mass"),
                   "best_objective": best.objective if best is not None else None,
                   "best_p_success": best.constraints[P_SUCCESS] if best is not None else None,
                   "seconds_per_evaluation": per_eval,
                   "eta_s": per_eval * remaining if self.times else None})
        self.evaluation = n + 1
        return self.callback(obs, opt) if self.callback is not None else None


def _open_run_dir(run_dir: Path, paths: dict, record: dict, resume: bool) -> int:
    """Check the run directory against ``resume`` and its run.json against ``record``,
    then write ``record``; returns the evaluations already done (0 for a new run)."""
    previous = 0
    if resume and not paths["checkpoint"].exists() and not paths["settings"].exists():
        raise RunError(f"cannot resume: {str(run_dir)!r} holds no run ({RUN_FILES['settings']} "
                       "missing); start it without --resume")
    if paths["checkpoint"].exists():
        if not resume:
            raise RunError(f"run directory {str(run_dir)!r} already holds a run "
                           f"({RUN_FILES['checkpoint']}); resume it or choose another run "
                           "directory")
        previous = _check_resume(paths, record)
    run_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_json(paths["settings"], record)
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


def _check_resume(paths: dict, record: dict) -> int:
    """Compare run.json with the requested settings; returns the evaluations done."""
    saved = read_run_settings(paths["settings"])
    for key, value in record.items():
        if key in MUTABLE or key in ("model_version", "machine", "resumed_on"):
            continue
        was = saved.get(key, RECORDED_DEFAULTS.get(key))
        if was != value:
            raise RunError(f"cannot resume: setting {key!r} of the run is {was!r}, "
                           f"requested {value!r}; pass the same settings or use another run "
                           "directory")
    if saved.get("model_version") != record.get("model_version"):
        warnings.warn("the simulator core changed since this run started: its saved samples "
                      "are not reused and later designs are evaluated with the new model",
                      RuntimeWarning, stacklevel=4)
    try:
        return len(load_checkpoint(paths["checkpoint"])["optimizer"]["history"])
    except (KeyError, TypeError) as exc:
        raise CheckpointError(f"checkpoint {str(paths['checkpoint'])!r} lacks the optimiser "
                              f"state ({exc!r})") from exc
