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
from .settings import fresh_base_seed

__all__ = ["DesignEvaluator"]


class DesignEvaluator:
    """``fun(x)`` of :func:`optimizer.loop.minimize` for a case on a design problem.

    Per-sample results go to ``results_path`` (samples already there for the same design
    are reused, so a design that was in flight when a run was killed is finished, not
    restarted).  ``calls`` counts evaluations and ``last_result`` holds the latest
    estimate.  ``progress(done, total)`` is called per finished sample.  ``fresh``,
    ``first_evaluation``: fresh samples per evaluation (module docstring);
    ``next_evaluation`` is the number of the next call's evaluation.
    """

    def __init__(self, case: Case | str, problem: DesignProblem, samples: int, base_seed: int,
                 results_path=None, progress: Callable[[int, int], None] | None = None,
                 sequential: bool = False, fresh: bool = False, first_evaluation: int = 1):
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
        self.cheap_constraint = self.case.cheap_constraint(problem.mass)

    def estimate(self, x, label: str = "", stop=None):
        """The problem's reliability estimate of ``x`` on the optimisation samples."""
        return self.problem.evaluate(np.asarray(x, dtype=float), self.samples, self.base_seed,
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
        if self.fresh:
            base = fresh_base_seed(self.base_seed, self.next_evaluation)
            r = self.problem.evaluate(x, self.samples, base, stop=rule,
                                      results_path=self.results_path, progress=self.progress)
        else:
            r = self.estimate(x, stop=rule)
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
            "samples_planned": self.samples,
        }
        if self.fresh:
            info["base_seed"] = r.base_seed
        return objective, {P_SUCCESS: value}, {P_SUCCESS: var}, json_clean(info)
