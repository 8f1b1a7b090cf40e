"""The expensive function of a Case: one design -> one observation for the optimiser.

:class:`DesignEvaluator` asks a :class:`~optimizer.problem.DesignProblem` for the
reliability of a design over ``samples`` samples of one base seed (common random numbers:
every design sees the same noise draws) and turns it into ``(objective,
{"p_success": k/n}, {"p_success": binomial variance}, info)``, the constraint GP taking the
variance as known noise (:func:`~optimizer.observation.binomial_observation` with the n
samples the estimate rests on).

With ``fresh=True`` every evaluation gets samples of its own instead: evaluation ``j``
(1-based, counted from ``first_evaluation``) draws samples of base seed
:func:`~optimizer.settings.fresh_base_seed` (``base_seed``, j), so that its P*_s is
independent of every other design's (the constraint GP takes the observations as
independent; with common random numbers near-copies share their luck).

With ``sequential=True`` the samples are drawn in index order and a design's sampling stops
as soon as its feasibility at ``samples`` is decided (:mod:`optimizer.sequential`); the
observation then rests on the samples drawn up to the decision, ``info["samples"]`` of
``info["samples_planned"]``.

Fidelity (``fidelity``: phase -> name, :data:`~optimizer.settings.FIDELITY_PHASES`): the
first ``seed_points`` evaluations (counted like ``first_evaluation``) are the "initial"
phase, the rest the "iterations" phase; an evaluation runs on the problem at its phase's
fidelity (``problem.at_fidelity(name)``; the problem itself at the reference), and
``info["fidelity"]`` records which.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from .cases import P_SUCCESS, Case, get_case
from .jsonio import json_clean
from .observation import binomial_observation
from .problem import DesignProblem
from .settings import REFERENCE_FIDELITY, fresh_base_seed

__all__ = ["DesignEvaluator"]


class DesignEvaluator:
    """``fun(x)`` of :func:`optimizer.loop.minimize` for a case on a design problem.

    Per-sample results go to ``results_path`` (samples already there for the same design
    are reused, so a design that was in flight when a run was killed is finished, not
    restarted).  ``calls`` counts evaluations and ``last_result`` holds the latest
    estimate.  ``progress(done, total)`` is called per finished sample.  ``fresh``,
    ``first_evaluation``: fresh samples per evaluation (module docstring);
    ``next_evaluation`` is the number of the next call's evaluation.  ``fidelity``,
    ``seed_points``: the fidelity of each phase (module docstring; default: the
    reference throughout).
    """

    def __init__(self, case: Case | str, problem: DesignProblem, samples: int, base_seed: int,
                 results_path=None, progress: Callable[[int, int], None] | None = None,
                 sequential: bool = False, fresh: bool = False, first_evaluation: int = 1,
                 fidelity: dict | None = None, seed_points: int = 0):
        self.case = get_case(case)
        self.problem = problem
        self.samples = int(samples)
        self.base_seed = int(base_seed)
        self.results_path = results_path
        self.progress = progress
        self.sequential = bool(sequential)
        self.fresh = bool(fresh)
        self.next_evaluation = int(first_evaluation)
        self.calls = 0
        self.last_result = None
        self.fidelity = dict(fidelity or {})
        self.seed_points = int(seed_points)
        self._at = {REFERENCE_FIDELITY: problem}
        self.cheap_constraint = self.case.cheap_constraint(problem.mass)

    def phase_fidelity(self, phase: str) -> str:
        """The fidelity of ``phase`` ("initial", "iterations", ...)."""
        return self.fidelity.get(phase, REFERENCE_FIDELITY)

    def next_fidelity(self) -> str:
        """The fidelity of the next call's evaluation (by its phase)."""
        phase = "initial" if self.next_evaluation <= self.seed_points else "iterations"
        return self.phase_fidelity(phase)

    def problem_at(self, fidelity: str) -> DesignProblem:
        """The problem at ``fidelity`` (itself at the reference; ``problem.at_fidelity``
        otherwise, made once)."""
        if fidelity not in self._at:
            at = getattr(self.problem, "at_fidelity", None)
            if at is None:
                raise ValueError(f"fidelity {fidelity!r}: the problem has no fidelities "
                                 f"but {REFERENCE_FIDELITY!r}")
            self._at[fidelity] = at(fidelity)
        return self._at[fidelity]

    def estimate(self, x, label: str = "", stop=None):
        """The problem's reliability estimate of ``x`` on the optimisation samples, at the
        fidelity of the "iterations" phase (so that a design evaluated beside the run's,
        e.g. the reference design of the results table, is taken as the run's iterations
        took theirs)."""
        problem = self.problem_at(self.phase_fidelity("iterations"))
        return problem.evaluate(np.asarray(x, dtype=float), self.samples, self.base_seed,
                                stop=stop, results_path=self.results_path, label=label,
                                progress=self.progress)

    def __call__(self, x):
        x = np.asarray(x, dtype=float)
        if self.cheap_constraint is not None and not self.cheap_constraint(x):
            # the optimiser never proposes such points; refuse rather than spend samples
            raise ValueError(f"design {x.tolist()} violates the cheap constraint "
                             f"m_a <= {self.case.mass_limit:g} kg and must not be simulated")
        t0 = time.perf_counter()
        rule = self.case.sequential_rule(self.samples) if self.sequential else None
        fidelity = self.next_fidelity()
        problem = self.problem_at(fidelity)
        base = (fresh_base_seed(self.base_seed, self.next_evaluation) if self.fresh
                else self.base_seed)
        r = problem.evaluate(x, self.samples, base, stop=rule, results_path=self.results_path,
                             label="", progress=self.progress)
        self.next_evaluation += 1
        self.calls += 1
        self.last_result = r
        value, var = binomial_observation(r.successes, r.n_samples)
        objective = self.case.objective_value(r)
        if not math.isfinite(objective):
            objective = float(self.problem.horizon)
        info = {
            "successes": r.successes, "samples": r.n_samples, "p_success": r.p_success,
            "ci_low": r.ci_low, "ci_high": r.ci_high, "mass": r.mass,
            "mean_completion_time": r.mean_completion_time,
            "mean_completion_time_success": r.mean_completion_time_success,
            "failures_by_reason": dict(r.failures_by_reason), "key": r.key,
            "reused_samples": r.reused, "wall_time": time.perf_counter() - t0,
            "samples_planned": self.samples, "fidelity": fidelity,
        }
        if self.fresh:
            info["base_seed"] = r.base_seed
        return objective, {P_SUCCESS: value}, {P_SUCCESS: var}, json_clean(info)
