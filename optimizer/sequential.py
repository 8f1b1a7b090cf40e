"""Sequential Monte Carlo: stop sampling a design as soon as its feasibility is decided.

A design is feasible when its P*_s observed over N = N_MC samples, k / N, is at least C_P,
that is when at most F of the N samples fail, F being the largest f with
``(N - f) / N >= C_P`` (the optimiser's own test; F = 2 for N = 100 and C_P = 0.98).
Drawn in index order (common random numbers), the samples decide that verdict early:

* **infeasible at failure F + 1**: whatever the remaining samples give, k / N < C_P;
* **feasible once failures + remaining samples <= F**: even if every remaining sample
  failed, k / N >= C_P.  This saves at most F samples, and only designs with (almost) no
  failures, so it is optional (``stop_when_feasible``): Case 1 uses it (its objective m_a
  is exact); Case 2 does not, so that the mean T of every feasible design is taken over
  the same N samples.

The estimate then rests on the m samples drawn up to the decision (m <= N): P*_s = k / m
with the binomial variance of :func:`~optimizer.observation.binomial_observation` for
those m samples (Laplace-smoothed, so that an estimate at k = 0 or k = m still has a
variance), and, for Case 2, the mean T of those m samples.  An early-stopped infeasible
design is observed infeasible (k / m <= (N - F - 1) / N < C_P) and an early-stopped
feasible one feasible, so the verdict is the one all N samples would have given.

The rule sees the samples in index order and answers with the shortest deciding prefix,
so the result never depends on how many samples were drawn at once or how fast they came.
"""
from __future__ import annotations

from dataclasses import dataclass
from collections.abc import Sequence

from .observation import wilson_interval

__all__ = ["SequentialRule", "allowed_failures", "pass_level"]


def allowed_failures(n_samples: int, threshold: float, rule: str = "estimate") -> int:
    """F: the most failures among ``n_samples`` that still meet ``threshold``: by the
    estimate, ``(n - F) / n >= threshold`` ("estimate"), or by the lower end of the
    Wilson 95 % interval of ``n - F`` successes ("wilson": F = 11 for 1000 samples at
    98 %).  -1 when even ``n`` successes fall short."""
    if rule not in ("estimate", "wilson"):
        raise ValueError(f"rule: got {rule!r}; must be 'estimate' or 'wilson'")
    n = int(n_samples)

    def meets(f: int) -> bool:
        if rule == "wilson":
            return wilson_interval(n - f, n)[0] >= threshold
        return (n - f) / n >= threshold

    f = n
    while f >= 0 and not meets(f):
        f -= 1
    return f


def pass_level(n_samples: int, threshold: float, rule: str = "estimate",
               chance: float = 0.5) -> float:
    """The true P*_s at which a test of ``n_samples`` samples (at most
    :func:`allowed_failures` failures) passes with probability ``chance``: for 1000
    samples at 98 % by the Wilson rule (F = 11) about 0.9884, by the estimate (F = 20)
    about 0.9794.  Failures are binomial; found by bisection to 1e-9."""
    from scipy.stats import binom

    n, f_max = int(n_samples), allowed_failures(n_samples, threshold, rule)
    if f_max < 0:
        return 1.0
    lo, hi = 0.0, 1.0                       # passes(lo) < chance <= passes(hi)
    while hi - lo > 1e-9:
        mid = 0.5 * (lo + hi)
        if binom.cdf(f_max, n, 1.0 - mid) >= chance:
            hi = mid
        else:
            lo = mid
    return hi


@dataclass(frozen=True)
class SequentialRule:
    """Stopping rule for N_MC = ``n_samples`` samples and C_P = ``threshold``; ``rule``:
    what meets C_P at ``n_samples`` (:func:`allowed_failures`; "wilson" for validations
    under the Wilson rule).

    Call it with the successes of samples 0..n-1 (index order); it returns the length of
    the shortest prefix that decides feasibility at ``n_samples``, or None when the
    samples given do not decide it yet.  ``n_samples`` samples always decide.
    """

    n_samples: int
    threshold: float
    stop_when_feasible: bool = True
    rule: str = "estimate"

    def __post_init__(self):
        if int(self.n_samples) < 1:
            raise ValueError(f"n_samples: got {self.n_samples!r}; must be >= 1")
        object.__setattr__(self, "_f_max", allowed_failures(self.n_samples, self.threshold,
                                                            self.rule))

    @property
    def allowed_failures(self) -> int:
        return self._f_max

    def __call__(self, successes: Sequence[bool]) -> int | None:
        n, f_max = int(self.n_samples), self.allowed_failures
        failures = 0
        for m, ok in enumerate(successes[:n], 1):
            failures += not ok
            if failures > f_max:
                return m                                       # infeasible
            if self.stop_when_feasible and failures + (n - m) <= f_max:
                return m                                       # feasible
            if m == n:
                return m
        return None

    def expected_to_decide(self, successes: Sequence[bool]) -> float:
        """How many more samples the decision is expected to take, from the successes so
        far (index order): the rate p = (k + 1) / (m + 2) (Laplace) gives the expected
        draws to the failure that makes the design infeasible, (F + 1 - f) / (1 - p), and
        to the sample that makes it feasible (with ``stop_when_feasible``; else to the
        n-th), (n - F + f - m) / p; the smaller, at most the samples left.  It sizes the
        evaluator's batches (:func:`tethernet_ros.montecarlo.evaluate`), never the result.
        """
        n, f_max = int(self.n_samples), self.allowed_failures
        m = min(len(successes), n)
        k = sum(1 for ok in successes[:m] if ok)
        f = m - k
        left = n - m
        if left <= 0 or self(successes) is not None:
            return 0.0
        # p = (k + 1) / (m + 2), 1 - p = (f + 1) / (m + 2); integer divisions, so that an
        # integer expectation is exact (the caller rounds up)
        to_infeasible = (f_max + 1 - f) * (m + 2) / (f + 1)
        to_feasible = ((n - f_max + f - m) * (m + 2) / (k + 1) if self.stop_when_feasible
                       else left)
        return float(min(to_infeasible, max(to_feasible, 1.0), left))

    def verdict(self, successes: Sequence[bool]) -> str:
        """'infeasible' or 'feasible' for samples that decide (see :meth:`__call__`),
        '' when they do not."""
        m = self(successes)
        if m is None:
            return ""
        failures = sum(1 for ok in successes[:m] if not ok)
        return "infeasible" if failures > self.allowed_failures else "feasible"
