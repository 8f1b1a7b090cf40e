"""The end of a run: choose the best design, validate it with fresh samples, build the
summary and write the results table and the convergence figure."""
from __future__ import annotations

from .cases import P_SUCCESS, VALIDATION_RULES, validation_rule_text
from .report import plot_convergence, write_results
from .selection import rank_candidates, validation_evidence
from .sequential import SequentialRule

__all__ = ["finish_run", "meets_requirement", "sampling_counts"]


def finish_run(case, opt, stopped, paths, settings, problem, evaluator, emit, min_probability,
               compare_reference) -> dict:
    """The run's summary (see :func:`optimizer.run.run_optimization`); writes
    results.csv / results.md and convergence.png.  The ranked designs
    (:func:`optimizer.selection.rank_candidates`) are validated in turn until one meets
    C_P, at most ``settings["validation_candidates"]`` (default 1) of them, ranked again
    after each failure with the failed validations as evidence (module docstring of
    :mod:`optimizer.selection`); the first that meets C_P is the run's result, else the
    first validated.  Every validated design is a row of the table.  ``settings
    ["validation_rule"]`` says how a validation meets C_P (:func:`meets_requirement`); with
    ``settings["validation_stop"]`` a validation stops at the failure that decides it
    misses C_P (:class:`optimizer.sequential.SequentialRule` at the validation's size), its
    P*_s then over the samples drawn ("stopped" in its dict)."""
    ranked, rule = rank_candidates(opt, min_probability)
    best = ranked[0] if ranked else None
    feasible = [o for o in opt.history if o.feasible]
    validation = None
    rows = []
    val_n = settings["validation_samples"]
    n_candidates = max(1, int(settings.get("validation_candidates", 1)))
    v_rule = settings.get("validation_rule", "estimate")
    # with validation_stop, a validation ends at the failure that decides it misses C_P
    # (by either rule: a design below C_P by its estimate is below it by its Wilson bound)
    v_stop = (SequentialRule(val_n, case.p_threshold, stop_when_feasible=False)
              if val_n and settings.get("validation_stop") else None)

    def validate(x, label):
        def prog(done, total):
            emit({"stage": "validation", "label": label, "done": done, "total": total})
        return problem.evaluate(x, val_n, settings["validation_seed"], stop=v_stop,
                                results_path=paths["validation"], label=label, progress=prog)

    if best is not None:
        tried = []
        vres = None
        if val_n and not stopped:
            tried = _validate_in_turn(opt, ranked, min_probability, validate, case,
                                      n_candidates, v_rule)
            # the first design that met C_P, if any (the last one tried), else the first
            best, vres = (tried[-1] if meets_requirement(tried[-1][1], case, v_rule)
                          else tried[0])
        if n_candidates > 1:
            rule += (f"; validated in turn until one met C_P = {case.p_threshold:g}"
                     f"{validation_rule_text(v_rule)}, the ranking redone after each failure with its "
                     f"validation in the constraint GP's data ({len(tried)} of at most "
                     f"{n_candidates} validated)")
        validation = _validation_dict(vres, case, v_rule, val_n)
        rows.append(_row(f"best (Case {case.number})", problem.design_dict(best.x), best.info,
                         validation, evaluation=_index(opt.history, best)))
        for cand, r in tried:
            if cand is not best:
                rows.append(_row(f"candidate (evaluation {_index(opt.history, cand)}), failed "
                                 "validation", problem.design_dict(cand.x), cand.info,
                                 _validation_dict(r, case, v_rule, val_n),
                                 evaluation=_index(opt.history, cand)))
    ref = problem.reference_design(case.reference) if case.reference else None
    if compare_reference and not stopped and ref is not None:
        emit({"stage": "validation", "label": f"reference {case.reference}", "done": 0,
              "total": evaluator.samples})
        r = evaluator.estimate(ref, label=case.reference)
        info = {"successes": r.successes, "samples": r.n_samples, "p_success": r.p_success,
                "ci_low": r.ci_low, "ci_high": r.ci_high, "mass": r.mass,
                "mean_completion_time": r.mean_completion_time}
        vref = _validation_dict(validate(ref, case.reference) if val_n else None, case,
                                v_rule, val_n)
        rows.append(_row(f"reference {case.reference} (docs/model.md §9)", problem.design_dict(ref), info,
                         vref, evaluation=None))

    summary = {
        "case": case.name, "case_number": case.number, "problem": case.describe(),
        "p_threshold": case.p_threshold,
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
        "files": {k: str(v) for k, v in paths.items()}, "backend": problem.describe(),
        "variables": list(problem.variable_names),
        "published": ({"design": case.reference, **po} if case.reference and
                      (po := problem.published_outcome(case.reference)) else None),
        **sampling_counts(opt.history, settings["samples"], settings["sequential"]),
        "validation_candidates": n_candidates, "validation_rule": v_rule,
        "validation_samples": val_n, "validation_stop": bool(settings.get("validation_stop")),
    }
    if best is not None:
        summary.update({
            "best_design": problem.design_dict(best.x), "best_vector": [float(v) for v in best.x],
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


def _validate_in_turn(opt, ranked, min_probability, validate, case, n_candidates: int,
                      rule: str) -> list:
    """Validate the ranked designs in turn until one meets C_P (by ``rule``), at most
    ``n_candidates``; after each failure its validation joins the constraint GP's data and
    the designs are ranked again.  Returns the (observation, validation result) pairs in
    the order validated."""
    tried = []
    evidence = []                            # the failed validations, for the GP
    order = ranked
    while len(tried) < n_candidates:
        cand = next((o for o in order if all(o is not t for t, _ in tried)), None)
        if cand is None:
            break
        r = validate(cand.x, "best" if not tried else f"candidate {len(tried) + 1}")
        tried.append((cand, r))
        if meets_requirement(r, case, rule):
            break
        evidence.append(validation_evidence(cand, r.successes, r.n_samples, P_SUCCESS))
        if len(tried) < n_candidates:
            order, _ = rank_candidates(opt, min_probability, evidence)
    return tried


def sampling_counts(history, samples: int, sequential: bool) -> dict:
    """Samples the observations rest on (``episodes``) against ``samples`` for every
    design (``episodes_full``), and the difference (``episodes_saved``).  Samples drawn
    past a decision point (a batch's rest) are not counted: they depend on the worker
    count."""
    used = sum(int(o.info.get("samples", samples)) for o in history)
    full = len(history) * int(samples)
    return {"sampling": "sequential" if sequential else "full", "episodes": used,
            "episodes_full": full, "episodes_saved": full - used}


def meets_requirement(result, case, rule: str = "estimate") -> bool:
    """Whether a validation ``result`` meets the case's reliability requirement C_P: its
    P*_s over the fresh samples ("estimate", the source's test) or the lower end of its
    Wilson 95 % interval ("wilson") at least C_P.  The one home of that rule."""
    if rule not in VALIDATION_RULES:
        raise ValueError(f"validation rule {rule!r}: must be one of {', '.join(VALIDATION_RULES)}")
    value = result.ci_low if rule == "wilson" else result.p_success
    return value >= case.p_threshold



def _index(history, obs) -> int:
    """1-based evaluation number of ``obs`` (by identity)."""
    return next(i for i, o in enumerate(history, 1) if o is obs)


def _validation_dict(r, case, rule: str, planned: int) -> dict | None:
    if r is None:
        return None
    return {"meets_requirement": meets_requirement(r, case, rule), "samples": r.n_samples,
            "samples_planned": planned, "stopped": r.n_samples < planned,
            "base_seed": r.base_seed, "successes": r.successes,
            "p_success": r.p_success, "wilson": [r.ci_low, r.ci_high],
            "clopper_pearson": [r.cp_low, r.cp_high],
            "mean_completion_time": r.mean_completion_time, "mass": r.mass,
            "failures_by_reason": dict(r.failures_by_reason), "reused": r.reused}


def _row(label, design: dict, info, validation, evaluation) -> dict:
    return {"design": label, "evaluation": evaluation, "x": design,
            "mass": info.get("mass"), "mean_completion_time": info.get("mean_completion_time"),
            "p_success": info.get("p_success"), "successes": info.get("successes"),
            "samples": info.get("samples"), "ci": [info.get("ci_low"), info.get("ci_high")],
            "validation": validation}
