"""One evaluated design (:class:`Observation`) and the value and known variance of a
success probability estimated from Monte Carlo samples (:func:`binomial_observation`)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from collections.abc import Mapping

import numpy as np

from .jsonio import json_clean

__all__ = ["Observation", "binomial_observation", "wilson_interval", "Z95"]

#: the standard normal's 97.5 % quantile (scipy.stats.norm.ppf(0.975)): two-sided 95 %
Z95 = 1.959963984540054


def binomial_observation(successes: int, trials: int) -> tuple[float, float]:
    """Value and observation variance of a success probability estimated from trials.

    Returns ``(k/N, p_adj (1 - p_adj) / N)`` with the Laplace-smoothed ``p_adj =
    (k + 1) / (N + 2)`` (posterior mean under a uniform prior, the Agresti-Coull idea
    with one pseudo-success and one pseudo-failure). The plain plug-in variance
    ``p(1-p)/N`` would claim zero noise at ``k = N`` (or ``k = 0``), which is exactly
    where a reliability constraint ``P_s >= 0.98`` is decided; the smoothed value keeps a
    principled floor (``N = 100``, ``k = 100``: std 0.0098, about one
    success in ``N``), and equals the plug-in variance to within ``O(1/N)`` elsewhere
    (``k = 98``: std 0.0149 versus 0.0140).
    """
    k, n = int(successes), int(trials)
    if n <= 0 or not 0 <= k <= n:
        raise ValueError(f"need 0 <= successes <= trials and trials > 0, got {k}/{n}")
    p_adj = (k + 1.0) / (n + 2.0)
    return k / n, p_adj * (1.0 - p_adj) / n


def wilson_interval(successes: int, trials: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval (95 % by default) of a success probability from ``successes``
    of ``trials``; (0, 1) without trials.  The formula of the simulator's results
    (``tethernet_ros.core.metrics.wilson_interval``), here so that the optimiser needs
    nothing of the simulator."""
    k, n = int(successes), int(trials)
    if n <= 0:
        return 0.0, 1.0
    p = k / n
    den = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return max(0.0, centre - half), min(1.0, centre + half)


@dataclass
class Observation:
    """One evaluated design.

    Attributes:
        x: design in the problem's own units, shape ``(d,)``.
        objective: objective value (to be minimised), own units.
        constraints: coupled constraint values by name (feasible if value >= threshold).
        constraint_variances: known observation variance of each constraint value (units
            squared); a constraint absent here has unknown noise (fitted by its GP).
        feasible: every observed constraint value met its threshold.
        info: free-form JSON-serialisable data returned by the evaluated function.
        acquisition: how the optimiser chose ``x`` (phase, acquisition value, EI+ tries,
            model predictions); empty if ``x`` was not produced by
            :meth:`optimizer.bayesopt.ConstrainedBayesOpt.ask`.
    """

    x: np.ndarray
    objective: float
    constraints: dict[str, float]
    constraint_variances: dict[str, float]
    feasible: bool
    info: dict = field(default_factory=dict)
    acquisition: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {
            "x": [float(v) for v in self.x],
            "objective": float(self.objective),
            "constraints": {k: float(v) for k, v in self.constraints.items()},
            "constraint_variances": {k: float(v) for k, v in self.constraint_variances.items()},
            "feasible": bool(self.feasible),
            "info": json_clean(self.info),
            "acquisition": json_clean(self.acquisition),
        }

    @classmethod
    def from_dict(cls, d: Mapping) -> Observation:
        return cls(
            x=np.asarray(d["x"], dtype=float),
            objective=float(d["objective"]),
            constraints={k: float(v) for k, v in d["constraints"].items()},
            constraint_variances={k: float(v) for k, v in d["constraint_variances"].items()},
            feasible=bool(d["feasible"]),
            info=dict(d.get("info", {})),
            acquisition=dict(d.get("acquisition", {})),
        )
