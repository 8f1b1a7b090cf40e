"""Reliability-constrained Bayesian optimiser (SPEC section 7), simulator-independent.

See :mod:`optimizer.bayesopt` for the method and :mod:`optimizer.testproblems` for
standard constrained test problems with known optima.  The names below are loaded on first
use, so that importing a light module of the package (e.g. :mod:`optimizer.jsonio`) does not
load the surrogate's libraries.
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
