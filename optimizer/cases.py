"""The two design problems of docs/optimizer.md §1.

Both search the design vector X = [m_c, L_n, r_n, d_L, V_x, V_y, V_z, d_c] within the
bounds of a :class:`~optimizer.problem.DesignProblem` and require the success probability
P*_s(X) >= C_P = 0.98:

* **Case 1** (``"mass"``): minimise the system mass m_a(X) (kg).  m_a is exact (a formula
  of m_c, L_n, r_n), so only the P*_s constraint needs the simulation.
* **Case 2** (``"time"``): minimise the mean completion time T (s) over the Monte Carlo
  samples (an episode whose closing never triggers counts with T = horizon), subject also
  to m_a(X) <= C_m = 15 kg.  The mass constraint is the optimiser's *cheap* constraint:
  points that fail it are never proposed, so they are never simulated.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from collections.abc import Callable

import numpy as np

from .sequential import SequentialRule

__all__ = ["Case", "CASES", "CASE_MASS", "CASE_TIME", "get_case", "P_SUCCESS",
           "VALIDATION_RULES", "validation_rule_text"]

#: name of the modelled constraint (observed P*_s = k/N)
P_SUCCESS = "p_success"

#: How a validation meets the requirement C_P: by its estimate P*_s over the fresh samples
#: (the source's test) or by the lower end of its Wilson 95 % interval
#: (``optimizer.finish.meets_requirement`` applies them).
VALIDATION_RULES = ("estimate", "wilson")


def validation_rule_text(rule: str | None) -> str:
    """The rule as the words that follow "meets C_P = 0.98" in reports ("" for the
    source's test)."""
    return " by the lower end of its Wilson 95 % interval" if rule == "wilson" else ""


@dataclass(frozen=True)
class Case:
    """One optimisation problem of docs/optimizer.md §1.

    name: ``"mass"`` (Case 1) or ``"time"`` (Case 2); objective: ``"mass"`` (m_a, kg) or
    ``"mean_completion_time"`` (mean T, s); p_threshold: C_P; mass_limit: C_m (kg) or None;
    reference: name of the docs/model.md §9 design found by the source for this case.
    """

    name: str
    number: int
    title: str
    objective: str
    objective_label: str
    objective_unit: str
    p_threshold: float = 0.98
    mass_limit: float | None = None
    reference: str = ""

    @property
    def constraints(self) -> dict[str, float]:
        """Modelled (expensive, noisy) constraints: ``{"p_success": C_P}``."""
        return {P_SUCCESS: self.p_threshold}

    @property
    def objective_from_samples(self) -> bool:
        """True when the objective is estimated from the samples (mean T), False when it
        is exact (m_a)."""
        return self.objective != "mass"

    def cheap_constraint(self, mass: Callable[[np.ndarray], float]
                         ) -> Callable[[np.ndarray], bool] | None:
        """``f(x) -> bool`` (``mass(x) <= C_m``, mass in kg) or None without a mass limit."""
        if self.mass_limit is None:
            return None
        limit = float(self.mass_limit)

        def mass_ok(x) -> bool:
            return mass(x) <= limit

        mass_ok.__name__ = f"mass_at_most_{limit:g}kg"
        return mass_ok

    def sequential_rule(self, samples: int) -> SequentialRule:
        """The stopping rule of sequential sampling for N_MC = ``samples``: infeasible at
        the first failure past the allowed number; feasible early only when the objective
        does not come from the samples (:mod:`optimizer.sequential`)."""
        return SequentialRule(samples, self.p_threshold,
                              stop_when_feasible=not self.objective_from_samples)

    def objective_value(self, result) -> float:
        """Objective of a :class:`~optimizer.problem.ReliabilityEstimate`.

        Case 1: m_a (exact).  Case 2: mean T over the samples; NaN if no sample has a
        finite T (every sample a worker error).
        """
        if self.objective == "mass":
            return float(result.mass)
        t = float(result.mean_completion_time)
        return t if math.isfinite(t) else float("nan")

    def describe(self) -> str:
        extra = f" and m_a <= {self.mass_limit:g} kg" if self.mass_limit is not None else ""
        return (f"Case {self.number}: minimise {self.objective_label} s.t. "
                f"P*_s >= {self.p_threshold:g}{extra}")


CASE_MASS = Case(name="mass", number=1, title="mass-minimised", objective="mass",
                 objective_label="m_a", objective_unit="kg", reference="mass-min")
CASE_TIME = Case(name="time", number=2, title="time-minimised", objective="mean_completion_time",
                 objective_label="mean T", objective_unit="s", mass_limit=15.0,
                 reference="time-min")
CASES: dict[str, Case] = {"mass": CASE_MASS, "time": CASE_TIME}


def get_case(name: str | Case) -> Case:
    """A case by name (``mass``/``1`` or ``time``/``2``)."""
    if isinstance(name, Case):
        return name
    key = {"1": "mass", "2": "time", "case1": "mass", "case2": "time"}.get(str(name).lower(),
                                                                         str(name).lower())
    if key not in CASES:
        raise ValueError(f"case {name!r}: allowed cases are 'mass' (Case 1) and 'time' (Case 2)")
    return CASES[key]
