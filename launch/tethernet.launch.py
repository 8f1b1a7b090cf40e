"""Launch the tethernet_ros capture suite on a full ROS 2 Jazzy install.

    ros2 launch tethernet_ros tethernet.launch.py [params_file:=/path/to.yaml]
        [lockstep:=true]            # the closing policy through ROS, every control period
        [builtin_policy:=false]     # your controller decides (e.g. ros2 run tethernet_ros
                                    # example_controller), not actuator_node
    ros2 service call /tethernet/run_capture tethernet_msgs/srv/RunCapture \
        "{design: {corner_mass: 2.05, net_side: 19.84, thread_radius: 0.001, \
          distance_to_target: 16.14, launch_velocity: [4.02, 2.60, 8.88], \
          closing_displacement: 2.26}, seed: 3, record_bag: true}"

    ros2 action send_goal --feedback /tethernet/capture tethernet_msgs/action/Capture "{...}"

(noise settings left out: every scale 1.0, the nominal spreads; `nominal: true` for none)

Starts sim_node, monitor_node, actuator_node, sensor_node and capture_node with the
parameters of config/tethernet.yaml (installed to share/tethernet_ros/config);
``lockstep`` sets the capture node's parameter of that name, ``builtin_policy`` the
actuator node's (false implies lockstep: docs/ros.md, the controller contract), and
``example_controller:=true`` starts the example controller as the one decider (the
built-in policy off); the rule is tethernet_ros/ros/launch_arguments.py's.  launch_ros
passes them as a ``/**`` parameter file after ``params_file``; they take effect because
config/tethernet.yaml keeps every parameter under ``/**`` (a ``/<node>:`` entry would
win; tests/test_ros_launch.py).  ``name=`` reaches each
process as ``-r __node:=<name>``, which renames every node in it: the capture node's
recorder names itself ``<name>_recorder`` with a remap of its own, so names stay unique.
Without a ROS install (PyPI wheels only) use `tethernet capture --via ros`, which starts
the same processes the same way.
"""
import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction, SetEnvironmentVariable
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from tethernet_ros.ros.launch_arguments import LAUNCH_ARGUMENTS, decider, node_overrides
from tethernet_ros.ros.names import NODES


def _nodes(context):
    """The suite's Node actions for the launch arguments' values."""
    values = {name: LaunchConfiguration(name).perform(context) for name in LAUNCH_ARGUMENTS}
    params_file = values.pop("params_file") or os.path.join(
        get_package_share_directory("tethernet_ros"), "config", "tethernet.yaml")
    overrides = node_overrides(values)
    actions = [Node(package="tethernet_ros", executable=name, name=name, output="screen",
                    parameters=[params_file, *([overrides[name]] if name in overrides else [])])
               for name in NODES]
    if decider(values) == "example_controller":
        actions.append(Node(package="tethernet_ros", executable="example_controller",
                            name="example_controller", output="screen"))
    return actions


def generate_launch_description():
    return LaunchDescription([
        *(DeclareLaunchArgument(name, default_value=arg.default, description=arg.description)
          for name, arg in LAUNCH_ARGUMENTS.items()),
        SetEnvironmentVariable("ROS_AUTOMATIC_DISCOVERY_RANGE",
                               os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")),
        OpaqueFunction(function=_nodes),
    ])
