"""QoS profiles of the suite's topics."""
from __future__ import annotations

#: keep-last depth of the latched topics (the last message is what a late subscriber gets)
LATCHED_DEPTH = 1


def state_qos(depth: int = 1000):
    """Reliable, keep-last(depth), volatile: states, metrics, markers, poses, clock."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(depth=int(depth), reliability=ReliabilityPolicy.RELIABLE,
                      history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.VOLATILE)


def command_qos():
    """Reliable, keep-last(10), volatile: setup and commands."""
    return state_qos(10)


def latched_qos():
    """Reliable, keep-last(1), transient-local: the episode result and the monitor's
    verdict.  A reliable, transient-local subscriber that joins later (``ros2 topic echo
    --qos-durability transient_local --qos-reliability reliable``) still gets the last
    one; a best-effort one gets no history; a volatile one matches and gets only new ones."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(depth=LATCHED_DEPTH, reliability=ReliabilityPolicy.RELIABLE,
                      history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.TRANSIENT_LOCAL)
