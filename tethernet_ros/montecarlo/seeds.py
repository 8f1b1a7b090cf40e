"""Common random numbers: which noise seed each Monte Carlo sample draws.

Sample ``i`` of a run with base seed ``b`` draws its noise with
``NoiseModel.sample(sample_seed(b, i))``, ``sample_seed(b, i) = b * 1_000_003 + i``.  The
draw depends on the seed only, never on the design or the noise scales, so every design
(and every scale of a sensitivity study) sees the same underlying random numbers for the
same sample.  The default base seed 0 gives seeds 0, 1, 2, ... (so ``tethernet capture
--seed 17`` replays sample 17 of a default validation); seeds of different base seeds do
not overlap while N < 1_000_003.
"""
from __future__ import annotations

#: Seed of sample i under base seed b: b * SEED_STRIDE + i.
SEED_STRIDE = 1_000_003


def sample_seed(base_seed: int, index: int) -> int:
    """Noise seed of sample ``index`` (0-based) under ``base_seed`` (both integers >= 0)."""
    if base_seed < 0 or index < 0:
        raise ValueError("base seed and sample index must be >= 0")
    return int(base_seed) * SEED_STRIDE + int(index)
