"""The reliability of one design under one noise model, summarised from its samples:
P*_s with its Wilson and Clopper-Pearson intervals (core.metrics), mean T, failures by
category."""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from collections.abc import Sequence

from ..core.config import SimConfig
from ..core.design import Design
from ..core.metrics import clopper_pearson_interval, wilson_interval
from .records import SampleResult


@dataclass
class MonteCarloResult:
    """Reliability of one design under one noise model.

    p_success = successes / n_samples (worker errors count as failures);
    ci_low, ci_high: Wilson 95 % interval; cp_low, cp_high: Clopper-Pearson 95 %;
    mean_completion_time: mean T (s) over samples with a finite T (every episode except
    worker errors; a 'closing never triggered' sample counts with T = horizon);
    mean_completion_time_success: mean T over the successes; mass: m_a (kg);
    failures_by_reason: failure category -> count (sums to the number of failures);
    samples: per-sample results ordered by index; reused: samples read from the results
    file instead of simulated; wall_time: s.
    """

    design: Design
    label: str
    key: str
    n_samples: int
    base_seed: int
    successes: int
    p_success: float
    ci_low: float
    ci_high: float
    cp_low: float
    cp_high: float
    mean_completion_time: float
    mean_completion_time_success: float
    mass: float
    failures_by_reason: dict
    samples: list
    reused: int = 0
    wall_time: float = 0.0
    backend: str = ""
    noise_scales: dict = field(default_factory=dict)

    @classmethod
    def from_samples(cls, design: Design, samples: Sequence[SampleResult], base_seed: int,
                     key: str, config: SimConfig, label: str = "", reused: int = 0,
                     wall_time: float = 0.0, backend: str = "",
                     noise_scales: dict | None = None) -> MonteCarloResult:
        samples = sorted(samples, key=lambda r: r.index)
        n = len(samples)
        k = sum(1 for r in samples if r.success)
        lo, hi = wilson_interval(k, n)
        clo, chi = clopper_pearson_interval(k, n)
        ts = [r.completion_time for r in samples if math.isfinite(r.completion_time)]
        tss = [r.completion_time for r in samples if r.success and math.isfinite(r.completion_time)]
        fails = Counter(r.category or "other" for r in samples if not r.success)
        return cls(design=design, label=label, key=key, n_samples=n, base_seed=base_seed,
                   successes=k, p_success=k / n if n else math.nan, ci_low=lo, ci_high=hi,
                   cp_low=clo, cp_high=chi,
                   mean_completion_time=sum(ts) / len(ts) if ts else math.nan,
                   mean_completion_time_success=sum(tss) / len(tss) if tss else math.nan,
                   mass=design.mass(config.density),
                   failures_by_reason=dict(fails.most_common()), samples=list(samples),
                   reused=reused, wall_time=wall_time, backend=backend,
                   noise_scales=dict(noise_scales or {}))

    @property
    def failures(self) -> int:
        return self.n_samples - self.successes

    def to_dict(self, with_samples: bool = False) -> dict:
        d = {"design_name": self.label, "design": self.design.to_dict(), "mass": self.mass,
             "samples": self.n_samples, "base_seed": self.base_seed, "successes": self.successes,
             "p_success": self.p_success, "ci_low": self.ci_low, "ci_high": self.ci_high,
             "ci_method": "wilson", "cp_low": self.cp_low, "cp_high": self.cp_high,
             "mean_completion_time": self.mean_completion_time,
             "mean_completion_time_success": self.mean_completion_time_success,
             "failures": self.failures, "failures_by_reason": dict(self.failures_by_reason),
             "worker_errors": self.failures_by_reason.get("worker error", 0),
             "noise_scales": self.noise_scales, "key": self.key, "reused": self.reused,
             "wall_time": self.wall_time, "backend": self.backend}
        if with_samples:
            d["per_sample"] = [r.to_record() for r in self.samples]
        return d
