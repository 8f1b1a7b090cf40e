"""A fast stand-in episode backend for optimiser-run tests (no simulation).

``SyntheticBackend`` implements :class:`tethernet_ros.montecarlo.EpisodeBackend`: sample
``seed`` of a design succeeds when a uniform number drawn from the seed alone is below a
smooth success probability of the design, so the results have the structure of the real
ones (common random numbers, binomial noise, a feasible region) at no cost.  It records
every task it runs.
"""
import math

import numpy as np

from tethernet_ros.montecarlo import EpisodeBackend, Outcome, SampleResult


def synthetic_probability(design) -> float:
    """Smooth P_s of a design: high for long nets and slow closing, low for light corners."""
    z = (design.L_n - 13.0) + 2.0 * (design.m_c - 1.0) - abs(design.d_c) - 2.0
    return 1.0 / (1.0 + math.exp(-z))


class SyntheticBackend(EpisodeBackend):
    """``workers``: the parallelism it reports (the batch size of sequential sampling);
    ``batches``: the number of tasks of each ``map`` call."""

    name = "synthetic"

    def __init__(self, fail_after: int | None = None, workers: int = 1):
        self.tasks = []
        self.batches = []
        self.fail_after = fail_after
        self.workers = workers

    def map(self, tasks, max_in_flight=None):
        tasks = list(tasks)
        self.batches.append(len(tasks))
        for t in tasks:
            if self.fail_after is not None and len(self.tasks) >= self.fail_after:
                raise KeyboardInterrupt("simulated kill")
            self.tasks.append(t)
            u = np.random.default_rng(t.seed).random()
            d = t.design
            ok = bool(u < synthetic_probability(d))
            T = d.d_L / d.V_e[2] + t.config.settle_time + 0.1 * u
            yield Outcome(t, SampleResult(
                key=t.key, index=t.index, seed=t.seed, success=ok, settled_cqi=1.0 if ok else 3.0,
                locked_pairs=12 if ok else 4, closing_time=T - t.config.settle_time,
                completion_time=T, mass=d.mass(t.config.density),
                failure_reason="" if ok else "settled CQI 3 > 2.0",
                category="" if ok else "settled CQI > 2"))
