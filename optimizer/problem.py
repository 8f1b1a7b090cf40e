"""What the optimiser needs from a simulator: the interface a design problem implements.

The optimiser never imports the simulator.  A Case (:mod:`optimizer.cases`) is run on a
:class:`DesignProblem` built outside this package (for the tether-net simulator:
``tethernet_ros.design_problem.SimulatorProblem``), which knows the design variables, their
bounds, the cheap mass formula and how to estimate a design's reliability from Monte Carlo
samples (:class:`ReliabilityEstimate`).
"""
from __future__ import annotations

from typing import Protocol
from collections.abc import Callable, Sequence

import numpy as np

__all__ = ["ReliabilityEstimate", "DesignProblem"]


class ReliabilityEstimate(Protocol):
    """A design's reliability over the samples drawn (``tethernet_ros.montecarlo.
    MonteCarloResult`` is one).  Times in s, mass in kg; NaN where undefined.

    successes / n_samples: the estimate P*_s = ``p_success``; ci_low, ci_high: Wilson 95 %
    interval; cp_low, cp_high: Clopper-Pearson 95 %; mean_completion_time: mean T over the
    samples (``mean_completion_time_success``: over the successes); failures_by_reason:
    failure category -> count; key: identity of the design's episodes; reused: samples read
    back from a results file instead of simulated; base_seed: the samples' base seed.
    """

    successes: int
    n_samples: int
    base_seed: int
    p_success: float
    ci_low: float
    ci_high: float
    cp_low: float
    cp_high: float
    mass: float
    mean_completion_time: float
    mean_completion_time_success: float
    failures_by_reason: dict
    key: str
    reused: int


class DesignProblem(Protocol):
    """A design space and the expensive evaluation of a design in it.

    variable_names, bounds: the design vector's variables and the search box (own units);
    horizon: the completion time T (s) of a capture that never completes, the Case 2
    objective when no sample gave a T.
    """

    variable_names: Sequence[str]
    bounds: list[tuple[float, float]]
    horizon: float

    def mass(self, x: np.ndarray) -> float:
        """System mass m_a (kg) of design vector ``x``: cheap and exact."""

    def evaluate(self, x: np.ndarray, n_samples: int, base_seed: int, *,
                 stop: Callable[[Sequence[bool]], int | None] | None = None,
                 results_path=None, label: str = "",
                 progress: Callable[[int, int], None] | None = None) -> ReliabilityEstimate:
        """Reliability of ``x`` over samples 0..n_samples-1 of ``base_seed`` (the same
        samples for every design).  With ``stop`` (a
        :class:`~optimizer.sequential.SequentialRule`) the samples are drawn in index order
        and the estimate rests on the shortest prefix ``stop`` says decides.
        ``results_path``: a file of finished samples to reuse and append to;
        ``progress(done, total)`` after each finished sample."""

    def design_dict(self, x: np.ndarray) -> dict:
        """``x`` as a JSON-ready mapping of named variables (for reports)."""

    def reference_design(self, name: str) -> np.ndarray | None:
        """The design vector of a named reference design, or None if there is none."""

    def published_outcome(self, name: str) -> dict | None:
        """What the source study published for a named reference design (its Table 4):
        ``mass`` (kg), ``mean_completion_time`` (s), ``p_success_optimisation`` (None where
        not given) and ``p_success_validated``; None if nothing is published."""

    def settings(self) -> dict:
        """JSON-ready settings that determine the evaluations (a run refuses to resume
        under other settings), with ``model_version``: a change of it only warns."""

    def describe(self) -> str:
        """Where the episodes run (for reports)."""

    # optional: ``scenario() -> str``, the problem's non-default scenario in words, which
    # the summary and results.md state ('' or absent: the default one).
    # optional: ``machine_facts() -> dict``, the facts of the machine that decide whether
    # the problem's evaluations are the same bit for bit elsewhere (CPU features, library
    # versions); a run directory records them beside the optimiser's own
    # (:func:`optimizer.run.machine_record`)
    # optional: ``fidelities: tuple[str, ...]``, the names of the fidelities besides
    # "reference" (the problem as given) that the problem evaluates at, with
    # ``at_fidelity(name) -> DesignProblem``, the same problem evaluated at that fidelity
    # (its estimates' ``key`` must differ from the reference's, so that a results file
    # never mixes them); the run's ``fidelity`` setting chooses one per phase
    # (:mod:`optimizer.settings`)
