"""Statistics of study cells over the same (common-random-number) samples.

A cell's reliability is P*_s with its Wilson 95 % interval; two cells compare by the
difference of their P*_s against the intervals' half-widths, by the share of samples whose
verdict flips between them (with McNemar's exact test on the flips), and by the relative
difference of their mean completion times T.
"""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass

from scipy.stats import binomtest

from ..core.metrics import wilson_interval


@dataclass(frozen=True)
class CellStats:
    """One cell of one design: n samples, successes, P*_s and its Wilson 95 % interval,
    mean T (s), failures by category and the mean time the chaser waited before it fired
    (s; docs/model.md §16)."""

    label: str
    design: str
    n: int
    successes: int
    p: float
    lo: float
    hi: float
    mean_t: float
    failures: dict
    mean_wait: float = 0.0

    @property
    def half_width(self) -> float:
        return (self.hi - self.lo) / 2

    @classmethod
    def from_samples(cls, label: str, design: str, samples) -> CellStats:
        n = len(samples)
        k = sum(1 for s in samples if s.success)
        lo, hi = wilson_interval(k, n)
        ts = [s.completion_time for s in samples if math.isfinite(s.completion_time)]
        fails = Counter(s.category or s.failure_reason for s in samples if not s.success)
        waits = [float(getattr(s, "launch_time", 0.0)) for s in samples]
        waits = [w for w in waits if math.isfinite(w)]
        return cls(label, design, n, k, k / n if n else math.nan, lo, hi,
                   sum(ts) / len(ts) if ts else math.nan, dict(fails),
                   sum(waits) / len(waits) if waits else math.nan)


def mcnemar_p(a_only: int, b_only: int) -> float:
    """McNemar's exact two-sided p of paired verdicts: ``a_only`` samples succeed in a
    alone, ``b_only`` in b alone (1 when none differ)."""
    flips = a_only + b_only
    return float(binomtest(a_only, flips, 0.5).pvalue) if flips else 1.0


@dataclass(frozen=True)
class PairedStats:
    """Cell b against cell a over the same samples."""

    a: CellStats
    b: CellStats
    flips: int             # samples whose verdict differs
    a_only: int            # successes of a that fail in b
    b_only: int            # successes of b that fail in a
    mcnemar_p: float       # exact two-sided p-value of the flips' balance

    @property
    def p_diff(self) -> float:
        return self.b.p - self.a.p

    @property
    def flip_share(self) -> float:
        return self.flips / self.a.n if self.a.n else math.nan

    @property
    def t_diff(self) -> float:
        """Mean T of b less that of a (s)."""
        return self.b.mean_t - self.a.mean_t

    @property
    def t_rel_diff(self) -> float:
        return self.t_diff / self.a.mean_t

    @property
    def within_half_width(self) -> bool:
        """|P*_s(b) - P*_s(a)| below the smaller of the two intervals' half-widths."""
        return abs(self.p_diff) < min(self.a.half_width, self.b.half_width)

    @classmethod
    def from_samples(cls, a: CellStats, b: CellStats, samples_a, samples_b) -> PairedStats:
        by_seed = {s.seed: s.success for s in samples_b}
        a_only = b_only = 0
        for s in samples_a:
            if s.seed not in by_seed:
                raise ValueError(f"sample seed {s.seed} of cell {a.label!r} is missing from {b.label!r}")
            if s.success and not by_seed[s.seed]:
                a_only += 1
            elif by_seed[s.seed] and not s.success:
                b_only += 1
        return cls(a, b, a_only + b_only, a_only, b_only, mcnemar_p(a_only, b_only))


def paired_cells(a, b) -> PairedStats | None:
    """PairedStats of cell record b against cell record a (anything with ``stats`` and
    ``verdicts``, ``summary.CellRecord``) over the same samples, or None unless both are
    there with the same (non-zero) number of samples: a cell still running is compared
    once complete."""
    if a is None or b is None or not a.stats.n or a.stats.n != b.stats.n:
        return None
    return PairedStats.from_samples(a.stats, b.stats, a.verdicts, b.verdicts)
