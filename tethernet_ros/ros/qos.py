"""QoS profiles of the suite's topics."""
from __future__ import annotations


def state_qos(depth: int = 1000):
    """Reliable, keep-last(depth), volatile: states, metrics, markers, poses, clock."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(depth=int(depth), reliability=ReliabilityPolicy.RELIABLE,
                      history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.VOLATILE)


def command_qos():
    """Reliable, keep-last(10), volatile: setup, commands, results."""
    return state_qos(10)
