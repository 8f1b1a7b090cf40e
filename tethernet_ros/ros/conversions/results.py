"""CaptureMetrics.msg and EpisodeResult.msg from and to the core's metrics and results."""
from __future__ import annotations

import math

from ...core.episode import EpisodeResult
from ...core.metrics import criterion_of
from .stamps import set_time


#: CaptureMetrics fields that are the core's CQITerms
TERM_FIELDS = ("cqi", "volume_term", "area_term", "distance_term", "hull_volume", "hull_area",
               "com_distance")


def metrics_msg(terms, sim_time: float, locked_pairs: int, closing_active: bool,
                frame_id: str = "chaser"):
    """CaptureMetrics of core CQITerms (None: state not finite -> NaN terms)."""
    from tethernet_msgs.msg import CaptureMetrics

    m = CaptureMetrics()
    set_time(m.header.stamp, sim_time)
    m.header.frame_id = frame_id
    m.sim_time = float(sim_time)
    for name in TERM_FIELDS:
        setattr(m, name, getattr(terms, name) if terms else math.nan)
    m.locked_pairs = int(locked_pairs)
    m.closing_active = bool(closing_active)
    return m


def metrics_from_cdr(data: bytes):
    """The CaptureMetrics message of its serialized (CDR) bytes."""
    from rclpy.serialization import deserialize_message
    from tethernet_msgs.msg import CaptureMetrics

    return deserialize_message(data, CaptureMetrics)


def terms_from_msg(m) -> dict[str, float]:
    """The CQI terms of a CaptureMetrics message, by name."""
    return {name: getattr(m, name) for name in TERM_FIELDS}


def episode_result_msg(result: EpisodeResult, episode_id: str, nominal: bool,
                       sim_time: float = 0.0, seed: int | None = None):
    """EpisodeResult message of a core result, stamped with ``sim_time`` (s).  seed: the
    seed to report (the request's, also when nominal); default the result's (0 if None)."""
    from tethernet_msgs.msg import EpisodeResult as ResultMsg

    m = ResultMsg()
    set_time(m.header.stamp, sim_time)
    m.header.frame_id = "chaser"
    m.episode_id = episode_id
    if seed is None:
        seed = 0 if result.seed is None else result.seed
    m.seed = int(seed)
    m.nominal = bool(nominal)
    m.success = bool(result.success)
    m.settled_cqi = float(result.settled_cqi)
    m.locked_pairs = int(result.locked_pairs)
    ct = result.closing_time
    m.closing_time = -1.0 if ct is None or not math.isfinite(ct) else float(ct)
    m.completion_time = float(result.completion_time)
    m.mass = float(result.mass)
    m.failure_reason = result.failure_reason
    m.wall_time = float(result.wall_time)
    steps = getattr(result, "steps", -1)
    m.steps = -1 if steps is None else int(steps)
    pen = getattr(result, "max_penetration", math.nan)
    m.max_penetration = math.nan if pen is None else float(pen)
    m.launch_time = float(getattr(result, "launch_time", 0.0))
    m.criterion = criterion_of(result)
    tug = getattr(result, "tug", None)
    m.tug_tested = tug is not None
    if tug is not None:
        m.tug.holding_force = float(tug.get("holding_force", 0.0))
        m.tug.ladder = [tug_level_msg(level) for level in tug.get("ladder", [])]
        for name in TUG_FIELDS:
            value = tug[name]
            if name in ("held", "reason"):
                setattr(m.tug, name, type(getattr(m.tug, name))(value))
            elif name == "closed_pairs":
                m.tug.closed_pairs = int(value)
            else:
                setattr(m.tug, name, math.nan if value is None else float(value))
    return m


#: TugOutcome fields: the core's ``tug.TugOutcome``, in its order
TUG_FIELDS = ("held", "reason", "peak_tension", "largest_slip", "net_offset", "follow_ratio",
              "slid_share", "closed_pairs", "peak_force", "take_up_time", "duration")


def tug_level_msg(level: dict):
    """TugLevel message of a ladder level (``tug.TugOutcome.ladder``)."""
    from tethernet_msgs.msg import TugLevel

    return TugLevel(force=float(level["force"]), held=bool(level["held"]),
                    reason=str(level["reason"]), peak_tension=float(level["peak_tension"]))


def tug_from_msg(m) -> dict | None:
    """The tug verdict of an EpisodeResult message as the core's dict (None: not tested,
    or a message recorded before it carried the test)."""
    if not getattr(m, "tug_tested", False):
        return None
    d = {name: getattr(m.tug, name) for name in TUG_FIELDS}
    d["held"], d["reason"], d["closed_pairs"] = bool(d["held"]), str(d["reason"]), int(d["closed_pairs"])
    for name in TUG_FIELDS[2:]:
        if name != "closed_pairs":
            d[name] = None if not math.isfinite(d[name]) else float(d[name])
    d["holding_force"] = float(getattr(m.tug, "holding_force", 0.0))
    d["ladder"] = [{"force": float(lv.force), "held": bool(lv.held), "reason": str(lv.reason),
                    "peak_tension": float(lv.peak_tension)}
                   for lv in getattr(m.tug, "ladder", [])]
    return d


def episode_result_from_msg(m) -> EpisodeResult:
    """Core EpisodeResult of a message (a message recorded before it carried ``steps``
    and ``max_penetration``: -1 and NaN)."""
    return EpisodeResult(
        success=bool(m.success), settled_cqi=float(m.settled_cqi), locked_pairs=int(m.locked_pairs),
        closing_time=float(m.closing_time) if m.closing_time >= 0 else math.nan,
        completion_time=float(m.completion_time), mass=float(m.mass),
        failure_reason=m.failure_reason, wall_time=float(m.wall_time),
        seed=None if m.nominal else int(m.seed), steps=int(getattr(m, "steps", -1)),
        max_penetration=float(getattr(m, "max_penetration", math.nan)),
        launch_time=float(getattr(m, "launch_time", math.nan)), tug=tug_from_msg(m),
        criterion=criterion_of(m))
