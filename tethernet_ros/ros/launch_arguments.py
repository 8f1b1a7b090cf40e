"""The launch file's arguments and the node parameters they set (no ROS import).

``launch/tethernet.launch.py`` declares these arguments and passes :func:`node_overrides`
of their values to the nodes as ``parameters=[params_file, {...}]``; launch_ros writes
such a dict as a parameter file under ``/**``.  A ``/**`` entry loses to any
``/<node>:`` entry of an earlier file, so config/tethernet.yaml keeps every parameter
under ``/**`` (its header says why); tests/test_ros_launch.py starts the nodes as
launch_ros does and reads every parameter back.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class LaunchArgument:
    """One ``name:=value`` of ``ros2 launch tethernet_ros tethernet.launch.py``."""
    default: str
    description: str


#: the launch file's arguments (``params_file``'s default is the installed
#: share/tethernet_ros/config/tethernet.yaml, filled in by the launch file)
LAUNCH_ARGUMENTS: dict[str, LaunchArgument] = {
    "params_file": LaunchArgument("", "ROS parameter file of the suite (default: the "
                                      "package's config/tethernet.yaml)"),
    "lockstep": LaunchArgument("false", "true: run the closing policy through ROS (sim_node "
                                        "waits for a ClosingDecision every control period)"),
    "builtin_policy": LaunchArgument("true", "false: actuator_node leaves the closing "
                                             "decisions to your controller node (implies "
                                             "lockstep)"),
    "example_controller": LaunchArgument("false", "true: also start the example controller "
                                                  "as the one decider (implies "
                                                  "builtin_policy:=false, and so lockstep)"),
}

_TRUE = ("true", "1", "yes", "on")
_FALSE = ("false", "0", "no", "off")


class LaunchArgumentError(ValueError):
    pass


def flag(name: str, value) -> bool:
    """A boolean launch argument's value (``true``/``false``, any case; also 1/0,
    yes/no, on/off).  LaunchArgumentError names the argument otherwise."""
    if isinstance(value, bool):
        return value
    text = str(value).strip().lower()
    if text in _TRUE:
        return True
    if text in _FALSE:
        return False
    raise LaunchArgumentError(f"launch argument {name}: got {value!r}; must be true or false")


def decider(values: dict) -> str:
    """Who answers a lockstep episode's measurements: 'builtin' (actuator_node),
    'example_controller', or 'yours' (a node you start)."""
    if flag("example_controller", values.get("example_controller", "false")):
        return "example_controller"
    return "builtin" if flag("builtin_policy", values.get("builtin_policy", "true")) else "yours"


def node_overrides(values: dict) -> dict[str, dict]:
    """The node parameters that the launch arguments ``values`` (name -> text; missing
    ones take their default) set: {node: {parameter: value}}.

    One decider at a time: with ``example_controller`` true the actuator's built-in
    policy is off, and with the built-in policy off the episodes run in lockstep (the
    controller contract, docs/ros.md)."""
    unknown = sorted(set(values) - set(LAUNCH_ARGUMENTS))
    if unknown:
        raise LaunchArgumentError(f"unknown launch argument(s) {', '.join(unknown)}; the "
                                  f"arguments are {', '.join(LAUNCH_ARGUMENTS)}")
    builtin = decider(values) == "builtin"
    lockstep = flag("lockstep", values.get("lockstep", "false")) or not builtin
    return {"actuator_node": {"builtin_policy": builtin},
            "capture_node": {"lockstep": lockstep}}
