"""Capture metrics of docs/model.md §7: the Capture Quality Index, locked pairs, success.

This is the one CQI function of the project (library, workers, monitor node, replay), and
the one home of the success rule (:func:`capture_verdict`) and of the failure categories
that Monte Carlo summaries count (:func:`failure_category`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, asdict

import numpy as np
from scipy.spatial import ConvexHull, QhullError


@dataclass(frozen=True)
class CQITerms:
    """CQI and its parts.  hull_volume (m^3), hull_area (m^2), com_distance q_n (m)."""

    cqi: float
    volume_term: float
    area_term: float
    distance_term: float
    hull_volume: float
    hull_area: float
    com_distance: float

    def to_dict(self) -> dict:
        return asdict(self)


def hull_volume_area(points: np.ndarray) -> tuple[float, float]:
    """Volume (m^3) and surface area (m^2) of the convex hull of (N, 3) points.

    A flat (coplanar) or collinear set has zero volume; its "surface" is both faces of its
    planar hull, i.e. twice the planar hull's area (the limit of a thin solid).
    """
    pts = np.asarray(points, dtype=float)
    try:
        hull = ConvexHull(pts)
        return float(hull.volume), float(hull.area)
    except QhullError:
        pass
    return 0.0, 2.0 * planar_hull_area(pts)


def planar_hull_area(points: np.ndarray) -> float:
    """Area (m^2) of the convex hull of (N, 3) points that lie in a plane (0 if they are
    collinear).  The plane is spanned from the centroid by the point farthest from it (a)
    and the point farthest from the line along a (b), in IEEE operations only: no SVD,
    whose last bits depend on the CPU kernel of the linear-algebra library."""
    pts = np.asarray(points, dtype=float)
    c = pts - pts.mean(axis=0)
    d2 = c[:, 0] * c[:, 0] + c[:, 1] * c[:, 1] + c[:, 2] * c[:, 2]
    a = c[int(np.argmax(d2))]
    la = float(np.sqrt(d2.max()))
    if la == 0.0:
        return 0.0
    e1 = a / la
    cr = np.cross(e1, c)
    n2 = cr[:, 0] * cr[:, 0] + cr[:, 1] * cr[:, 1] + cr[:, 2] * cr[:, 2]
    if not float(np.sqrt(n2.max())) > 1e-12 * la:
        return 0.0
    n = cr[int(np.argmax(n2))]
    n = n / float(np.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]))
    e2 = np.cross(n, e1)
    planar = np.empty((len(c), 2))
    planar[:, 0] = c[:, 0] * e1[0] + c[:, 1] * e1[1] + c[:, 2] * e1[2]
    planar[:, 1] = c[:, 0] * e2[0] + c[:, 1] * e2[1] + c[:, 2] * e2[2]
    try:
        return float(ConvexHull(planar).volume)  # 2D 'volume' is the area
    except QhullError:
        return 0.0


def centre_of_mass(positions: np.ndarray, masses: np.ndarray) -> np.ndarray:
    """Mass-weighted mean position (m)."""
    m = np.asarray(masses, dtype=float)
    return (np.asarray(positions, dtype=float) * m[:, None]).sum(axis=0) / m.sum()


def capture_quality_index(net_positions: np.ndarray, net_masses: np.ndarray,
                          target_com: np.ndarray, target_volume: float, target_area: float,
                          target_min_surface_distance: float) -> CQITerms:
    """I_CQ = 0.1 |V_n - V_t|/V_t + 0.1 |S_n - S_t|/S_t + 0.8 |q_n|/L_c.

    net_positions (N, 3) and net_masses (N,) are the net's lumped nodes; V_n, S_n are the
    volume and area of their convex hull, q_n the distance between the net's and the
    target's centres of mass, L_c the smallest distance from the target's CoM to its surface.
    """
    vol, area = hull_volume_area(net_positions)
    d = centre_of_mass(net_positions, net_masses) - np.asarray(target_com, dtype=float)
    q = math.sqrt(float(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]))
    tv = 0.1 * abs(vol - target_volume) / target_volume
    ta = 0.1 * abs(area - target_area) / target_area
    td = 0.8 * q / target_min_surface_distance
    return CQITerms(cqi=tv + ta + td, volume_term=tv, area_term=ta, distance_term=td,
                    hull_volume=vol, hull_area=area, com_distance=q)


def cqi_fails(settled_cqi: float, max_cqi: float = 2.0) -> bool:
    """First test of the success rule: the settled CQI fails unless I*_CQ <= max_cqi (a NaN
    CQI fails)."""
    return not (settled_cqi <= max_cqi)


def pairs_fail(locked_pairs: int, min_locked_pairs: int = 10) -> bool:
    """Second test of the success rule: n_L fails when n_L < min_locked_pairs."""
    return locked_pairs < min_locked_pairs


def clear_success(cqi: float, locked_pairs: int, ring_pairs: int, max_cqi: float = 2.0) -> bool:
    """A success with a margin, which the early call reads (docs/model.md §7): the CQI at
    most half of max_cqi and every one of the ring's ``ring_pairs`` drawstring pairs
    locked (a NaN CQI is not clear)."""
    return cqi <= 0.5 * max_cqi and locked_pairs >= ring_pairs


def capture_verdict(settled_cqi: float, locked_pairs: int, max_cqi: float = 2.0,
                    min_locked_pairs: int = 10) -> tuple[bool, str]:
    """Success rule of docs/model.md §7: I*_CQ <= max_cqi and n_L >= min_locked_pairs.
    Returns (success, failure reason or '')."""
    if not math.isfinite(settled_cqi):
        return False, "settled CQI is not finite"
    reasons = []
    if cqi_fails(settled_cqi, max_cqi):
        reasons.append(f"settled CQI {settled_cqi:.3f} > {max_cqi:g}")
    if pairs_fail(locked_pairs, min_locked_pairs):
        reasons.append(f"{locked_pairs} locked pairs < {min_locked_pairs}")
    return (not reasons), "; ".join(reasons)


#: the start of the failure reason of an episode whose closing controller, outside the
#: kernel (policy 'external': a ROS node, a user's controller), did not answer in time
CONTROLLER_TIMEOUT = "controller did not answer"


#: the start of the reason, and the category, of a capture the source's criterion calls a
#: success that the tug test did not hold (criterion 'held', ``episode.held_verdict``)
NOT_HELD = "not held"


def criterion_of(r) -> str:
    """The criterion that judged a result (an EpisodeResult, a SampleResult or an
    EpisodeResult message): 'source' when it carries none (a record or bag from before it
    was carried, or an empty message field)."""
    return str(getattr(r, "criterion", "") or "source")


def failure_category(reason: str, settled_cqi: float | None = None,
                     locked_pairs: int | None = None, closing_time: float | None = None,
                     max_cqi: float = 2.0, min_locked_pairs: int = 10) -> str:
    """Group a failed episode into a category for counting ('' when ``reason`` is empty).

    Categories: 'worker error', 'controller did not answer', 'not held' (criterion 'held':
    the tug test lost a capture the source calls a success), 'diverged', 'closing never
    triggered', 'settled CQI > 2',
    'locked pairs < 10', 'settled CQI > 2 and locked pairs < 10' (thresholds as given),
    'other'.  The numbers (settled CQI, n_L, closing time; NaN closing time = never
    triggered) decide where given, by the tests of :func:`capture_verdict`; otherwise the
    reason text does.
    """
    if not reason:
        return ""
    r = reason.lower()
    if r.startswith("worker error"):
        return "worker error"
    if reason.startswith(CONTROLLER_TIMEOUT):
        return CONTROLLER_TIMEOUT
    if reason.startswith(NOT_HELD):
        return NOT_HELD
    if "diverged" in r:
        return "diverged"
    if closing_time is not None or settled_cqi is not None:
        if closing_time is not None and not math.isfinite(closing_time):
            return "closing never triggered"
        bad_cqi = settled_cqi is not None and cqi_fails(settled_cqi, max_cqi)
        bad_pairs = locked_pairs is not None and pairs_fail(locked_pairs, min_locked_pairs)
    else:
        if "closing never triggered" in r:
            return "closing never triggered"
        bad_cqi = ("cqi" in r and ">" in r) or "not finite" in r
        bad_pairs = "locked pairs" in r
    cqi_label = f"settled CQI > {max_cqi:g}"
    pairs_label = f"locked pairs < {min_locked_pairs}"
    if bad_cqi and bad_pairs:
        return f"{cqi_label} and {pairs_label}"
    if bad_cqi:
        return cqi_label
    if bad_pairs:
        return pairs_label
    return "other"


def wilson_interval(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion."""
    if n <= 0:
        return 0.0, 1.0
    from scipy.stats import norm

    z = float(norm.ppf(0.5 + confidence / 2))
    p = successes / n
    den = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return max(0.0, centre - half), min(1.0, centre + half)


def clopper_pearson_interval(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper-Pearson) interval of a binomial proportion: beta quantiles,
    (0, upper) at 0 successes and (lower, 1) at n successes."""
    if n <= 0:
        return 0.0, 1.0
    from scipy.stats import beta

    a = 1.0 - confidence
    lo = 0.0 if successes <= 0 else float(beta.ppf(a / 2, successes, n - successes + 1))
    hi = 1.0 if successes >= n else float(beta.ppf(1 - a / 2, successes + 1, n - successes))
    return lo, hi
