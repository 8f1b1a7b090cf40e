"""QoS profiles of the suite's topics."""
from __future__ import annotations

#: keep-last depth of the latched topics (the last message is what a late subscriber gets)
LATCHED_DEPTH = 1


def state_qos(depth: int = 1000):
    """Reliable, keep-last(depth), volatile: states, metrics, markers, poses, clock."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(depth=int(depth), reliability=ReliabilityPolicy.RELIABLE,
                      history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.VOLATILE)


#: s: the liveliness lease each node of the suite offers on the topic that shows it alive
#: (names.WATCHED; AUTOMATIC liveliness: DDS asserts it while the process lives, also
#: while the node is busy, so a hung node is not taken for a dead one)
ALIVE_LEASE_S = 0.5
#: s: the lease the capture node asks of them: a node whose process is gone (killed, or
#: crashed, which the ROS graph shows only after DDS's participant lease, about 20 s) is
#: noticed this long after
ALIVE_DEADLINE_S = 1.0


def alive_qos(qos, lease_s: float):
    """``qos`` with AUTOMATIC liveliness and a lease of ``lease_s`` s (offered by a
    publisher, or asked for by a subscription: an offer at most the request matches)."""
    import copy

    from rclpy.duration import Duration
    from rclpy.qos import LivelinessPolicy

    qos = copy.copy(qos)
    qos.liveliness = LivelinessPolicy.AUTOMATIC
    qos.liveliness_lease_duration = Duration(seconds=lease_s)
    return qos


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
