"""The optimisation loop: :func:`minimize` asks the optimiser
(:class:`~optimizer.bayesopt.ConstrainedBayesOpt`) for a design, evaluates it, tells it the
result, writes a checkpoint (:mod:`optimizer.checkpoint`) and repeats until the budget is
spent; a killed run resumes from its checkpoint to the same result."""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from collections.abc import Callable, Mapping

from .bayesopt import ConstrainedBayesOpt
from .checkpoint import CheckpointError, load_checkpoint, save_checkpoint
from .observation import Observation

__all__ = ["OptimizeResult", "minimize"]


@dataclass
class OptimizeResult:
    """Result of :func:`minimize`.

    ``best``: best observed-feasible observation (or None); ``history``: all
    observations in evaluation order; ``optimizer``: the optimiser (for further asks);
    ``stopped_by_callback``: the callback ended the run early.
    """

    best: Observation | None
    history: list[Observation]
    optimizer: ConstrainedBayesOpt
    stopped_by_callback: bool = False


def _unpack(out):
    if not isinstance(out, tuple) or not 2 <= len(out) <= 4:
        raise TypeError("fun must return (objective, constraints[, variances[, info]])")
    out = tuple(out) + (None,) * (4 - len(out))
    return out


def minimize(fun: Callable, bounds, constraints: Mapping[str, float], *,
             cheap_constraint=None, n_initial: int = 50, n_iterations: int = 200,
             checkpoint_path: str | os.PathLike | None = None, resume: bool = False,
             callback: Callable[[Observation, ConstrainedBayesOpt], Any] | None = None,
             **options) -> OptimizeResult:
    """Minimise ``fun`` over ``bounds`` subject to coupled and cheap constraints.

    Args:
        fun: ``fun(x) -> (objective, constraints, variances, info)`` with ``x`` in
            problem units; ``constraints`` a dict ``name -> value`` (feasible if
            ``value >= threshold``), ``variances`` a dict of known observation variances
            or None, ``info`` a JSON-serialisable dict or None (the last two optional).
        bounds, constraints, cheap_constraint, n_initial, n_iterations, options: see
            :class:`ConstrainedBayesOpt`.
        checkpoint_path: JSON checkpoint, written atomically after every evaluation.
        resume: continue from ``checkpoint_path`` if it exists (history replayed into the
            optimiser without re-evaluation; at most the evaluation in flight is lost).
            Bounds, constraints and settings must match the checkpoint; ``n_iterations``
            may differ (budget extension). Without ``resume`` an existing checkpoint is an
            error (never silently overwritten).
        callback: ``callback(observation, optimizer)`` after every evaluation and
            checkpoint; a truthy return value stops the run.

    Exceptions raised by ``fun`` propagate; the checkpoint then holds every completed
    evaluation.
    """
    opt = ConstrainedBayesOpt(bounds, constraints, cheap_constraint, n_initial=n_initial,
                              n_iterations=n_iterations, **options)
    if checkpoint_path is not None and Path(checkpoint_path).exists():
        if not resume:
            raise FileExistsError(f"checkpoint {str(checkpoint_path)!r} exists; pass resume=True "
                                  "to continue it or remove it to start afresh")
        state = load_checkpoint(checkpoint_path)
        try:
            saved = state["optimizer"]
            fresh = opt.state_dict()
            for key in ("bounds", "constraints", "has_cheap_constraint"):
                if saved[key] != fresh[key]:
                    raise ValueError(f"checkpoint {key} {saved[key]!r} differ from the requested "
                                     f"{fresh[key]!r}")
            for key in sorted(set(fresh["settings"]) | set(saved["settings"])):
                val = fresh["settings"].get(key)
                if key != "n_iterations" and saved["settings"].get(key) != val:
                    raise ValueError(f"checkpoint setting {key}={saved['settings'].get(key)!r} differs "
                                     f"from the requested {val!r}")
            opt = ConstrainedBayesOpt.from_state_dict(saved, cheap_constraint,
                                                      n_iterations=n_iterations)
        except (KeyError, TypeError) as exc:
            raise CheckpointError(f"checkpoint file {str(checkpoint_path)!r} lacks optimiser "
                                  f"state ({exc!r})") from exc
    stopped = False
    while not opt.done:
        x = opt.ask()
        objective, cons, var, info = _unpack(fun(x.copy()))
        obs = opt.tell(x, objective, cons, var, info)
        if checkpoint_path is not None:
            save_checkpoint(checkpoint_path, {"optimizer": opt.state_dict()})
        if callback is not None and callback(obs, opt):
            stopped = True
            break
    return OptimizeResult(best=opt.best_feasible(), history=list(opt.history), optimizer=opt,
                          stopped_by_callback=stopped)
