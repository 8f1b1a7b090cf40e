"""Names of the suite's graph: nodes, topics and their types, services, and what the
capture node requires of the graph before an episode.  No ROS import."""
from __future__ import annotations

from ..core import metrics

#: the node executables of the suite (console scripts, ``ros2 run tethernet_ros <node>``)
NODES = ("sim_node", "monitor_node", "actuator_node", "sensor_node", "capture_node")
#: the capture node's second node (its bag recorder) is named after it, with this suffix
RECORDER_SUFFIX = "_recorder"


def recorder_name(capture_node_name: str) -> str:
    """Name of the recorder node that belongs to the capture node ``capture_node_name``
    (its name as remapped: under ``ros2 launch ... name:=capture`` it is
    ``capture_recorder``)."""
    return capture_node_name + RECORDER_SUFFIX

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
    "cancel": "/tethernet/cancel_episode",
    # the closed loop through ROS (lockstep episodes; docs/ros.md, the controller contract)
    "true_measurement": "/tethernet/true_measurement",
    "measurement": "/tethernet/measurement",
    "closing_decision": "/tethernet/closing_decision",
    "launch_decision": "/tethernet/launch_decision",
    "sensed_target_pose": "/tethernet/sensed/target_pose",
    "sensed_target_twist": "/tethernet/sensed/target_twist",
    "sensed_net_point": "/tethernet/sensed/net_point",
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
    "cancel": "std_msgs/msg/String",       # the episode id: the simulation stops it
    "true_measurement": "tethernet_msgs/msg/Measurement",     # sim_node -> sensor_node
    "measurement": "tethernet_msgs/msg/Measurement",          # sensor_node -> controller
    "closing_decision": "tethernet_msgs/msg/ClosingDecision", # controller -> sim_node
    "launch_decision": "tethernet_msgs/msg/LaunchDecision",   # controller -> sim_node
    "sensed_target_pose": "geometry_msgs/msg/PoseWithCovarianceStamped",
    "sensed_target_twist": "geometry_msgs/msg/TwistWithCovarianceStamped",
    "sensed_net_point": "geometry_msgs/msg/PointStamped",
}

SERVICE = "/tethernet/run_capture"
#: the Capture action (tethernet_msgs/action/Capture): one capture with feedback and cancel
ACTION = "/tethernet/capture"

#: how a RunCapture request or a Capture goal ended (the constants of RunCapture.srv and
#: Capture.action, tests/test_ros_interfaces.py checks that they agree); 0 is never sent.
#: The result is valid only when SUCCEEDED.
SUCCEEDED, REJECTED, ABORTED, CANCELED = 1, 2, 3, 4
STATUS_NAMES = {SUCCEEDED: "SUCCEEDED", REJECTED: "REJECTED", ABORTED: "ABORTED",
                CANCELED: "CANCELED"}
#: std_srvs/Trigger of the capture node: success when it sees every node of the suite
READY_SERVICE = "/tethernet/suite_ready"

#: subscribers of each topic the capture node requires before it starts an episode: the
#: setup reaches the simulation, actuator and monitor nodes and the capture node's own
#: recorder; the commands the simulation, the monitor and the recorder; the net state the
#: monitor and the recorder (the sensor node, always running, is needed in lockstep only)
REQUIRED_SUBSCRIBERS = {"setup": 4, "launch_command": 3, "closing_command": 3, "net_state": 2}
#: topics that need a publisher before an episode starts
REQUIRED_PUBLISHERS = ("launch_command", "closing_command", "net_state", "metrics", "result",
                       "verdict")
#: what a lockstep episode (the closing policy run through ROS) requires besides (these
#: counts replace REQUIRED_SUBSCRIBERS'): the sensor node also on the setup and the
#: commands (it builds the episode's sensor from them), the sensor node and the recorder on
#: the truth, a controller (the actuator's built-in policy or a user's node) and the
#: recorder on the sensed measurement, the simulation and the recorder on the decisions
#: (a launch decision's publisher is needed only while a launch waits: a controller of
#: closing alone never sees a measurement before the launch)
LOCKSTEP_SUBSCRIBERS = {"setup": 5, "launch_command": 4, "closing_command": 4,
                        "true_measurement": 2, "measurement": 2, "closing_decision": 2,
                        "launch_decision": 2}
LOCKSTEP_PUBLISHERS = ("true_measurement", "measurement", "closing_decision")
#: the topic whose publisher's liveliness shows each node of the suite alive, and that
#: node: the capture node aborts an episode at once when one of them is gone
#: (qos.ALIVE_LEASE_S; the sensor node only in lockstep episodes)
WATCHED = {"net_state": "sim_node", "metrics": "monitor_node",
           "launch_command": "actuator_node", "measurement": "sensor_node"}
#: topics every bag holds, whatever ``record_topics`` says (replay needs them; the loop's
#: topics are silent unless an episode runs in lockstep)
ALWAYS_RECORDED = ("setup", "launch_command", "closing_command", "net_state", "metrics",
                   "result", "verdict", "true_measurement", "measurement", "closing_decision",
                   "launch_decision")
#: latched topics (transient-local, depth 1, qos.latched_qos): a late subscriber gets the last
LATCHED = ("result", "verdict")
#: recorded topics whose messages carry the simulated time of a state (header stamp) and go
#: on to the episode's last state (the loop's topics stop when closing starts)
STAMPED = ("net_state", "metrics", "markers", "target_pose", "clock")

#: the start of the failure reason of an episode whose controller did not answer a
#: measurement in time (sim_node's ``decision_timeout``): the capture node answers ABORTED
#: with it at once, and the ROS Monte Carlo backend counts the sample as failed
CONTROLLER_TIMEOUT = metrics.CONTROLLER_TIMEOUT


#: the start of the failure reason of a lockstep episode in which two publishers sent
#: ClosingDecisions (the contract allows one decider): the capture node answers ABORTED
TWO_CONTROLLERS = "two controllers decided"


def is_controller_timeout(reason: str) -> bool:
    """Whether a failure reason says that the episode's controller did not answer."""
    return reason.startswith(CONTROLLER_TIMEOUT)


def is_loop_failure(reason: str) -> bool:
    """Whether a failure reason is a lockstep loop's (no answer in time, or two deciders):
    the simulation's result says so, no verdict follows, the capture node answers ABORTED."""
    return reason.startswith((CONTROLLER_TIMEOUT, TWO_CONTROLLERS))
