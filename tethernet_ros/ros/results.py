"""Episode results as the suite reports them: comparing two results, and reading an
episode's result back from its bag.  No ROS import."""
from __future__ import annotations

import math

from ..core.episode import source_verdict
from ..core.metrics import criterion_of
from .names import TOPICS


class BagResultError(RuntimeError):
    """The episode's bag does not hold a usable, consistent result (one line)."""


def compare_results(a, b) -> str:
    """'' if two results (core or message; closing_time NaN and -1 both mean 'never')
    agree exactly on success, settled CQI, n_L, closing time, T and failure reason; else
    a one-line description of the first difference.  Results judged by different criteria
    (the simulation's 'held', the monitor's 'source': it judges states and cannot pull)
    are compared by the source's criterion (:func:`source_verdict`)."""
    def ct(r):
        v = r.closing_time
        return math.nan if v is None or (isinstance(v, float) and not math.isnan(v) and v < 0) else v
    (sa, ra), (sb, rb) = ((a.success, a.failure_reason), (b.success, b.failure_reason)) \
        if criterion_of(a) == criterion_of(b) else (source_verdict(a), source_verdict(b))
    for name, va, vb in (("success", sa, sb),
                         ("settled_cqi", a.settled_cqi, b.settled_cqi),
                         ("locked_pairs", a.locked_pairs, b.locked_pairs),
                         ("closing_time", ct(a), ct(b)),
                         ("completion_time", a.completion_time, b.completion_time),
                         ("failure_reason", ra, rb)):
        if isinstance(va, float) or isinstance(vb, float):
            fa, fb = float(va), float(vb)
            if (math.isnan(fa) and math.isnan(fb)) or fa == fb:
                continue
        elif va == vb:
            continue
        return f"{name} differs: {va!r} vs {vb!r}"
    return ""


def result_from_bag(bag_path, episode_id: str | None = None, with_metrics: bool = False):
    """``(EpisodeResult message, metrics messages)`` of the episode recorded in a bag.

    Reads the result and verdict topics (and the metrics topic if ``with_metrics``); the
    bag must be complete, hold exactly one simulation result for ``episode_id`` (any id if
    None) and a monitor verdict that agrees with it.  Raises :class:`BagResultError`.
    """
    from ..bags import BagError, read_bag

    topics = {TOPICS["result"], TOPICS["verdict"]}
    if with_metrics:
        topics.add(TOPICS["metrics"])
    try:
        contents = read_bag(bag_path, topics=topics)
    except BagError as exc:
        raise BagResultError(str(exc)) from None
    if not contents.complete:
        raise BagResultError(f"bag {bag_path} is incomplete or damaged: "
                             + "; ".join(contents.problems or ["no MCAP footer"]))

    def pick(topic):
        msgs = [m.msg for m in contents.by_topic(topic)
                if m.msg is not None and (episode_id is None or m.msg.episode_id == episode_id)]
        if len(msgs) != 1:
            raise BagResultError(f"bag {bag_path} holds {len(msgs)} messages on {topic} for "
                                 f"episode {episode_id!r}; expected 1")
        return msgs[0]

    result = pick(TOPICS["result"])
    verdict = pick(TOPICS["verdict"])
    mismatch = compare_results(result, verdict)
    if mismatch:
        raise BagResultError(f"bag {bag_path}: monitor verdict disagrees with the simulation "
                             f"result: {mismatch}")
    metrics = []
    if with_metrics:
        metrics = sorted((m.msg for m in contents.by_topic(TOPICS["metrics"])
                          if m.msg is not None), key=lambda m: m.sim_time)
    return result, metrics
