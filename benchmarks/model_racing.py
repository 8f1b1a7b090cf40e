"""What the race and the validations in turn can do with a given set of candidates: a
model with known reliabilities and independent binomial samples (an estimate, not a
measurement of the simulator; benchmarks/bench_replication.py runs whole optimisations).

    .venv/bin/python benchmarks/model_racing.py [--replications 4000] [--seed 0]

The candidates are the Case 1 re-run's (docs/cases/README.md, "Case 1 with the new
defaults"): the five it raced, in its ranking's order, then evaluation 208, the design it
validated next; each design's true P_s is taken as its pooled rate over every fresh
sample the run and its second validation drew for it (racing, validation seeds 0 and 3).
Each replication races the five with :func:`optimizer.racing.race` (the run's round of
100 and budget of 2000) on binomial samples, then validates the race's order (the winner
first, the dropped ones removed) and then evaluation 208 on 1000 binomial samples by the
Wilson rule (:class:`optimizer.sequential.SequentialRule`: at most 11 failures), until one
passes.  The constraint GP's re-ranking after a failure is not modelled.  Prints the
share of replications whose first validation passes, the failed validations per
replication and which design is chosen, and each design's chance to pass one validation.
"""
from __future__ import annotations

import argparse
import os
import sys
from collections import Counter
from dataclasses import dataclass

import numpy as np
from scipy import stats

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from optimizer.racing import race  # noqa: E402
from optimizer.sequential import SequentialRule  # noqa: E402

C_P = 0.98
VALIDATION = SequentialRule(1000, C_P, rule="wilson")


@dataclass(frozen=True)
class Candidate:
    """A design of the run: its evaluation, m_a (kg) and the successes of all of its
    fresh samples (docs/cases/README.md and results.md of the Case 1 re-run)."""

    evaluation: int
    objective: float
    successes: int
    samples: int

    @property
    def p_true(self) -> float:
        return self.successes / self.samples


#: the raced five, in ranking order, then the design validated after them
RACED = (Candidate(250, 6.6824, 192, 200),           # racing only (dropped)
         Candidate(210, 6.6865, 489, 500),           # racing only
         Candidate(227, 6.6916, 494 + 676, 500 + 688),
         Candidate(222, 6.7086, 398 + 533 + 991, 400 + 545 + 1000),
         Candidate(139, 6.7197, 393 + 178, 400 + 190))
NEXT = Candidate(208, 6.7244, 994 + 997, 2000)


@dataclass
class Estimate:
    successes: int
    n_samples: int


def replicate(rng: np.random.Generator) -> tuple[int, int | None]:
    """One race and its validations: (failed validations, chosen evaluation or None)."""
    drawn: dict[int, list[bool]] = {}

    def sample(c: Candidate, n: int) -> Estimate:
        have = drawn.setdefault(c.evaluation, [])
        have += list(rng.random(n - len(have)) < c.p_true)
        return Estimate(sum(have[:n]), n)

    result = race(list(RACED), sample, C_P, 100, 2000)
    failed = 0
    for c in result.order(list(RACED)) + [NEXT]:
        if rng.binomial(VALIDATION.n_samples, 1.0 - c.p_true) <= VALIDATION.allowed_failures:
            return failed, c.evaluation
        failed += 1
    return failed, None


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--replications", type=int, default=4000)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    runs = [replicate(rng) for _ in range(args.replications)]
    fails = np.array([f for f, _ in runs])
    chosen = Counter(c for _, c in runs)
    f_max = VALIDATION.allowed_failures
    print(f"validation: {VALIDATION.n_samples} samples, at most {f_max} failures (Wilson rule)")
    for c in RACED + (NEXT,):
        p_pass = stats.binom(VALIDATION.n_samples, 1.0 - c.p_true).cdf(f_max)
        print(f"  evaluation {c.evaluation}: m_a {c.objective:.4f} kg, P_s {c.p_true:.4f} "
              f"({c.successes}/{c.samples}), passes one validation with probability {p_pass:.3f}")
    print(f"{args.replications} replications: first validation passes in "
          f"{np.mean(fails == 0):.3f}, failed validations {fails.mean():.2f} per replication "
          f"(max {fails.max()}), chosen: "
          + ", ".join(f"{k if k is not None else 'none'} {v / len(runs):.3f}"
                      for k, v in chosen.most_common()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
