"""The RunCapture service's and the Capture action's replies, feedback and cancel."""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..names import SUCCEEDED


@dataclass
class Outcome:
    """How one RunCapture request or Capture goal ended.  status: names.SUCCEEDED,
    REJECTED, ABORTED or CANCELED; error: '' when SUCCEEDED, else why (one line);
    result: the EpisodeResult message (SUCCEEDED only); bag_path: '' if none."""

    status: int
    error: str = ""
    result: object = None
    bag_path: str = ""


def capture_reply(reply, outcome: Outcome):
    """Fill a RunCapture.Response or Capture.Result (the same fields) from an Outcome;
    the result stays all zero unless SUCCEEDED.  Returns ``reply``."""
    reply.status = int(outcome.status)
    reply.error = outcome.error
    reply.bag_path = outcome.bag_path
    if outcome.status == SUCCEEDED and outcome.result is not None:
        reply.result = outcome.result
    return reply


def capture_feedback_msg(metrics, states: int, wall_time: float):
    """Capture.Feedback of the latest CaptureMetrics message (None: none yet), the states
    heard so far and the wall time since the goal started (s)."""
    from tethernet_msgs.action import Capture

    fb = Capture.Feedback()
    fb.states = int(states)
    fb.wall_time = float(wall_time)
    if metrics is not None:
        fb.sim_time = float(metrics.sim_time)
        fb.cqi = float(metrics.cqi)
        fb.locked_pairs = int(metrics.locked_pairs)
        fb.closing_active = bool(metrics.closing_active)
    else:
        fb.cqi = math.nan
    return fb


def cancel_msg(episode_id: str):
    """The cancel topic's message (std_msgs/String): the id of the episode to stop."""
    from std_msgs.msg import String

    return String(data=episode_id)
