"""Message stamps: builtin_interfaces/Time from and to seconds (sec + nanosec)."""
from __future__ import annotations






def split_time(t: float) -> tuple[int, int]:
    """(sec, nanosec) of a non-negative time ``t`` in s."""
    ns = int(round(max(t, 0.0) * 1e9))
    return ns // 1_000_000_000, ns % 1_000_000_000


def set_time(msg_time, t: float):
    """Set a builtin_interfaces/Time to ``t`` s; returns it."""
    msg_time.sec, msg_time.nanosec = split_time(t)
    return msg_time


def time_from_msg(msg_time) -> float:
    """Seconds of a builtin_interfaces/Time."""
    return msg_time.sec + 1e-9 * msg_time.nanosec
