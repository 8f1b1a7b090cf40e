"""The two design problems of SPEC section 7 on top of the Monte Carlo evaluator.

Both search X = [m_c, L_n, r_n, d_L, V_x, V_y, V_z, d_c] (``VARIABLE_NAMES``) within
``DESIGN_BOUNDS`` and require the success probability P*_s(X) >= 0.98:

* **Case 1** (``"mass"``): minimise the system mass m_a(X).  m_a is exact (a formula of
  m_c, L_n, r_n), so only the P*_s constraint needs the simulation.
* **Case 2** (``"time"``): minimise the mean completion time T over the Monte Carlo samples
  (an episode whose closing never triggers counts with T = horizon), subject also to
  m_a(X) <= 15 kg.  The mass constraint is the optimiser's *cheap* constraint: points that
  fail it are never proposed, so they are never simulated.

The expensive evaluation of a design is :func:`tethernet_ros.montecarlo.evaluate` with N
samples of one base seed (common random numbers: every design sees the same noise draws)
on an :class:`~tethernet_ros.montecarlo.EpisodeBackend` passed in; this module depends on
that interface only.  The constraint is observed as ``k/N`` with the binomial variance of
:func:`optimizer.binomial_observation`, which the constraint GP takes as known noise.

Choice of the final design (:func:`select_best`), given that P*_s is noisy: among the
evaluated designs whose observed P*_s met 0.98, keep those whose constraint GP (latent
posterior, binomial noise removed, evidence of neighbouring designs pooled) gives a
probability of at least ``min_probability`` (default 0.5) that the true P*_s >= 0.98; take
the lowest objective (earliest on ties).  If that filter leaves nothing, fall back to the
plain observed-feasible rule and say so.  Either way the winner is then validated with
fresh samples (SPEC: 1000) by :mod:`optimizer.run`; the validated P*_s and its interval are
what the results table reports.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import DESIGN_BOUNDS, VARIABLE_NAMES, Design, system_mass
from tethernet_ros.core.noise import NoiseModel

from .bayesopt import ConstrainedBayesOpt, Observation, binomial_observation

__all__ = ["Case", "CASES", "CASE_MASS", "CASE_TIME", "get_case", "DesignEvaluator",
           "select_best", "P_SUCCESS"]

#: name of the modelled constraint (observed P*_s = k/N)
P_SUCCESS = "p_success"


@dataclass(frozen=True)
class Case:
    """One optimisation problem of SPEC section 7.

    name: ``"mass"`` (Case 1) or ``"time"`` (Case 2); objective: ``"mass"`` (m_a, kg) or
    ``"mean_completion_time"`` (mean T, s); p_threshold: C_P; mass_limit: C_m (kg) or None;
    reference: name of the SPEC section 8 design found by the source for this case.
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
    def bounds(self) -> list[tuple[float, float]]:
        """Search box in the order of ``VARIABLE_NAMES``."""
        return [tuple(DESIGN_BOUNDS[n]) for n in VARIABLE_NAMES]

    @property
    def constraints(self) -> dict[str, float]:
        """Modelled (expensive, noisy) constraints: ``{"p_success": C_P}``."""
        return {P_SUCCESS: self.p_threshold}

    def cheap_constraint(self, density: float) -> Callable[[np.ndarray], bool] | None:
        """``f(x) -> bool`` (m_a(x) <= C_m with thread density ``density``) or None."""
        if self.mass_limit is None:
            return None
        limit = float(self.mass_limit)
        rho = float(density)

        def mass_ok(x) -> bool:
            return system_mass(float(x[0]), float(x[1]), float(x[2]), rho) <= limit

        mass_ok.__name__ = f"mass_at_most_{limit:g}kg"
        return mass_ok

    def objective_value(self, result) -> float:
        """Objective of a :class:`~tethernet_ros.montecarlo.MonteCarloResult`.

        Case 1: m_a (exact).  Case 2: mean T over the samples; if no sample has a finite T
        (every sample a worker error) the horizon is used, the T of a failed capture.
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


class DesignEvaluator:
    """The expensive function ``fun(x)`` of :func:`optimizer.minimize` for a case.

    Each call runs ``montecarlo.evaluate`` on ``samples`` samples of ``base_seed`` (the same
    seeds for every design) on ``backend`` and returns ``(objective, {"p_success": k/N},
    {"p_success": binomial variance}, info)``.  Per-sample results go to ``results_path``
    (JSON lines; samples already there for the same design are reused, so a design that was
    in flight when a run was killed is finished, not restarted).

    ``calls`` counts evaluations and ``last_result`` holds the latest
    :class:`~tethernet_ros.montecarlo.MonteCarloResult`.  ``progress(done, total)`` is
    called per finished sample.
    """

    def __init__(self, case: Case, backend, samples: int, base_seed: int,
                 noise_model: NoiseModel | None = None, config: SimConfig | None = None,
                 results_path=None, progress: Callable[[int, int], None] | None = None):
        self.case = get_case(case)
        self.backend = backend
        self.samples = int(samples)
        self.base_seed = int(base_seed)
        self.noise_model = noise_model or NoiseModel()
        self.config = config or SimConfig()
        self.results_path = results_path
        self.progress = progress
        self.calls = 0
        self.last_result = None
        self.cheap_constraint = self.case.cheap_constraint(self.config.density)

    def evaluate_design(self, design: Design, label: str = ""):
        """MonteCarloResult of ``design`` on the optimisation samples."""
        from tethernet_ros import montecarlo

        def prog(done, total, _result):
            if self.progress is not None:
                self.progress(done, total)

        return montecarlo.evaluate(design, self.samples, self.base_seed, self.noise_model,
                                   self.config, self.backend, results_path=self.results_path,
                                   label=label, progress=prog)

    def __call__(self, x):
        x = np.asarray(x, dtype=float)
        if self.cheap_constraint is not None and not self.cheap_constraint(x):
            # the optimiser never proposes such points; refuse rather than spend samples
            raise ValueError(f"design {x.tolist()} violates the cheap constraint "
                             f"m_a <= {self.case.mass_limit:g} kg and must not be simulated")
        design = Design.from_vector(x)
        t0 = time.perf_counter()
        r = self.evaluate_design(design)
        self.calls += 1
        self.last_result = r
        value, var = binomial_observation(r.successes, r.n_samples)
        objective = self.case.objective_value(r)
        if not math.isfinite(objective):
            objective = float(self.config.horizon)
        info = {
            "successes": r.successes, "samples": r.n_samples, "p_success": r.p_success,
            "ci_low": r.ci_low, "ci_high": r.ci_high, "mass": r.mass,
            "mean_completion_time": r.mean_completion_time,
            "mean_completion_time_success": r.mean_completion_time_success,
            "failures_by_reason": dict(r.failures_by_reason), "key": r.key,
            "reused_samples": r.reused, "wall_time": time.perf_counter() - t0,
        }
        info = {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in info.items()}
        return objective, {P_SUCCESS: value}, {P_SUCCESS: var}, info


def select_best(opt: ConstrainedBayesOpt, min_probability: float | None = 0.5
                ) -> tuple[Observation | None, str]:
    """The design to validate and the rule that chose it (see the module docstring).

    Returns ``(observation, rule)``; ``(None, "no evaluated design met the constraints")``
    when no evaluation was observed feasible.
    """
    plain = opt.best_feasible()
    if plain is None:
        return None, "no evaluated design met the constraints"
    if min_probability is None or len(opt.history) < 2:
        return plain, "lowest objective among observed-feasible designs"
    try:
        pooled = opt.best_feasible(min_probability=min_probability)
    except Exception:  # noqa: BLE001 - a GP fit failure must not lose the run's result
        return plain, ("lowest objective among observed-feasible designs "
                       "(constraint GP could not be fitted)")
    if pooled is None:
        return plain, (f"lowest objective among observed-feasible designs (none had a "
                       f"posterior probability of feasibility >= {min_probability:g})")
    return pooled, (f"lowest objective among designs with observed P*_s >= threshold and "
                    f"posterior probability of feasibility >= {min_probability:g}")
