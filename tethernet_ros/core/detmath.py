"""Elementary functions whose results are the same on every machine (docs/model.md §13).

An episode must be bit-identical on every x86-64 machine.  IEEE 754 fixes the result of
+, -, *, / and sqrt, but not of exp, log, sin, cos, atan or cbrt: the C library picks a
variant per CPU at load time (glibc's FMA and non-FMA code paths), and numpy's array
functions take SIMD paths chosen per CPU (AVX-512 against AVX2 give other last bits).
Everything on an episode's path that needs such a function calls this module instead.

The functions evaluate with mpmath, in integer arithmetic, and round once to the nearest
binary64 number: the same bits wherever Python runs.  They are meant for building a
scenario (a few hundred calls), not for the kernel, which needs only IEEE operations.
"""
from __future__ import annotations

import math

import mpmath
import numpy as np

#: 53 bits: mpmath rounds each result to the nearest binary64 number
_CTX = mpmath.MPContext()
_CTX.prec = 53
#: wider working precision for composite formulas, rounded once at the end
_WIDE = mpmath.MPContext()
_WIDE.prec = 96

__all__ = ["cos", "sin", "exp", "log", "atan2", "cbrt", "cbrt_array", "hypot", "norm3",
           "standard_normal", "WIDE"]

#: a context for formulas evaluated at 96 bits and rounded once with ``float()``
WIDE = _WIDE


def cos(x: float) -> float:
    """cos(x), x in rad."""
    return float(_CTX.cos(float(x)))


def sin(x: float) -> float:
    """sin(x), x in rad."""
    return float(_CTX.sin(float(x)))


def exp(x: float) -> float:
    return float(_CTX.exp(float(x)))


def log(x: float) -> float:
    """Natural logarithm of x > 0."""
    return float(_CTX.log(float(x)))


def atan2(y: float, x: float) -> float:
    """Angle (rad) of the point (x, y), in (-pi, pi]."""
    return float(_CTX.atan2(float(y), float(x)))


def cbrt(x: float) -> float:
    """Real cube root."""
    return float(_CTX.cbrt(float(x)))


def cbrt_array(x) -> np.ndarray:
    """Element-wise real cube root of an array (float64, same shape)."""
    a = np.asarray(x, dtype=np.float64)
    out = np.empty_like(a)
    flat, res = a.ravel(), out.ravel()
    for i in range(flat.size):
        res[i] = cbrt(flat[i])
    return out


def hypot(a: float, b: float) -> float:
    """sqrt(a^2 + b^2) with IEEE operations only (math.sqrt is exactly rounded; no overflow
    guard: lengths in m)."""
    a, b = float(a), float(b)
    return math.sqrt(a * a + b * b)


def norm3(v) -> float:
    """Euclidean length of a 3-vector, summed in the order x, y, z (no BLAS)."""
    x, y, z = float(v[0]), float(v[1]), float(v[2])
    return math.sqrt(x * x + y * y + z * z)


_TWO53 = 9007199254740992.0  # 2**53


def standard_normal(rng: np.random.Generator) -> float:
    """One standard normal variate from one uniform of ``rng`` by the inverse CDF.

    numpy's own sampler (ziggurat) calls the C library's exp and log1p in its tail and
    wedge branches, so its draws may differ between machines.  Here the uniform is
    ``rng.random()`` = k / 2^53 (k < 2^53, exact), mapped to the centre of its cell,
    p = (2k + 1 - 2^53) / 2^53 in (-1, 1) (exact), and z = sqrt(2) erfinv(p), evaluated at
    96 bits and rounded once.  |z| <= 8.3.
    """
    k = rng.random() * _TWO53
    p = (2.0 * k + 1.0 - _TWO53) / _TWO53
    return float(_WIDE.sqrt(2) * _WIDE.erfinv(p))
