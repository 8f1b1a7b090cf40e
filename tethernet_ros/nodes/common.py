"""Names, QoS profiles, parameter defaults and the main-loop helper shared by the nodes.

The defaults here and config/tethernet.yaml must agree (tests/test_ros_nodes.py checks it).
Rates are in Hz of *simulated* time; timeouts in wall-clock seconds.
"""
from __future__ import annotations

import os
import sys
import time

#: topic names (parameters ``topics.<key>`` of every node)
TOPICS: dict[str, str] = {
    "setup": "/tethernet/episode_setup",
    "launch_command": "/tethernet/launch_command",
    "closing_command": "/tethernet/closing_command",
    "net_state": "/tethernet/net_state",
    "target_pose": "/tethernet/target_pose",
    "markers": "/tethernet/markers",
    "metrics": "/tethernet/capture_metrics",
    "result": "/tethernet/episode_result",
    "verdict": "/tethernet/monitor_verdict",
    "clock": "/clock",
}

#: message type of every topic (ROS 2 type names)
TOPIC_TYPES: dict[str, str] = {
    "setup": "tethernet_msgs/msg/EpisodeSetup",
    "launch_command": "tethernet_msgs/msg/LaunchCommand",
    "closing_command": "tethernet_msgs/msg/ClosingCommand",
    "net_state": "tethernet_msgs/msg/NetState",
    "target_pose": "geometry_msgs/msg/PoseStamped",
    "markers": "visualization_msgs/msg/MarkerArray",
    "metrics": "tethernet_msgs/msg/CaptureMetrics",
    "result": "tethernet_msgs/msg/EpisodeResult",
    "verdict": "tethernet_msgs/msg/EpisodeResult",
    "clock": "rosgraph_msgs/msg/Clock",
}

SERVICE = "/tethernet/run_capture"
#: std_srvs/Trigger of the capture node: success when it sees every node of the suite
READY_SERVICE = "/tethernet/suite_ready"

#: parameter defaults per node (nested names use '.'); config/tethernet.yaml mirrors them
DEFAULTS: dict[str, dict] = {
    "sim_node": {
        "publish_rate": 10.0,        # NetState / target pose / clock rate (Hz of sim time)
        "marker_rate": 2.0,          # MarkerArray rate (Hz of sim time)
        "real_time_factor": 0.0,     # > 0: pace the episode at this multiple of real time
        "frame_id": "chaser",
        "queue_depth": 1000,
        "min_state_subscribers": 2,  # monitor + recorder: wait for them before stepping
        "match_timeout": 5.0,        # s (wall) to wait for those subscribers
        "warm_up": True,             # load the numba kernels before announcing the node
    },
    "monitor_node": {
        "queue_depth": 1000,
        "frame_id": "chaser",
    },
    "actuator_node": {
        # spreads of SPEC section 6 (the request's NoiseSettings scale them)
        "noise.sigma_distance": 0.25,         # m
        "noise.sigma_orientation_deg": 45.0,  # deg
        "noise.sigma_speed": 0.25,            # m/s
        "noise.sigma_polar_deg": 2.0,         # deg
        "noise.azimuth_range_deg": 360.0,     # deg, uniform on [0, range)
        "noise.sigma_closing": 0.1,           # m
        "min_command_subscribers": 3,         # sim + monitor + recorder
        "match_timeout": 5.0,
        "frame_id": "chaser",
    },
    "capture_node": {
        "bag_dir": "bags",
        "compression": "zstd",       # MCAP chunk compression: zstd, lz4 or none
        "settle_time": 20.0,         # s (sim) after closing activation: SPEC default
        "horizon": 120.0,            # s (sim): SPEC default
        "sim_config": "{}",          # JSON of further SimConfig overrides
        "start_timeout": 60.0,       # s (wall) for the first state of an episode
        "stall_timeout": 15.0,       # s (wall) without a new state -> the episode is aborted
        "episode_timeout": 3600.0,   # s (wall) for a whole episode
        "ready_timeout": 30.0,       # s (wall) to wait for the other nodes before an episode
        "drain_time": 0.0,           # s (wall) of extra quiet time before closing a bag
                                     # (completeness is checked by stamps, not by waiting)
        # topics recorded in bags (keys of TOPICS; ALWAYS_RECORDED are added); /clock and
        # the target pose are left out by default: the states carry both
        "record_topics": ["setup", "launch_command", "closing_command", "net_state", "markers",
                          "metrics", "result", "verdict"],
    },
}
for _node in DEFAULTS.values():
    _node.update({f"topics.{k}": v for k, v in TOPICS.items()})
DEFAULTS["capture_node"]["service"] = SERVICE

#: subscribers of each topic the capture node requires before it starts an episode
#: (its own recorder included)
REQUIRED_SUBSCRIBERS = {"setup": 4, "launch_command": 3, "closing_command": 3, "net_state": 2}
#: topics every bag holds, whatever ``record_topics`` says (replay needs them)
ALWAYS_RECORDED = ("setup", "launch_command", "closing_command", "net_state", "metrics",
                   "result", "verdict")
#: publishers it requires
REQUIRED_PUBLISHERS = ("launch_command", "closing_command", "net_state", "metrics", "result",
                       "verdict")


def state_qos(depth: int = 1000):
    """Reliable, keep-last(depth), volatile: states, metrics, markers, poses, clock."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(depth=int(depth), reliability=ReliabilityPolicy.RELIABLE,
                      history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.VOLATILE)


def command_qos():
    """Reliable, keep-last(10), volatile: setup, commands, results."""
    return state_qos(10)


def declare(node, name: str) -> None:
    """Declare every default parameter of ``name`` (a key of DEFAULTS) on ``node``."""
    for key, value in DEFAULTS[name].items():
        node.declare_parameter(key, value)


def param(node, key: str):
    return node.get_parameter(key).value


def topic(node, key: str) -> str:
    return node.get_parameter(f"topics.{key}").value


def wait_for_subscribers(publisher, count: int, timeout: float) -> bool:
    """Wait until ``publisher`` has matched ``count`` subscriptions (or timeout s)."""
    deadline = time.monotonic() + timeout
    while publisher.get_subscription_count() < count:
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def default_environment() -> None:
    """Keep DDS discovery on this host unless the environment says otherwise."""
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")


def run_node(factory, args=None, threads: int = 1) -> int:
    """rclpy main loop: init, build the node, spin until Ctrl-C / SIGTERM / shutdown,
    clean up.  Returns the process exit status (0 on a clean shutdown)."""
    default_environment()
    import signal

    import rclpy
    from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor, \
        SingleThreadedExecutor

    rclpy.init(args=args if args is not None else sys.argv)
    # SIGTERM shuts down as cleanly as SIGINT (rclpy handles SIGINT itself)
    signal.signal(signal.SIGTERM, lambda *_: rclpy.try_shutdown())
    node = None
    status = 0
    try:
        node = factory()
        executor = MultiThreadedExecutor(num_threads=threads) if threads > 1 \
            else SingleThreadedExecutor()
        executor.add_node(node)
        try:
            executor.spin()
        finally:
            executor.shutdown(timeout_sec=1.0)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception as exc:  # noqa: BLE001 - one line on stderr, non-zero status
        if os.environ.get("TETHERNET_DEBUG"):
            import traceback

            traceback.print_exc()
        name = node.get_name() if node is not None else getattr(factory, "__name__", "node")
        print(f"{name}: error: {exc}", file=sys.stderr)
        status = 1
    finally:
        if node is not None:
            close = getattr(node, "close", None)
            if close is not None:
                close()
            node.destroy_node()
        rclpy.try_shutdown()
    return status
