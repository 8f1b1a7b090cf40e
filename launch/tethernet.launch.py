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
actuator node's (false implies lockstep: docs/ros.md, the controller contract); both win
over the parameter file's values.  ``name=`` reaches each
process as ``-r __node:=<name>``, which renames every node in it: the capture node's
recorder names itself ``<name>_recorder`` with a remap of its own, so names stay unique.
Without a ROS install (PyPI wheels only) use `tethernet capture --via ros`, which starts
the same processes the same way.
"""
import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, SetEnvironmentVariable
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PythonExpression
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue

# the node executables (tethernet_ros/ros/names.py NODES; setup.py console scripts)
NODES = ("sim_node", "monitor_node", "actuator_node", "sensor_node", "capture_node")


def generate_launch_description():
    default_params = os.path.join(get_package_share_directory("tethernet_ros"), "config",
                                  "tethernet.yaml")
    params_file = LaunchConfiguration("params_file")
    builtin = LaunchConfiguration("builtin_policy")
    # lockstep when asked, and whenever the built-in policy is off (a user's node decides)
    lockstep = PythonExpression(["'", LaunchConfiguration("lockstep"), "'.lower() == 'true' or '",
                                 builtin, "'.lower() != 'true'"])
    overrides = {
        "actuator_node": {"builtin_policy": ParameterValue(builtin, value_type=bool)},
        "capture_node": {"lockstep": ParameterValue(lockstep, value_type=bool)},
    }
    actions = [
        DeclareLaunchArgument("params_file", default_value=default_params,
                              description="ROS parameter file of the suite"),
        DeclareLaunchArgument("lockstep", default_value="false",
                              description="run the closing policy through ROS (sim_node waits "
                                          "for a ClosingDecision every control period)"),
        DeclareLaunchArgument("builtin_policy", default_value="true",
                              description="false: actuator_node leaves the closing decisions "
                                          "to your controller node (implies lockstep)"),
        DeclareLaunchArgument("example_controller", default_value="false",
                              description="true: also start the example controller (with "
                                          "builtin_policy:=false)"),
        SetEnvironmentVariable("ROS_AUTOMATIC_DISCOVERY_RANGE",
                               os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")),
    ]
    for name in NODES:
        actions.append(Node(package="tethernet_ros", executable=name, name=name,
                            output="screen",
                            parameters=[params_file, *([overrides[name]] if name in overrides
                                                       else [])]))
    actions.append(Node(package="tethernet_ros", executable="example_controller",
                        name="example_controller", output="screen",
                        condition=IfCondition(LaunchConfiguration("example_controller"))))
    return LaunchDescription(actions)
