"""Reliability-constrained Bayesian optimiser (docs/optimizer.md), simulator-independent: it
imports nothing of the simulator, which it sees through :mod:`optimizer.problem`.

A module per job, in reading order:

================  =========================================================================
problem.py        the interface a simulator implements (DesignProblem, ReliabilityEstimate)
run.py            a whole run of Case 1 or 2: run directory, resume, validation, reports
settings.py       the run's settings: defaults, allowed ranges, checks (RunSettings)
cases.py          the two cases of docs/optimizer.md §1
evaluator.py      one design -> one observation (P*_s = k/n with its binomial variance)
sequential.py     stop sampling a design as soon as its feasibility is decided
bayesopt.py       the ask/tell optimiser (seed design, active set, state for checkpoints)
loop.py           minimize(): ask, evaluate, tell, checkpoint, repeat
gp.py             the Gaussian-process surrogates (scikit-optimize)
acquisition.py    probability of feasibility, expected improvement (plus), maximisation
observation.py    an evaluated design; binomial_observation
selection.py      the choice of the final design
finish.py         choose, validate, summarise; report.py: history.csv, table, figure
status.py         how far a run has come (read from its directory, also while it runs)
checkpoint.py     atomic checkpoints; jsonio.py: the NaN-to-null and atomic-write rules
testproblems.py   standard constrained test problems with known optima
================  =========================================================================

The names below are loaded on first use, so that importing a light module of the package
(e.g. :mod:`optimizer.jsonio`) does not load the surrogate's libraries.
"""
from importlib import import_module

_HOMES = {
    "ConstrainedBayesOpt": "bayesopt", "Observation": "observation",
    "binomial_observation": "observation", "expected_improvement_plus": "acquisition",
    "OptimizeResult": "loop", "minimize": "loop", "CheckpointError": "checkpoint",
    "load_checkpoint": "checkpoint", "save_checkpoint": "checkpoint",
}

__all__ = list(_HOMES)


def __getattr__(name):
    if name not in _HOMES:
        raise AttributeError(f"module 'optimizer' has no attribute {name!r}")
    return getattr(import_module(f".{_HOMES[name]}", __name__), name)
