"""Reliability-constrained Bayesian optimiser (SPEC section 7), simulator-independent.

See :mod:`optimizer.bayesopt` for the method and :mod:`optimizer.testproblems` for
standard constrained test problems with known optima.
"""

from .bayesopt import (
    ConstrainedBayesOpt,
    Observation,
    OptimizeResult,
    binomial_observation,
    expected_improvement_plus,
    minimize,
)
from .checkpoint import CheckpointError, load_checkpoint, save_checkpoint

__all__ = [
    "ConstrainedBayesOpt",
    "Observation",
    "OptimizeResult",
    "binomial_observation",
    "expected_improvement_plus",
    "minimize",
    "CheckpointError",
    "load_checkpoint",
    "save_checkpoint",
]
