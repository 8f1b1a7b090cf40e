"""What a ROS 2 user meets with `ros2 launch`, `ros2 param`, `ros2 topic echo` and
`ros2 action`, checked with real rclpy against the nodes as processes:

- under a launch file's ``name=`` (a ``__node`` remap of the whole process) every node
  keeps a unique name: the capture node's recorder is ``<name>_recorder``;
- every parameter has a descriptor (description, range) and a bad value is refused
  with the reason, at start-up and by ``ros2 param set``;
- RunCapture answers with a status (SUCCEEDED, REJECTED, ABORTED); the Capture action
  gives feedback, a result, and can be canceled;
- the result and verdict topics are latched: a subscriber that joins after the episode
  still gets them;
- a nominal request reports the seed it was sent with.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

rclpy = pytest.importorskip("rclpy", reason="ROS 2 wheels not installed: run scripts/setup.sh")

from rclpy.parameter_client import AsyncParameterClient  # noqa: E402
from ros_graph import Graph, private_domain, start_node, stop  # noqa: E402

from tethernet_ros.core.config import SimConfig  # noqa: E402
from tethernet_ros.core.design import load_design  # noqa: E402
from tethernet_ros.core.noise import NoiseModel  # noqa: E402
from tethernet_ros.ros.names import NODES, recorder_name  # noqa: E402
from tethernet_ros.ros.parameters import PARAMETERS  # noqa: E402
from tethernet_ros.ros.suite import RosSuite, suite_environment  # noqa: E402

pytestmark = [pytest.mark.ros, pytest.mark.timeout(300)]

ROOT = Path(__file__).resolve().parent.parent
PARAMS = ROOT / "config" / "tethernet.yaml"
DESIGN = load_design("time-min")
CONFIG = SimConfig(settle_time=2.0)      # short episodes


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    s = RosSuite(config=CONFIG, noise_model=NoiseModel(), bag_dir=tmp_path_factory.mktemp("bags"),
                 log_dir=tmp_path_factory.mktemp("logs"),
                 env={**os.environ, "ROS_DOMAIN_ID": str(private_domain(37))},
                 params={"capture_node": {"stall_timeout": 5.0, "start_timeout": 10.0,
                                          "ready_timeout": 2.0}})
    s.start()
    yield s
    s.stop()


# --- node names under launch ------------------------------------------------------------------
def test_launch_name_and_namespace_keep_the_recorder_apart(tmp_path):
    """`ros2 launch` starts a node with ``-r __node:=<name>`` (and ``-r __ns:=<ns>``),
    which renames every node of the process: the recorder must still be a node of its
    own, ``<name>_recorder``, whose parameters `ros2 param list` finds."""
    domain = private_domain(11)
    env = {**suite_environment(), "ROS_DOMAIN_ID": str(domain)}
    log = tmp_path / "capture.log"
    proc = start_node("capture_node", ["-r", "__node:=capture", "-r", "__ns:=/launched",
                                       "--params-file", str(PARAMS),
                                       "-p", f"bag_dir:={tmp_path / 'bags'}"], env, log)
    graph = Graph(domain)
    try:
        want = {"/launched/capture", "/launched/" + recorder_name("capture")}
        assert graph.spin_until(lambda: want <= graph.names(), timeout=60), \
            (graph.names(), log.read_text(errors="replace"))
        listed = [n for n, ns in graph.node.get_node_names_and_namespaces() if ns == "/launched"]
        assert sorted(listed) == ["capture", "capture_recorder"]          # each name once
        own = graph.ask(graph.params("/launched/capture").list_parameters).result.names
        assert "horizon" in own and "topics.net_state" in own
        rec = graph.ask(graph.params("/launched/capture_recorder").list_parameters)
        assert "use_sim_time" in rec.result.names and "horizon" not in rec.result.names
        assert proc.poll() is None
        assert "already registered" not in log.read_text(errors="replace")
    finally:
        graph.close()
        stop(proc)


def test_suite_nodes_have_unique_names(suite):
    """The suite starts its processes as the launch file does (``-r __node:=<name>``)."""
    graph = Graph(int(suite.env["ROS_DOMAIN_ID"]), "tethernet_test_names")
    try:
        want = {f"/{n}" for n in NODES} | {"/" + recorder_name("capture_node")}
        assert graph.spin_until(lambda: want <= graph.names())
        listed = [n for n, _ in graph.node.get_node_names_and_namespaces()]
        assert len(listed) == len(set(listed)), listed
    finally:
        graph.close()


# --- parameters ---------------------------------------------------------------------------------
def set_param(graph: Graph, client: AsyncParameterClient, name: str, value):
    from rclpy.parameter import Parameter

    return graph.ask(client.set_parameters, [Parameter(name, value=value)]).results[0]


def test_every_parameter_is_described_with_its_range(suite):
    graph = Graph(int(suite.env["ROS_DOMAIN_ID"]), "tethernet_test_describe")
    try:
        for node in NODES:
            client = graph.params(f"/{node}")
            names = graph.ask(client.list_parameters).result.names
            assert set(PARAMETERS[node]) <= set(names), node
            described = graph.ask(client.describe_parameters, names).descriptors
            for d in described:
                assert d.description, (node, d.name)
                spec = PARAMETERS[node].get(d.name)
                if spec is None:                       # rclpy's own parameters
                    continue
                if isinstance(spec.default, bool) or not isinstance(spec.default, (int, float)):
                    continue
                rng = d.floating_point_range if isinstance(spec.default, float) else d.integer_range
                assert len(rng) == 1, (node, d.name)
                assert (rng[0].from_value, rng[0].to_value) == (spec.low, spec.high)
                assert d.additional_constraints.startswith("must be ")
        # the core's range of the SimConfig fields, not a copy
        from tethernet_ros.core.config import _LIMITS

        assert (PARAMETERS["capture_node"]["horizon"].low,
                PARAMETERS["capture_node"]["horizon"].high) == _LIMITS["horizon"][:2]
    finally:
        graph.close()


def test_bad_parameter_values_are_refused_with_the_reason(suite):
    graph = Graph(int(suite.env["ROS_DOMAIN_ID"]), "tethernet_test_set")
    try:
        capture, sim = graph.params("/capture_node"), graph.params("/sim_node")
        actuator = graph.params("/actuator_node")
        # out of range: refused (rclpy checks the descriptor's range first)
        for client, name, value in ((capture, "horizon", -5.0), (sim, "publish_rate", 0.0),
                                    (capture, "settle_time", float("nan")),
                                    (actuator, "noise.sigma_speed", -0.1),
                                    (actuator, "noise.sigma_closing", float("inf")),
                                    (sim, "min_state_subscribers", -1)):
            r = set_param(graph, client, name, value)
            assert not r.successful and name in r.reason, (name, r.reason)
        # rules a range cannot say: the node's callback, "<name>: got X; must be ..."
        for client, name, value, must in (
                (capture, "compression", "lz4", "must be one of 'zstd', 'none'"),
                (capture, "sim_config", "[1, 2]", "must be a JSON object"),
                (capture, "sim_config", '{"dt": -1.0}', "config field 'dt': got -1.0; must be"),
                (capture, "sim_config", '{"horizon_s": 5}', "config field 'horizon_s': unknown"),
                (capture, "bag_dir", "", "must be a non-empty string")):
            r = set_param(graph, client, name, value)
            assert not r.successful, (name, value)
            assert r.reason.startswith(f"{name}: ") and must in r.reason, r.reason
        # read at start-up only: read-only
        r = set_param(graph, sim, "queue_depth", 10)
        assert not r.successful and "read-only" in r.reason
        # the values stayed; a good value is taken (and the node still serves)
        got = graph.ask(capture.get_parameters, ["horizon", "compression"]).values
        assert (got[0].double_value, got[1].string_value) == (120.0, "zstd")
        assert set_param(graph, capture, "horizon", 100.0).successful
        assert set_param(graph, capture, "horizon", 120.0).successful
        assert set_param(graph, sim, "publish_rate", 10.0).successful
    finally:
        graph.close()


@pytest.mark.parametrize("node,name,value,line", [
    ("capture_node", "horizon", -5.0, "horizon: got -5.0; must be a horizon in [1, 3600] s"),
    ("capture_node", "sim_config", '{"dt": 1.0}', "sim_config: config field 'dt': got 1.0"),
    ("sim_node", "publish_rate", 0.0, "publish_rate: got 0.0; must be a number in [0.01, 1000] Hz"),
])
def test_bad_start_up_value_stops_the_node_with_one_line(tmp_path, node, name, value, line):
    import yaml

    params = tmp_path / "params.yaml"
    params.write_text(yaml.safe_dump({f"/{node}": {"ros__parameters": {name: value}}}))
    env = {**suite_environment(), "ROS_DOMAIN_ID": str(private_domain(13))}
    out = subprocess.run(
        [sys.executable, "-m", f"tethernet_ros.ros.nodes.{node}", "--ros-args",
         "--params-file", str(PARAMS), "--params-file", str(params)],
        capture_output=True, text=True, env=env, timeout=120, cwd=tmp_path)
    assert out.returncode == 1, out.stderr
    assert f"{node}: error: {line}" in out.stderr, out.stderr
    assert "Traceback" not in out.stderr


# --- a nominal episode: the request's seed, latched results --------------------------------------
@pytest.fixture(scope="module")
def nominal_seed7(suite):
    """A nominal request that names seed 7 (noise settings and bag left out)."""
    from tethernet_msgs.srv import RunCapture

    from tethernet_ros.ros.conversions import design_msg

    req = RunCapture.Request(design=design_msg(DESIGN), seed=7, nominal=True)
    return suite.call(req, timeout=300)


def test_nominal_request_reports_its_seed(nominal_seed7):
    from tethernet_ros.core.episode import run_episode

    resp = nominal_seed7
    assert resp.error == "", resp.error
    r = resp.result
    assert r.nominal and r.seed == 7                 # the request's seed, not 0
    ref = run_episode(DESIGN, None, CONFIG, record_trace=False)     # nominal: no noise
    assert r.settled_cqi == ref.settled_cqi and r.completion_time == ref.completion_time


def test_result_and_verdict_are_latched(suite, nominal_seed7):
    """A subscriber created after the episode ended (``ros2 topic echo`` started late)
    still gets the last result and the last verdict."""
    from tethernet_msgs.msg import EpisodeResult

    from tethernet_ros.ros.names import LATCHED, TOPICS
    from tethernet_ros.ros.qos import latched_qos

    episode = nominal_seed7.result.episode_id
    assert episode
    graph = Graph(int(suite.env["ROS_DOMAIN_ID"]), "tethernet_test_late")
    try:
        got: dict[str, list] = {key: [] for key in LATCHED}
        for key in LATCHED:
            graph.node.create_subscription(EpisodeResult, TOPICS[key], got[key].append,
                                           latched_qos())
        assert graph.spin_until(lambda: all(got.values()), timeout=20), got
        for key in LATCHED:
            assert [m.episode_id for m in got[key]] == [episode], key
            assert got[key][0].seed == 7 and got[key][0].nominal
    finally:
        graph.close()


# --- the Capture action ------------------------------------------------------------------------------
class ActionUser:
    """An rclpy ActionClient of the Capture action, as `ros2 action send_goal` uses it."""

    def __init__(self, suite, name: str):
        from rclpy.action import ActionClient
        from tethernet_msgs.action import Capture

        from tethernet_ros.ros.names import ACTION

        self.graph = Graph(int(suite.env["ROS_DOMAIN_ID"]), name)
        self.client = ActionClient(self.graph.node, Capture, ACTION)
        assert self.graph.spin_until(self.client.server_is_ready), "no Capture action server"
        self.feedback: list = []

    def send(self, goal):
        self.feedback.clear()
        future = self.client.send_goal_async(goal, feedback_callback=lambda m: self.feedback.append(m.feedback))
        handle = self.graph.result(future)
        assert handle.accepted                 # every goal is accepted (Capture.action)
        return handle

    def result(self, handle, timeout: float = 300.0):
        return self.graph.result(handle.get_result_async(), timeout)

    def close(self):
        self.client.destroy()
        self.graph.close()


def goal_of(design, seed: int, **fields):
    from tethernet_msgs.action import Capture

    from tethernet_ros.ros.conversions import design_msg

    return Capture.Goal(design=design_msg(design), seed=seed, **fields)


def test_capture_action_feedback_and_result(suite):
    from action_msgs.msg import GoalStatus
    from tethernet_msgs.action import Capture

    from tethernet_ros.core.episode import run_episode

    user = ActionUser(suite, "tethernet_test_action")
    try:
        handle = user.send(goal_of(DESIGN, 3, record_bag=True, bag_name="action_seed3"))
        answer = user.result(handle)
        assert answer.status == GoalStatus.STATUS_SUCCEEDED
        res = answer.result
        assert res.status == Capture.Result.SUCCEEDED and res.error == "", res.error
        ref = run_episode(DESIGN, NoiseModel().sample(3), CONFIG, record_trace=False)
        r = res.result
        assert r.seed == 3 and r.settled_cqi == ref.settled_cqi        # bit for bit
        assert r.completion_time == ref.completion_time and r.success == ref.success
        assert Path(res.bag_path).name == "action_seed3" and Path(res.bag_path).is_dir()
        # feedback while it ran: sim time rising to the end, the CQI of each state (the
        # last feedback and the result travel on different topics: either may come first)
        assert user.graph.spin_until(lambda: bool(user.feedback) and user.feedback[-1].sim_time
                                     >= r.completion_time, timeout=10), user.feedback
        assert len(user.feedback) >= 2
        times = [f.sim_time for f in user.feedback]
        assert times == sorted(times) and times[-1] == ref.completion_time
        assert user.feedback[-1].cqi == ref.settled_cqi
        assert user.feedback[-1].locked_pairs == ref.locked_pairs
        assert user.feedback[-1].states >= 2 and user.feedback[-1].wall_time > 0
    finally:
        user.close()


def test_capture_action_cancel(suite):
    """A goal canceled mid-episode ends CANCELED: the simulation stops (no result is
    published for it), the bag stays marked incomplete, and the next goal runs."""
    from action_msgs.msg import GoalStatus
    from tethernet_msgs.action import Capture
    from tethernet_msgs.msg import EpisodeResult

    from tethernet_ros.bags import MARKER
    from tethernet_ros.ros.names import TOPICS
    from tethernet_ros.ros.qos import latched_qos

    user = ActionUser(suite, "tethernet_test_cancel")
    sim = user.graph.params("/sim_node")
    try:
        assert set_param(user.graph, sim, "real_time_factor", 1.0).successful    # 1 s per s
        handle = user.send(goal_of(DESIGN, 4, record_bag=True, bag_name="canceled"))
        assert user.graph.spin_until(lambda: any(f.states >= 3 for f in user.feedback), 60)
        cancel = user.graph.result(handle.cancel_goal_async())
        assert len(cancel.goals_canceling) == 1
        answer = user.result(handle, timeout=30)
        assert answer.status == GoalStatus.STATUS_CANCELED
        res = answer.result
        assert res.status == Capture.Result.CANCELED and "canceled" in res.error
        assert res.result == EpisodeResult()                         # no result
        bag = Path(res.bag_path)
        assert bag.name == "canceled.partial" and "canceled" in (bag / MARKER).read_text()
        # the simulation stopped: no result for that episode, ever
        last: list = []
        user.graph.node.create_subscription(EpisodeResult, TOPICS["result"], last.append,
                                            latched_qos())
        user.graph.spin_until(lambda: False, timeout=1.0)
        assert all(m.episode_id != "canceled" for m in last)
        assert set_param(user.graph, sim, "real_time_factor", 0.0).successful
        # ... and is free for the next goal
        handle = user.send(goal_of(DESIGN, 4))
        answer = user.result(handle, timeout=120)
        assert answer.result.status == Capture.Result.SUCCEEDED, answer.result.error
        assert answer.result.result.seed == 4
    finally:
        set_param(user.graph, sim, "real_time_factor", 0.0)
        user.close()


def test_capture_action_invalid_goal_says_why(suite):
    from action_msgs.msg import GoalStatus
    from tethernet_msgs.action import Capture

    user = ActionUser(suite, "tethernet_test_invalid")
    try:
        goal = goal_of(DESIGN, 1)
        goal.design.thread_radius = -1.0
        answer = user.result(user.send(goal), timeout=30)
        assert answer.status == GoalStatus.STATUS_ABORTED
        assert answer.result.status == Capture.Result.REJECTED
        assert answer.result.error.startswith("design.thread_radius: "), answer.result.error
        assert answer.result.bag_path == ""
    finally:
        user.close()
