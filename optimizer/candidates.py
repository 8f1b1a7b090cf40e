"""Where an ask looks: the candidate points the acquisition is evaluated on (unit cube),
and the rule that keeps an ask away from designs already evaluated.

Candidates (:func:`candidate_points`): ``n`` points uniform in the unit cube, plus
``max(n // LOCAL_SHARE, 1)`` Gaussian perturbations of a few observed points
(:func:`candidate_centres`: the ``CENTRES`` lowest-objective feasible ones, or, before any
is feasible, the most probably feasible), their standard deviations cycling through
``LOCAL_SCALES`` (fine, medium and coarse steps of the unit cube), clipped to the cube.
The uniform points keep the search global; the local ones let the polish start near the
incumbent.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from .acquisition import log_probability_feasible

__all__ = ["CENTRES", "DUPLICATE_TOL", "LOCAL_SCALES", "LOCAL_SHARE", "candidate_centres",
           "candidate_points", "near_any", "away_from_evaluated"]

#: observed points the local candidates perturb
CENTRES = 5
#: standard deviations of the local perturbations (unit-cube lengths), cycled
LOCAL_SCALES = (0.01, 0.05, 0.15)
#: one local candidate per this many uniform ones (at least one)
LOCAL_SHARE = 4
#: two designs closer than this in every normalised coordinate count as the same design
DUPLICATE_TOL = 1e-3


def candidate_centres(U: np.ndarray, objectives, feasible: np.ndarray, constraint_models: Mapping,
                      thresholds: Mapping[str, float]) -> np.ndarray:
    """The observed points (rows of ``U``, unit cube) the local candidates perturb, best
    first: the CENTRES feasible ones of lowest ``objectives`` (earlier first on ties) when
    any is feasible, else the CENTRES of highest posterior probability of feasibility."""
    if feasible.any():
        fi = np.flatnonzero(feasible)
        return U[fi[np.argsort([objectives[i] for i in fi], kind="stable")[:CENTRES]]]
    lp = log_probability_feasible(constraint_models, thresholds, U)
    return U[np.argsort(-lp, kind="stable")[:CENTRES]]


def candidate_points(rng: np.random.Generator, n: int, centres: np.ndarray) -> np.ndarray:
    """``n`` uniform points of the unit cube, then the local perturbations of ``centres``
    (cycled), in that order of draws from ``rng``; shape ``(n + max(n // LOCAL_SHARE, 1), d)``."""
    dim = centres.shape[1]
    uniform = rng.random((n, dim))
    n_loc = max(n // LOCAL_SHARE, 1)
    scales = np.array(LOCAL_SCALES)[np.arange(n_loc) % len(LOCAL_SCALES)][:, None]
    local = centres[np.arange(n_loc) % len(centres)] + scales * rng.standard_normal((n_loc, dim))
    return np.vstack([uniform, np.clip(local, 0.0, 1.0)])


def near_any(points: np.ndarray, others: np.ndarray, tol: float = DUPLICATE_TOL) -> np.ndarray:
    """For each row of ``points`` (unit cube), whether some row of ``others`` lies within
    ``tol`` of it in every coordinate."""
    if len(others) == 0:
        return np.zeros(len(points), dtype=bool)
    return (np.abs(points[:, None, :] - others[None, :, :]).max(axis=2) < tol).any(axis=1)


def away_from_evaluated(u: np.ndarray, score: float, cand: np.ndarray, evaluated: np.ndarray,
                        score_of: Callable[[np.ndarray], np.ndarray]) -> tuple[np.ndarray, float, bool]:
    """``(u, score, moved)``: the chosen point ``u`` unchanged unless it is a design already
    evaluated (:func:`near_any`), then the best-scoring (``score_of``) candidate that is not
    one.  With common random numbers a repeat returns the same observation and teaches the
    models nothing (a flat feasibility model, e.g. every P*_s observed 0, would otherwise
    send the polish to the same corner again and again).  When every candidate was
    evaluated, ``u`` is kept."""
    if not near_any(u[None, :], evaluated)[0]:
        return u, score, False
    fresh = cand[~near_any(cand, evaluated)]
    if not len(fresh):
        return u, score, False
    s = score_of(fresh)
    return fresh[int(np.argmax(s))], float(s.max()), True
