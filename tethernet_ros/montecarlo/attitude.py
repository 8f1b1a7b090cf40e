"""The target's attitude in a Monte Carlo run: |a_z|, the cosine between its long axis
and the line of sight, of each sample at launch or at a later time, and the successes
split by it (``tethernet validate`` on a tumbling target, the tumbling study's tables;
docs/studies/tumbling.md).  The physics is the core's (``core.scenario.launch_attitude``,
``core.tumble``); this module only counts."""
from __future__ import annotations

import bisect
import math


#: bins of |a_z|, the cosine between the stage's long axis and the line of sight at launch:
#: lying across it (angle > 60 deg), oblique, and end-on (within 26 deg of it)
ATTITUDE_BINS = (0.0, 0.5, 0.9, 1.0)


def long_axis_los(design, config, noise, seed: int, t: float = 0.0) -> float:
    """|a_z| of the sample drawing ``seed`` at ``t`` s of simulated time: the cosine
    between the stage's long axis and the line of sight (z).  At launch (t = 0) from the
    orientation noise and the tumble's phase and axis as the episode sets them
    (``core.scenario.launch_attitude``); later, as the target turns free of torque
    (``core.tumble``: a symmetric top by its closed form, any other shape by the kernel's
    own drift).  The net's touch is not counted, so at a closing time it is the attitude
    the target would have had untouched."""
    from ..core.kernel import quat_to_matrix
    from ..core.tumble import free_rotation, symmetric_top_axis

    q, ang_mom, inertia = _launch_attitude(design, config, noise, seed)
    if not t:
        return abs(float(quat_to_matrix(q)[2, 0]))
    if inertia[1] == inertia[2]:
        e = symmetric_top_axis(quat_to_matrix(q)[:, 0], ang_mom, inertia, float(t))
        return abs(float(e[2]))
    return abs(float(quat_to_matrix(free_rotation(q, ang_mom, inertia, float(t)))[2, 0]))


def _launch_attitude(design, config, noise, seed: int):
    """(attitude quaternion, world angular momentum (kg m^2/s), principal moments (kg m^2))
    at launch of the sample drawing ``seed``, computed once per process: the attitude
    tables at launch and at closing, and both policies of a cell, ask for the same
    samples."""
    key = (repr(design), repr(config.tumble), repr(config.target), repr(noise), int(seed))
    got = _ATTITUDES.get(key)
    if got is None:
        from ..core.scenario import launch_attitude

        if len(_ATTITUDES) >= 50_000:
            _ATTITUDES.clear()
        got = _ATTITUDES[key] = launch_attitude(design, _noise_sample(noise, seed), config)
    return got


_ATTITUDES: dict = {}


def _noise_sample(noise, seed: int):
    """``noise.sample(seed)``, drawn once per process: every cell and design of a study
    draws the same seeds (a draw takes about 6 ms, its normals being exact inverse-CDF
    values, core.detmath).  Keyed by the noise model's repr (it holds a dict)."""
    key = (repr(noise), int(seed))
    got = _SAMPLES.get(key)
    if got is None:
        if len(_SAMPLES) >= 20_000:
            _SAMPLES.clear()
        got = _SAMPLES[key] = noise.sample(seed)
    return got


_SAMPLES: dict = {}


def attitude_bin(a_z: float) -> int:
    """Index of the ATTITUDE_BINS bin that holds a_z (the last one includes 1)."""
    return min(bisect.bisect_right(ATTITUDE_BINS, a_z) - 1, len(ATTITUDE_BINS) - 2)


def attitude_counts(design, config, noise, outcomes, bin_of=None) -> tuple[list[int], list[int]]:
    """(successes, samples) per ATTITUDE_BINS bin of |a_z| at launch, over ``outcomes``:
    (noise seed, success) pairs of episodes of ``design`` under ``config`` and ``noise``.
    ``bin_of``: a dict seed -> bin shared by calls over the same episodes' attitudes (the
    policies of one cell), filled as seeds are met."""
    bin_of = {} if bin_of is None else bin_of
    n = [0] * (len(ATTITUDE_BINS) - 1)
    ok = [0] * (len(ATTITUDE_BINS) - 1)
    for seed, success in outcomes:
        if seed not in bin_of:
            bin_of[seed] = attitude_bin(long_axis_los(design, config, noise, seed))
        n[bin_of[seed]] += 1
        ok[bin_of[seed]] += int(bool(success))
    return ok, n


def closing_attitude_counts(design, config, noise, outcomes) -> tuple[list[int], list[int]]:
    """(successes, samples) per ATTITUDE_BINS bin of |a_z| at the closing time, untouched
    by the net (:func:`long_axis_los`), then one more entry for the samples whose closing
    never started; ``outcomes``: (noise seed, success, closing time (s) or NaN)."""
    k = len(ATTITUDE_BINS) - 1
    n, ok = [0] * (k + 1), [0] * (k + 1)
    for seed, success, t in outcomes:
        b = k if not math.isfinite(t) else attitude_bin(long_axis_los(design, config, noise,
                                                                      seed, t))
        n[b] += 1
        ok[b] += int(bool(success))
    return ok, n


def attitude_heads() -> list[str]:
    """Column heads of the ATTITUDE_BINS bins."""
    e = ATTITUDE_BINS
    return [f"{e[k]:g} <= a_z < {e[k + 1]:g}" if k < len(e) - 2 else f"a_z >= {e[k]:g}"
            for k in range(len(e) - 1)]
