"""The capture node's recording of one episode: what has been heard on each topic, and
when the recording is complete.

Messages arrive serialized (CDR) and go to the bag as they are; only the stamps of the
stamped topics are read in place, and the two results are decoded.  The recording is
complete when the simulation's result and the monitor's verdict are in and every stamped
topic heard has reached the result's stamp (the last state's sim time): no timer decides.
"""
from __future__ import annotations

import importlib
import struct
import threading
import time
from dataclasses import dataclass, field

from .names import STAMPED, is_loop_failure

#: topics whose messages the setup handshake may send again (docs/ros.md): a message
#: equal, byte for byte, to one already recorded in the episode is a repeat, not recorded
REPEATABLE = ("setup", "launch_command", "closing_command")


def cdr_stamp(key: str, data: bytes) -> tuple[int, int] | None:
    """(sec, nanosec) stamp of a serialized (CDR) message of a STAMPED topic, read in
    place: the header (or, for /clock, the time) is the first field; a MarkerArray's is
    its first marker's (None when it has none)."""
    order = "<" if data[1] == 1 else ">"         # encapsulation id: CDR_LE 0x0001, CDR_BE 0x0000
    offset = 4
    if key == "markers":
        (count,) = struct.unpack_from(order + "I", data, offset)
        if count == 0:
            return None
        offset += 4
    sec, nsec = struct.unpack_from(order + "iI", data, offset)
    return sec, nsec


def msg_class(type_name: str):
    """The rclpy message class of a type name pkg/msg/Name."""
    pkg, _, name = type_name.split("/")
    return getattr(importlib.import_module(f"{pkg}.msg"), name)


@dataclass
class Episode:
    """One episode as the capture node records it (times: time.monotonic() s)."""

    episode_id: str
    writer: object | None                  # bags.BagWriter, or None without a bag
    started: float
    last_state: float | None = None
    n_states: int = 0
    n_metrics: int = 0
    last_message: float = 0.0
    last_metrics: bytes | None = None      # the latest CaptureMetrics (CDR), for feedback
    result: object = None                  # the simulation's EpisodeResult message
    verdict: object = None                 # the monitor's EpisodeResult message
    last_stamp: dict = field(default_factory=dict)   # STAMPED key -> (sec, nanosec)
    ended: threading.Event = field(default_factory=threading.Event)
    lock: threading.Lock = field(default_factory=threading.Lock)
    repeatable: set = field(default_factory=set)     # REPEATABLE messages recorded (CDR)

    def record(self, key: str, topic_name: str, data: bytes) -> None:
        """Write one serialized message of topic ``key`` and note what it says (a repeat
        of a REPEATABLE message is neither)."""
        if key in REPEATABLE:
            with self.lock:
                if data in self.repeatable:
                    return
                self.repeatable.add(bytes(data))
        if self.writer is not None:
            self.writer.write(topic_name, data, time.time_ns())
        now = time.monotonic()
        with self.lock:
            self.last_message = now
            if key in STAMPED:
                st = cdr_stamp(key, data)
                if st is not None:
                    self.last_stamp[key] = st
            if key == "net_state":
                self.n_states += 1
                self.last_state = now
            elif key == "metrics":
                self.n_metrics += 1
                self.last_metrics = data
            elif key in ("result", "verdict"):
                from rclpy.serialization import deserialize_message
                from tethernet_msgs.msg import EpisodeResult

                msg = deserialize_message(data, EpisodeResult)
                if msg.episode_id == self.episode_id:
                    setattr(self, key, msg)
                    if self.result is not None and (
                            self.verdict is not None
                            or is_loop_failure(self.result.failure_reason)):
                        self.ended.set()      # (no verdict comes for a controller's failure)

    def behind(self) -> list[str]:
        """Stamped topics heard in this episode that have not reached the result's stamp
        (net_state and metrics count even when not heard at all)."""
        final = (self.result.header.stamp.sec, self.result.header.stamp.nanosec)
        with self.lock:
            late = sorted(k for k, st in self.last_stamp.items() if st < final)
            return late + [k for k in ("net_state", "metrics") if k not in self.last_stamp]

    def quiet_for(self) -> float:
        """Seconds since the last message."""
        with self.lock:
            return time.monotonic() - self.last_message

    def seen_running(self) -> bool:
        """True once two states and a metrics message of the episode are in: the
        simulation and the monitor both have their setup and commands (the lockstep
        loop too, which the second state waits for)."""
        with self.lock:
            return self.n_states >= 2 and self.n_metrics >= 1

    def progress(self) -> tuple[int, bytes | None]:
        """(metrics messages heard, the latest one serialized, or None)."""
        with self.lock:
            return self.n_metrics, self.last_metrics

    def settled(self) -> bool:
        """True once there is a metrics message for every state heard."""
        with self.lock:
            return self.n_metrics >= self.n_states
