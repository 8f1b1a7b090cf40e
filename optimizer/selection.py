"""Choice of the final design of a run, given that P*_s is noisy.

Among the evaluated designs whose observed P*_s met C_P, keep those whose constraint GP
(latent posterior, binomial noise removed, evidence of neighbouring designs pooled) gives a
probability of at least ``min_probability`` (default 0.5) that the true P*_s >= C_P; take
the lowest objective (earliest on ties).  If that filter leaves nothing, fall back to the
plain observed-feasible rule and say so.  Either way the winner is then validated with
fresh samples (docs/optimizer.md §6: 1000) by :mod:`optimizer.finish`; the validated P*_s and its interval
are what the results table reports.  A design chosen from 100-sample estimates at the
constraint's edge may fail that validation (the lightest of many designs near C_P is the
luckiest); with ``validation_candidates`` K > 1 the run validates candidates in turn
until one meets C_P, at most K of them.  Each failed validation is evidence about its
neighbourhood too: it joins the constraint GP's data (:func:`validation_evidence`, P*_s
over the validation's samples with their own binomial variance) and the designs are ranked
again, so that neighbours of a design that failed lose posterior probability of
feasibility and may drop below the filter.  Its limit: the GP takes the optimisation
estimates of near-copies as independent, although they rest on the same common random
numbers and share their luck, so a cluster of near-copies observed feasible can outweigh
the validations (Case 1 at full budget: after the first and second failures the next
near-copy still passed the filter and failed in turn; two others dropped out;
docs/cases/README.md).
"""
from __future__ import annotations

from collections.abc import Sequence

from .bayesopt import ConstrainedBayesOpt
from .cases import P_SUCCESS
from .observation import Observation, binomial_observation

__all__ = ["rank_candidates", "select_best", "validation_evidence"]


def rank_candidates(opt: ConstrainedBayesOpt, min_probability: float | None = 0.5,
                    evidence: Sequence[Observation] = (), level: float | None = None
                    ) -> tuple[list[Observation], str]:
    """The designs to validate, best first, and the rule that ranked them (see the module
    docstring); ``([], "no evaluated design met the constraints")`` when no evaluation was
    observed feasible.  ``evidence``: failed validations (:func:`validation_evidence`)
    that the constraint GP is fitted to besides the history.  ``level``: the P*_s that
    the posterior probability is taken against instead of C_P (the selection level,
    :func:`optimizer.finish.selection_level`)."""
    plain = opt.ranked_feasible()
    if not plain:
        return [], "no evaluated design met the constraints"
    if min_probability is None or len(opt.history) < 2:
        return plain, "lowest objective among observed-feasible designs"
    try:
        pooled = opt.ranked_feasible(min_probability=min_probability, evidence=evidence,
                                     levels=None if level is None else {P_SUCCESS: level})
    except Exception:  # noqa: BLE001 - a GP fit failure must not lose the run's result
        return plain, ("lowest objective among observed-feasible designs "
                       "(constraint GP could not be fitted)")
    what = ("posterior probability of feasibility" if level is None else
            f"posterior probability of P*_s >= {level:.4g} (the rate a validation passes "
            "at half the time)")
    if not pooled:
        return plain, (f"lowest objective among observed-feasible designs (none had a "
                       f"{what} >= {min_probability:g})")
    return pooled, (f"lowest objective among designs with observed P*_s >= threshold and "
                    f"{what} >= {min_probability:g}")


def select_best(opt: ConstrainedBayesOpt, min_probability: float | None = 0.5
                ) -> tuple[Observation | None, str]:
    """The design to validate first and the rule that chose it (:func:`rank_candidates`).

    Returns ``(observation, rule)``; ``(None, "no evaluated design met the constraints")``
    when no evaluation was observed feasible.
    """
    ranked, rule = rank_candidates(opt, min_probability)
    return (ranked[0] if ranked else None), rule


def validation_evidence(candidate: Observation, successes: int, samples: int,
                        name: str) -> Observation:
    """A validation of ``candidate`` (``successes`` of ``samples`` fresh episodes) as an
    observation of constraint ``name`` for the constraint GP: P*_s = k / N with the
    binomial variance of :func:`~optimizer.observation.binomial_observation`; never a
    candidate itself (``feasible`` False)."""
    p, var = binomial_observation(successes, samples)
    return Observation(x=candidate.x, objective=candidate.objective, constraints={name: p},
                       constraint_variances={name: var}, feasible=False,
                       info={"successes": successes, "samples": samples})
