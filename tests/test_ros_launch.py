"""The launch file's arguments take effect: the nodes started as launch_ros starts them
(the package's parameter file, then the arguments' values as a ``/**`` parameter file),
every overridden parameter read back from the running node.

launch and launch_ros are not on PyPI, so the launch file itself does not run here; its
rule is tethernet_ros/ros/launch_arguments.py's (the launch file imports it), and the
precedence of the files is rcl's own, exercised below with the real nodes.
"""
from __future__ import annotations

import pytest

rclpy = pytest.importorskip("rclpy", reason="ROS 2 wheels not installed: run scripts/setup.sh")

import yaml  # noqa: E402
from ros_graph import Graph, private_domain, start_node, stop  # noqa: E402

from tethernet_ros.ros.launch_arguments import LAUNCH_ARGUMENTS, LaunchArgumentError, \
    decider, flag, node_overrides  # noqa: E402
from tethernet_ros.ros.suite import default_params_file, suite_environment  # noqa: E402

pytestmark = [pytest.mark.ros, pytest.mark.timeout(300)]

#: launch argument values -> what the nodes must hold (actuator builtin_policy, capture
#: lockstep)
CASES = [
    ({}, True, False),
    ({"lockstep": "true"}, True, True),
    ({"builtin_policy": "false"}, False, True),
    ({"builtin_policy": "false", "example_controller": "true"}, False, True),
    ({"example_controller": "True"}, False, True),
]


def test_the_rule_of_the_arguments():
    for values, builtin, lockstep in CASES:
        assert node_overrides(values) == {"actuator_node": {"builtin_policy": builtin},
                                          "capture_node": {"lockstep": lockstep}}, values
    assert decider({"example_controller": "true", "builtin_policy": "true"}) == \
        "example_controller"
    assert decider({"builtin_policy": "false"}) == "yours"
    with pytest.raises(LaunchArgumentError, match=r"^launch argument lockstep: got 'maybe'"):
        node_overrides({"lockstep": "maybe"})
    with pytest.raises(LaunchArgumentError, match="unknown launch argument"):
        node_overrides({"lock_step": "true"})
    assert flag("x", "ON") and not flag("x", "0")
    assert set(LAUNCH_ARGUMENTS) == {"params_file", "lockstep", "builtin_policy",
                                     "example_controller"}


def launch_like(tmp_path, name: str, values: dict, env: dict, extra: list[str] = ()):
    """Start node ``name`` as launch_ros would for these launch argument values."""
    override = tmp_path / f"{name}_launch_params.yaml"
    params = node_overrides(values).get(name, {})
    override.write_text(yaml.safe_dump({"/**": {"ros__parameters": params}}))
    args = ["-r", f"__node:={name}", "--params-file", str(default_params_file()),
            "--params-file", str(override), *extra]
    return start_node(name, args, env, tmp_path / f"{name}.log")


@pytest.mark.parametrize("case", range(len(CASES)))
def test_launch_arguments_reach_the_nodes(tmp_path, case):
    values, builtin, lockstep = CASES[case]
    domain = private_domain(60 + case)
    env = {**suite_environment(), "ROS_DOMAIN_ID": str(domain)}
    procs = [launch_like(tmp_path, "actuator_node", values, env),
             launch_like(tmp_path, "capture_node", values, env,
                         ["-p", f"bag_dir:={tmp_path / 'bags'}", "-p", "horizon:=60.0"])]
    graph = Graph(domain, "tethernet_test_launch")
    try:
        got = {}
        for node, name in (("actuator_node", "builtin_policy"), ("capture_node", "lockstep"),
                           ("capture_node", "horizon")):
            client = graph.params(f"/{node}")
            got[name] = graph.ask(client.get_parameters, [name]).values[0]
        assert got["builtin_policy"].bool_value is builtin, values
        assert got["lockstep"].bool_value is lockstep, values
        assert got["horizon"].double_value == 60.0           # a `-p` beside the file counts too
        # the actuator without its built-in policy publishes no decisions at all (its name
        # reaches the graph's node list a moment after its services answer)
        assert graph.spin_until(lambda: "/actuator_node" in graph.names(), timeout=30)
        topics = {t for t, _ in graph.node.get_publisher_names_and_types_by_node(
            "actuator_node", "/")}
        assert ("/tethernet/closing_decision" in topics) is builtin, topics
    finally:
        graph.close()
        for p in procs:
            stop(p)
