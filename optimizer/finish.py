"""The end of a run, a function per job: choose the design and validate it with fresh
samples (:func:`choose_design`, :class:`Validator`), build the table's rows and the
summary, write the results table and the convergence figure (:func:`finish_run`)."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from .cases import P_SUCCESS, VALIDATION_RULES, validation_rule_text
from .report import plot_convergence, write_results
from .racing import RaceResult, race
from .selection import rank_candidates, validation_evidence
from .sequential import SequentialRule, pass_level

__all__ = ["finish_run", "meets_requirement", "sampling_counts", "Validator", "Choice",
           "choose_design"]


def finish_run(case, opt, stopped, paths, settings, problem, evaluator, emit) -> dict:
    """The run's summary (see :func:`optimizer.run.run_optimization`); writes
    results.csv / results.md and convergence.png.

    Args:
        case: the :class:`~optimizer.cases.Case`; opt: the optimiser after the run;
        stopped: the run was stopped early (nothing is validated);
        paths: the run's files (:data:`optimizer.run.RUN_FILES`);
        settings: the run's resolved :class:`~optimizer.settings.RunSettings`;
        problem: the :class:`~optimizer.problem.DesignProblem`;
        evaluator: the run's :class:`~optimizer.evaluator.DesignEvaluator` (for the
            reference design on the optimisation samples);
        emit: ``emit(event)``, the run's progress events.
    """
    # racing and validation run on the problem as given, the reference fidelity, whatever
    # the search ran at (RunSettings refuses another fidelity for them); their samples are
    # of seeds and files of their own, so no optimisation sample is reused by them
    validator = Validator(case, problem, settings, paths["validation"], emit)
    choice = choose_design(case, opt, stopped, settings, validator,
                           _racer(case, opt, problem, settings, paths["racing"], emit))
    rows = _design_rows(case, opt, problem, choice, validator)
    if settings.compare_reference and not stopped:
        rows += _reference_rows(case, problem, evaluator, validator, emit)
    summary = _summary(case, opt, stopped, paths, settings, problem, choice, rows)
    write_results(paths["results_csv"], paths["results_md"], summary)
    plot_convergence(paths["convergence"], opt.history, case, choice.best,
                     choice.validation["p_success"] if choice.validation else None)
    return summary


def _racer(case, opt, problem, settings, results_path, emit):
    """``racer(candidates)``: :func:`optimizer.racing.race` on the problem, its samples of
    base seed ``settings.racing_seed`` appended to ``results_path``."""
    def sample(obs, n):
        label = f"racing evaluation {_index(opt.history, obs)}"

        def prog(done, total):
            emit({"stage": "validation", "label": label, "done": done, "total": total})
        return problem.evaluate(obs.x, n, settings.racing_seed, results_path=results_path,
                                label=label, progress=prog)

    def racer(candidates):
        return race(candidates, sample, case.p_threshold, settings.racing_round,
                    settings.racing_budget,
                    max_samples=settings.racing_max_samples or settings.validation_samples,
                    clear_level=selection_level(case, settings))
    return racer


def selection_level(case, settings) -> float | None:
    """The P*_s the final ranking and the race are taken against: None (C_P itself) for
    ``selection_level`` "requirement", else the true P*_s at which the run's validation
    passes half the time (:func:`optimizer.sequential.pass_level`)."""
    if settings.selection_level == "requirement" or not settings.validation_samples:
        return None
    return pass_level(settings.validation_samples, case.p_threshold, settings.validation_rule)


class Validator:
    """Validations of a run: ``validator(x, label)`` evaluates design ``x`` on the
    validation samples (``settings.validation_samples`` of base seed
    ``settings.validation_seed``, appended to ``results_path``).  With
    ``settings.validation_stop`` a validation ends at the failure that decides it misses
    C_P by the run's rule (:class:`~optimizer.sequential.SequentialRule` at the
    validation's size: for 1000 samples at 98 %, the 21st failure by the estimate, the
    12th by the Wilson rule), its P*_s then over the samples drawn."""

    def __init__(self, case, problem, settings, results_path, emit):
        self.case, self.problem, self.settings = case, problem, settings
        self.results_path, self.emit = results_path, emit
        self.samples = settings.validation_samples
        self.rule = settings.validation_rule
        self.stop = (SequentialRule(self.samples, case.p_threshold, stop_when_feasible=False,
                                    rule=self.rule)
                     if self.samples and settings.validation_stop else None)

    def __call__(self, x, label: str):
        def prog(done, total):
            self.emit({"stage": "validation", "label": label, "done": done, "total": total})
        return self.problem.evaluate(x, self.samples, self.settings.validation_seed,
                                     stop=self.stop, results_path=self.results_path,
                                     label=label, progress=prog)

    def meets(self, result) -> bool:
        """Whether ``result`` meets C_P by the run's rule (:func:`meets_requirement`)."""
        return meets_requirement(result, self.case, self.rule)

    def as_dict(self, result) -> dict | None:
        """A validation result as the summary and the table record it."""
        return _validation_dict(result, self.case, self.rule, self.samples)


@dataclass
class Choice:
    """The run's chosen design: ``best`` (an observation of the history, or None),
    ``result`` (its validation, or None), ``tried`` (every (observation, validation)
    pair, in the order validated), ``rule`` (the words that say how it was chosen),
    ``validation`` (``result`` as a dict) and ``race`` (the race before the validations,
    or None)."""

    best: object = None
    result: object = None
    tried: list = field(default_factory=list)
    rule: str = ""
    validation: dict | None = None
    race: RaceResult | None = None


def choose_design(case, opt, stopped, settings, validator: Validator,
                  racer: Callable[[list], RaceResult] | None = None) -> Choice:
    """Rank the designs (:func:`optimizer.selection.rank_candidates`), race the first
    ``settings.racing_candidates`` of them with ``racer`` (:mod:`optimizer.racing`; the
    ranking then redone with their racing samples, the dropped ones removed, the winner
    first) and validate them in turn until one meets C_P, at most
    ``settings.validation_candidates`` of them, ranked again after each failure with the
    failed validations as evidence too (module docstring of :mod:`optimizer.selection`);
    the first that meets C_P is the run's result, else the first validated.  Nothing is
    raced or validated when the run was stopped or has no validation samples."""
    level = selection_level(case, settings)
    ranked, rule = rank_candidates(opt, settings.min_probability, level=level)
    choice = Choice(best=ranked[0] if ranked else None, rule=rule)
    if choice.best is None:
        return choice
    evidence, reorder = [], list
    if settings.racing_candidates and validator.samples and not stopped and racer is not None:
        k = settings.racing_candidates
        choice.race = racer(ranked[:k])
        evidence, reorder = choice.race.evidence(), choice.race.order
        again, _ = rank_candidates(opt, settings.min_probability, evidence, level)
        ranked = reorder(again) or reorder(ranked) or ranked
        choice.best = ranked[0]
        r = choice.race
        choice.rule += (f"; the first {min(k, len(r.entries))} raced on fresh samples "
                        f"({r.episodes} samples in {r.rounds} rounds, "
                        f"{sum(e.status == 'dropped' for e in r.entries)} dropped, "
                        + (f"evaluation {_index(opt.history, r.winner.candidate)} cleared C_P"
                           if r.winner else f"none cleared C_P: {r.stopped_by}") + ")")
    n_candidates = settings.validation_candidates
    if validator.samples and not stopped:
        choice.tried = _validate_in_turn(opt, ranked, settings.min_probability, validator,
                                         case, n_candidates, validator.rule, evidence,
                                         reorder, level)
        # the first design that met C_P, if any (the last one tried), else the first
        last = choice.tried[-1]
        choice.best, choice.result = last if validator.meets(last[1]) else choice.tried[0]
    if n_candidates > 1:
        choice.rule += (f"; validated in turn until one met C_P = {case.p_threshold:g}"
                        f"{validation_rule_text(validator.rule)}, the ranking redone after "
                        f"each failure with its validation in the constraint GP's data "
                        f"({len(choice.tried)} of at most {n_candidates} validated)")
    choice.validation = validator.as_dict(choice.result)
    return choice


def _design_rows(case, opt, problem, choice: Choice, validator: Validator) -> list[dict]:
    """The table's rows of the chosen design and of every design that failed validation."""
    if choice.best is None:
        return []
    rows = [_row(f"best (Case {case.number})", problem.design_dict(choice.best.x),
                 choice.best.info, choice.validation,
                 evaluation=_index(opt.history, choice.best))]
    for cand, r in choice.tried:
        if cand is not choice.best:
            rows.append(_row(f"candidate (evaluation {_index(opt.history, cand)}), failed "
                             "validation", problem.design_dict(cand.x), cand.info,
                             validator.as_dict(r), evaluation=_index(opt.history, cand)))
    return rows


def _reference_rows(case, problem, evaluator, validator: Validator, emit) -> list[dict]:
    """The row of the case's reference design (docs/model.md §9) on the optimisation
    samples and validated; none when the problem has no such design."""
    ref = problem.reference_design(case.reference) if case.reference else None
    if ref is None:
        return []
    emit({"stage": "validation", "label": f"reference {case.reference}", "done": 0,
          "total": evaluator.samples})
    r = evaluator.estimate(ref, label=case.reference)
    info = {"successes": r.successes, "samples": r.n_samples, "p_success": r.p_success,
            "ci_low": r.ci_low, "ci_high": r.ci_high, "mass": r.mass,
            "mean_completion_time": r.mean_completion_time}
    vref = validator.as_dict(validator(ref, case.reference) if validator.samples else None)
    return [_row(f"reference {case.reference} (docs/model.md §9)", problem.design_dict(ref),
                 info, vref, evaluation=None)]


def _summary(case, opt, stopped, paths, settings, problem, choice: Choice, rows) -> dict:
    """The run's summary dict (summary.json, less the timings)."""
    best = choice.best
    summary = {
        "case": case.name, "case_number": case.number, "problem": case.describe(),
        "p_threshold": case.p_threshold,
        "status": "stopped" if stopped else "complete",
        "evaluations": len(opt.history), "seed_points": opt.n_initial,
        "iterations": opt.n_iterations, "samples": settings.samples,
        "sample_seed": settings.sample_seed, "seed": settings.seed,
        "feasible_evaluations": sum(1 for o in opt.history if o.feasible),
        "selection_rule": choice.rule,
        "objective_name": case.objective, "objective_unit": case.objective_unit,
        "best_design": None, "best_vector": None, "best_evaluation": None,
        "best_objective": None, "p_success": None, "p_success_ci": None, "successes": None,
        "mass": None, "mean_completion_time": None, "validation": choice.validation,
        "table": rows, "run_dir": str(paths["settings"].parent),
        "scenario": getattr(problem, "scenario", lambda: "")(),
        "files": {k: str(v) for k, v in paths.items()}, "backend": problem.describe(),
        "variables": list(problem.variable_names),
        "published": ({"design": case.reference, **po} if case.reference and
                      (po := problem.published_outcome(case.reference)) else None),
        **sampling_counts(opt.history, settings.samples, settings.sequential),
        "validation_candidates": settings.validation_candidates,
        "validation_rule": settings.validation_rule,
        "validation_samples": settings.validation_samples,
        "validation_stop": bool(settings.validation_stop),
        "fresh_samples": bool(settings.fresh_samples),
        "selection_level": settings.selection_level,
        "fidelity": dict(getattr(settings, "fidelity", {}) or {}),
        "racing": (choice.race.to_dict(lambda o: _index(opt.history, o))
                   if choice.race is not None else None),
    }
    summary["episodes_racing"] = choice.race.episodes if choice.race is not None else 0
    summary["episodes_validation"] = sum(int(r.n_samples) for _, r in choice.tried)
    summary["episodes_total"] = (summary["episodes"] + summary["episodes_racing"]
                                 + summary["episodes_validation"])
    if best is not None:
        summary.update({
            "best_design": problem.design_dict(best.x), "best_vector": [float(v) for v in best.x],
            "best_evaluation": _index(opt.history, best), "best_objective": best.objective,
            "p_success": best.constraints[P_SUCCESS], "successes": best.info.get("successes"),
            "p_success_ci": [best.info.get("ci_low"), best.info.get("ci_high")],
            "mass": best.info.get("mass"),
            "mean_completion_time": best.info.get("mean_completion_time"),
        })
    return summary


def _validate_in_turn(opt, ranked, min_probability, validate, case, n_candidates: int,
                      rule: str, evidence=(), reorder=list, level=None) -> list:
    """Validate the ranked designs in turn until one meets C_P (by ``rule``), at most
    ``n_candidates``; after each failure its validation joins the constraint GP's data
    (beside ``evidence``, e.g. the racing samples) and the designs are ranked again (then
    put in order by ``reorder``, e.g. :meth:`RaceResult.order`).  Returns the
    (observation, validation result) pairs in the order validated."""
    tried = []
    evidence = list(evidence)                # racing samples and failed validations
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
            order = reorder(rank_candidates(opt, min_probability, evidence, level)[0])
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
