"""A whole optimisation run of Case 1 or Case 2: optimise, checkpoint, validate, report.

:func:`run_optimization` drives :func:`optimizer.minimize` with a
:class:`~optimizer.cases.DesignEvaluator` and keeps everything in one run directory::

    run.json          run settings (case, samples, seeds, SimConfig, noise model, ...)
    checkpoint.json   the optimiser's state, rewritten atomically after every evaluation
    samples.jsonl     every Monte Carlo sample of the optimisation (appended as it finishes)
    validation.jsonl  every validation sample
    history.csv       one row per evaluated design
    results.csv/.md   the results table (SPEC section 9)
    convergence.png   objective, best feasible so far, P*_s and m_a per evaluation
    summary.json      what :func:`run_optimization` returns

Resuming (``resume=True``) replays the checkpoint into the optimiser (no re-evaluation),
which then asks for exactly the design that was in flight; its samples already in
``samples.jsonl`` are reused, so a run killed at any moment loses at most the samples of
the design in flight that had not finished.  The settings in ``run.json`` must match
(``iterations`` and ``validation_samples`` may change).  Given the same settings a resumed
run reaches the same result as an uninterrupted one (same machine and library versions).

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
import tempfile
import time
import warnings
from dataclasses import asdict
from pathlib import Path
from typing import Any, Callable, Mapping

from .bayesopt import ConstrainedBayesOpt, Observation, minimize
from .cases import P_SUCCESS, Case, DesignEvaluator, get_case, select_best
from .checkpoint import CheckpointError, load_checkpoint

__all__ = ["run_optimization", "RunError", "default_run_dir", "RUN_FILES"]

RUN_FORMAT = "tethernet_ros.optimizer.run"
RUN_VERSION = 1
RUN_FILES = {
    "settings": "run.json", "checkpoint": "checkpoint.json", "samples": "samples.jsonl",
    "validation": "validation.jsonl", "history": "history.csv", "results_csv": "results.csv",
    "results_md": "results.md", "convergence": "convergence.png", "summary": "summary.json",
}
#: settings that may differ between a run and its resumption
_MUTABLE_SETTINGS = {"iterations", "validation_samples", "compare_reference"}


class RunError(ValueError):
    """A run cannot start or resume as asked (message: one line, says what to do)."""


def default_run_dir(case: str | Case) -> Path:
    return Path("out") / "optimize" / f"case{get_case(case).number}-{get_case(case).name}"


def _write_json(path: Path, obj: Any) -> None:
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    with os.fdopen(fd, "w", encoding="utf-8") as fh:
        json.dump(_clean(obj), fh, indent=1)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def _clean(obj):
    """Strict-JSON copy (non-finite floats -> None, tuples -> lists)."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, Mapping):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if hasattr(obj, "item") and callable(obj.item):  # numpy scalar
        return _clean(obj.item())
    return obj


def _check_int(name: str, value, minimum: int) -> int:
    import numbers

    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise RunError(f"{name}: got {value!r}; must be an integer >= {minimum}")
    if int(value) < minimum:
        raise RunError(f"{name}: got {value}; must be an integer >= {minimum}")
    return int(value)


def run_optimization(case: str | Case, iterations: int = 200, seed_points: int = 50,
                     samples: int = 100, backend=None, run_dir: str | os.PathLike | None = None,
                     resume: bool = False, validation_samples: int = 1000, *,
                     config=None, noise_model=None, seed: int = 0, sample_seed: int = 1,
                     validation_seed: int = 0, min_probability: float | None = 0.5,
                     compare_reference: bool = False,
                     progress: Callable[[dict], None] | None = None,
                     callback: Callable[[Observation, ConstrainedBayesOpt], Any] | None = None,
                     optimizer_options: Mapping | None = None) -> dict:
    """Optimise ``case`` (``"mass"`` = Case 1, ``"time"`` = Case 2), validate, report.

    Args:
        iterations, seed_points: model-based iterations after ``seed_points`` space-filling
            seed designs (SPEC reference: 200 and 50).
        samples: Monte Carlo samples per design during optimisation (SPEC: 100).
        backend: an :class:`~tethernet_ros.montecarlo.EpisodeBackend` (kept open; the
            caller closes it); None: a process pool on all cores, closed at the end.
        run_dir: the run directory (default ``out/optimize/case<N>-<name>``).
        resume: continue the run in ``run_dir``; without it a run directory that already
            holds a checkpoint is an error.  Resuming a directory with no checkpoint starts
            a new run.
        validation_samples: fresh samples for the final design (0: no validation).
        config, noise_model: SimConfig and NoiseModel of every episode (SPEC defaults).
        seed, sample_seed, validation_seed: see the module docstring.
        min_probability: posterior-feasibility filter of the final choice
            (:func:`optimizer.cases.select_best`; None: plain observed-feasible rule).
        compare_reference: also evaluate the case's SPEC section 8 reference design with
            the optimisation and the validation samples (an extra table row).
        progress: ``progress(event)`` with a dict ``event["stage"]`` in ``"start"``,
            ``"sample"`` (``evaluation``, ``done``, ``total``), ``"evaluation"``
            (``evaluation``, ``total``, ``objective``, ``p_success``, ``feasible``,
            ``best_objective``, ``best_p_success``, ``eta_s``, ...), ``"validation"``
            (``label``, ``done``, ``total``) and ``"done"``.
        callback: ``callback(observation, optimizer)`` after every evaluation and its
            checkpoint; a truthy value stops the run early (no validation; status
            ``"stopped"``); an exception propagates (the checkpoint is intact).
        optimizer_options: extra :class:`~optimizer.ConstrainedBayesOpt` settings
            (``n_restarts_gp``, ``n_candidates``, ``active_set``, ``exploration_ratio``...).

    Returns the summary dict also written to ``summary.json``.
    """
    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.noise import NoiseModel
    from tethernet_ros import montecarlo

    t_start = time.perf_counter()
    case = get_case(case)
    iterations = _check_int("iterations", iterations, 0)
    seed_points = _check_int("seed_points", seed_points, 1)
    samples = _check_int("samples", samples, 1)
    validation_samples = _check_int("validation_samples", validation_samples, 0)
    seed = _check_int("seed", seed, 0)
    sample_seed = _check_int("sample_seed", sample_seed, 0)
    validation_seed = _check_int("validation_seed", validation_seed, 0)
    if validation_samples and validation_seed == sample_seed:
        raise RunError(f"validation_seed {validation_seed} equals sample_seed: the validation "
                       "samples must be fresh (use another base seed)")
    config = config or SimConfig()
    noise_model = noise_model or NoiseModel()
    opt_options = dict(optimizer_options or {})
    bad = set(opt_options) & {"n_initial", "n_iterations", "seed", "cheap_constraint"}
    if bad:
        raise RunError(f"optimizer_options may not set {sorted(bad)} (use the arguments)")
    run_dir = Path(run_dir) if run_dir is not None else default_run_dir(case)
    paths = {k: run_dir / v for k, v in RUN_FILES.items()}

    settings = _clean({
        "format": RUN_FORMAT, "version": RUN_VERSION, "case": case.name,
        "iterations": iterations, "seed_points": seed_points, "samples": samples,
        "validation_samples": validation_samples, "seed": seed, "sample_seed": sample_seed,
        "validation_seed": validation_seed, "config": config.to_dict(),
        "noise_model": asdict(noise_model),
        "optimizer_options": opt_options, "min_probability": min_probability,
        "compare_reference": bool(compare_reference),
        "model_version": montecarlo.model_version(),
    })
    settings = json.loads(json.dumps(settings))
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
    _write_json(paths["settings"], settings)

    own_backend = backend is None
    if own_backend:
        backend = montecarlo.ProcessPoolBackend()
    total = seed_points + iterations

    def emit(event: dict) -> None:
        if progress is not None:
            progress(event)

    state = {"evaluation": previous + 1, "last": time.perf_counter(), "times": []}

    def sample_progress(done, n):
        emit({"stage": "sample", "evaluation": state["evaluation"], "total": total,
              "done": done, "samples": n})

    evaluator = DesignEvaluator(case, backend, samples, sample_seed, noise_model, config,
                                results_path=paths["samples"], progress=sample_progress)
    emit({"stage": "start", "case": case.name, "done": previous, "total": total,
          "samples": samples, "run_dir": str(run_dir), "backend": backend.describe()})

    def on_evaluation(obs: Observation, opt: ConstrainedBayesOpt):
        now = time.perf_counter()
        if obs.info.get("reused_samples", 0) < samples:  # a simulated design: time it
            state["times"].append(now - state["last"])
        state["last"] = now
        n = len(opt.history)
        _write_history(paths["history"], opt.history, case)
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

    try:
        res = minimize(evaluator, case.bounds, case.constraints,
                       cheap_constraint=evaluator.cheap_constraint, n_initial=seed_points,
                       n_iterations=iterations, checkpoint_path=paths["checkpoint"],
                       resume=resume, callback=on_evaluation, seed=seed, **opt_options)
        opt = res.optimizer
        _write_history(paths["history"], opt.history, case)
        summary = _finish(case, opt, res.stopped_by_callback, paths, settings, backend, evaluator,
                          config, noise_model, emit, min_probability, compare_reference)
    finally:
        if own_backend:
            backend.close()
    times = state["times"]
    summary["seconds_per_evaluation"] = sum(times) / len(times) if times else None
    summary["wall_time"] = time.perf_counter() - t_start
    _write_json(paths["summary"], summary)
    emit({"stage": "done", **summary})
    return _clean(summary)


def _check_resume(paths: dict, settings: dict) -> int:
    """Compare run.json with the requested settings; returns the evaluations done."""
    try:
        saved = json.loads(paths["settings"].read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise RunError(f"{paths['settings']} is missing: the run directory is not a run of "
                       "this tool") from None
    except ValueError:
        raise RunError(f"{paths['settings']} is corrupt; start a new run in another "
                       "directory") from None
    if saved.get("format") != RUN_FORMAT:
        raise RunError(f"{paths['settings']} is not a run settings file of this tool")
    for key, value in settings.items():
        if key in _MUTABLE_SETTINGS or key == "model_version":
            continue
        if saved.get(key) != value:
            raise RunError(f"cannot resume: setting {key!r} of the run is {saved.get(key)!r}, "
                           f"requested {value!r}; pass the same settings or use another run "
                           "directory")
    if saved.get("model_version") != settings["model_version"]:
        warnings.warn("the simulator core changed since this run started: its saved samples "
                      "are not reused and later designs are evaluated with the new model",
                      RuntimeWarning, stacklevel=3)
    try:
        return len(load_checkpoint(paths["checkpoint"])["optimizer"]["history"])
    except (KeyError, TypeError) as exc:
        raise CheckpointError(f"checkpoint {str(paths['checkpoint'])!r} lacks the optimiser "
                              f"state ({exc!r})") from exc


def _finish(case, opt, stopped, paths, settings, backend, evaluator, config, noise_model, emit,
            min_probability, compare_reference) -> dict:
    from tethernet_ros import montecarlo
    from tethernet_ros.core.design import REFERENCE_DESIGNS, VARIABLE_NAMES, Design

    from .report import plot_convergence, write_results

    best, rule = select_best(opt, min_probability)
    feasible = [o for o in opt.history if o.feasible]
    validation = None
    rows = []
    val_n = settings["validation_samples"]

    def validate(design, label):
        def prog(done, total, _r):
            emit({"stage": "validation", "label": label, "done": done, "total": total})
        return montecarlo.evaluate(design, val_n, settings["validation_seed"], noise_model,
                                   config, backend, results_path=paths["validation"],
                                   label=label, progress=prog)

    if best is not None:
        design = Design.from_vector(best.x)
        vres = validate(design, "best") if (val_n and not stopped) else None
        validation = _validation_dict(vres)
        rows.append(_row(f"best (Case {case.number})", design, best.info, validation,
                         evaluation=_index(opt.history, best)))
    if compare_reference and not stopped and case.reference in REFERENCE_DESIGNS:
        ref = REFERENCE_DESIGNS[case.reference]
        emit({"stage": "validation", "label": f"reference {case.reference}", "done": 0,
              "total": evaluator.samples})
        r = evaluator.evaluate_design(ref, label=case.reference)
        info = {"successes": r.successes, "samples": r.n_samples, "p_success": r.p_success,
                "ci_low": r.ci_low, "ci_high": r.ci_high, "mass": r.mass,
                "mean_completion_time": r.mean_completion_time}
        vref = _validation_dict(validate(ref, case.reference) if val_n else None)
        rows.append(_row(f"reference {case.reference} (SPEC 8)", ref, info, vref, evaluation=None))

    summary = {
        "case": case.name, "case_number": case.number, "problem": case.describe(),
        "status": "stopped" if stopped else "complete",
        "evaluations": len(opt.history), "seed_points": opt.n_initial,
        "iterations": opt.n_iterations, "samples": settings["samples"],
        "sample_seed": settings["sample_seed"], "seed": settings["seed"],
        "feasible_evaluations": len(feasible), "selection_rule": rule,
        "objective_name": case.objective, "objective_unit": case.objective_unit,
        "best_design": None, "best_vector": None, "best_evaluation": None,
        "best_objective": None, "p_success": None, "p_success_ci": None, "successes": None,
        "mass": None, "mean_completion_time": None, "validation": validation,
        "table": rows, "run_dir": str(paths["settings"].parent),
        "files": {k: str(v) for k, v in paths.items()}, "backend": backend.describe(),
        "variables": list(VARIABLE_NAMES),
    }
    if best is not None:
        design = Design.from_vector(best.x)
        summary.update({
            "best_design": design.to_dict(), "best_vector": [float(v) for v in best.x],
            "best_evaluation": _index(opt.history, best), "best_objective": best.objective,
            "p_success": best.constraints[P_SUCCESS], "successes": best.info.get("successes"),
            "p_success_ci": [best.info.get("ci_low"), best.info.get("ci_high")],
            "mass": best.info.get("mass"),
            "mean_completion_time": best.info.get("mean_completion_time"),
        })
    write_results(paths["results_csv"], paths["results_md"], summary)
    plot_convergence(paths["convergence"], opt.history, case, best,
                     validation["p_success"] if validation else None)
    return summary


def _index(history, obs) -> int:
    """1-based evaluation number of ``obs`` (by identity)."""
    return next(i for i, o in enumerate(history, 1) if o is obs)


def _validation_dict(r) -> dict | None:
    if r is None:
        return None
    return {"samples": r.n_samples, "base_seed": r.base_seed, "successes": r.successes,
            "p_success": r.p_success, "wilson": [r.ci_low, r.ci_high],
            "clopper_pearson": [r.cp_low, r.cp_high],
            "mean_completion_time": r.mean_completion_time, "mass": r.mass,
            "failures_by_reason": dict(r.failures_by_reason), "reused": r.reused}


def _row(label, design, info, validation, evaluation) -> dict:
    return {"design": label, "evaluation": evaluation, "x": design.to_dict(),
            "mass": info.get("mass"), "mean_completion_time": info.get("mean_completion_time"),
            "p_success": info.get("p_success"), "successes": info.get("successes"),
            "samples": info.get("samples"), "ci": [info.get("ci_low"), info.get("ci_high")],
            "validation": validation}


def _write_history(path: Path, history, case: Case) -> None:
    from tethernet_ros.core.design import VARIABLE_NAMES

    head = (["evaluation", "phase", *VARIABLE_NAMES, "objective", "p_success", "successes",
             "samples", "feasible", "mass", "mean_completion_time", "probability_feasible",
             "eiplus_tries", "wall_time"])
    lines = [",".join(head)]
    for i, o in enumerate(history, 1):
        a, info = o.acquisition, o.info
        vals = [i, a.get("phase", ""), *[f"{v:.10g}" for v in o.x], f"{o.objective:.10g}",
                f"{o.constraints[P_SUCCESS]:.6g}", info.get("successes", ""),
                info.get("samples", ""), int(o.feasible), _fmt(info.get("mass")),
                _fmt(info.get("mean_completion_time")), _fmt(a.get("probability_feasible")),
                a.get("eiplus_tries", ""), _fmt(info.get("wall_time"))]
        lines.append(",".join(str(v) for v in vals))
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")
    os.replace(tmp, path)


def _fmt(v) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return ""
    return f"{v:.6g}" if isinstance(v, float) else str(v)
