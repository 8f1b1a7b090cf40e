"""The ROS 2 node suite with its nodes as separate processes (real rclpy, Fast DDS).

One suite (sim, monitor, actuator and capture nodes) serves the module; a short scenario
(settle time 2 s instead of 20 s) keeps each episode to a couple of seconds.  Checks:
via-ROS result == in-process result bit for bit; the bag decoded by rosbags and by
mcap-ros2-support; `tethernet replay` on good, truncated and corrupted bags; invalid
requests answered with the field named while the node keeps serving; a simulation node
killed mid-episode gives the caller a clear timeout error and an incomplete-marked bag.
The last test runs `tethernet capture --via ros` (default configuration) as a user
would.
"""
from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("rclpy", reason="ROS 2 wheels not installed: run scripts/setup.sh")

from tethernet_msgs.msg import EpisodeResult  # noqa: E402
from tethernet_msgs.srv import RunCapture  # noqa: E402

from tethernet_ros.bags import MARKER, read_bag, type_hash  # noqa: E402
from tethernet_ros.core.config import SimConfig  # noqa: E402
from tethernet_ros.core.design import load_design  # noqa: E402
from tethernet_ros.core.episode import RESULT_FIELDS, run_episode  # noqa: E402
from tethernet_ros.core.metrics import capture_quality_index  # noqa: E402
from tethernet_ros.core.noise import NoiseModel  # noqa: E402
from tethernet_ros.core.layout import grid_thread_pairs  # noqa: E402
from tethernet_ros.core.scenario import (actions_for, scenario_for,  # noqa: E402
                                         world_for)
from tethernet_ros.ros.names import ALWAYS_RECORDED, TOPICS  # noqa: E402
from tethernet_ros.ros.parameters import DEFAULTS  # noqa: E402
from tethernet_ros.ros.suite import RosSuite  # noqa: E402
from tethernet_ros.core.target import TargetConfig  # noqa: E402

pytestmark = [pytest.mark.ros, pytest.mark.timeout(400)]

DESIGN = load_design("time-min")
SEED = 3
NOISE = NoiseModel()
CONFIG = SimConfig(settle_time=2.0)      # short scenario; everything else the default
PUBLISH_RATE = 10.0
MARKER_RATE = 2.0
ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    bag_dir = tmp_path_factory.mktemp("bags")
    s = RosSuite(config=CONFIG, noise_model=NOISE, bag_dir=bag_dir,
                 log_dir=tmp_path_factory.mktemp("logs"),
                 params={"capture_node": {"stall_timeout": 3.0, "start_timeout": 8.0,
                                          "ready_timeout": 2.0},
                         "sim_node": {"publish_rate": PUBLISH_RATE, "marker_rate": MARKER_RATE}})
    # record every topic here (the default leaves out /clock and the target pose)
    s.params["capture_node"]["record_topics"] = list(TOPICS)   # (written out by start())
    s.start()
    yield s
    s.stop()


@pytest.fixture(scope="module")
def reference():
    return run_episode(DESIGN, NOISE.sample(SEED), CONFIG, record_trace=False)


@pytest.fixture(scope="module")
def captured(suite):
    result, bag = suite.capture(DESIGN, SEED, bag_name="time-min_seed3")
    return result, Path(bag)


def same(a, b) -> bool:
    return (isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b)) \
        or a == b


def assert_same_result(r, ref):
    """Every field of the library's result, bit for bit (the wall time aside; the seed
    is checked where the test knows it)."""
    for f in RESULT_FIELDS:
        if f in ("wall_time", "seed"):
            continue
        assert same(getattr(r, f), getattr(ref, f)), (f, getattr(r, f), getattr(ref, f))


# --- results --------------------------------------------------------------------------------
def test_via_ros_equals_library(captured, reference):
    result, bag = captured
    assert_same_result(result, reference)
    assert result.seed == SEED
    assert result.settled_terms == reference.settled_terms
    assert bag.is_dir() and bag.name == "time-min_seed3"
    # the client's trace is the monitor's metrics series, ending at the settled reading
    assert result.trace.time[-1] == reference.completion_time
    assert result.trace.cqi[-1] == reference.settled_cqi


# --- the bag ----------------------------------------------------------------------------------
def expected_steps(final_step: int, every: int) -> list[int]:
    steps = list(range(0, final_step + 1, every))
    return steps if steps[-1] == final_step else steps + [final_step]


def test_bag_with_rosbags(captured, reference):
    from rosbags.highlevel import AnyReader

    result, bag = captured
    msgs: dict[str, list] = {}
    with AnyReader([bag]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        for conn, _, raw in reader.messages():
            msgs.setdefault(conn.topic, []).append(reader.deserialize(raw, conn.msgtype))
    assert types == {
        TOPICS["setup"]: "tethernet_msgs/msg/EpisodeSetup",
        TOPICS["launch_command"]: "tethernet_msgs/msg/LaunchCommand",
        TOPICS["closing_command"]: "tethernet_msgs/msg/ClosingCommand",
        TOPICS["net_state"]: "tethernet_msgs/msg/NetState",
        TOPICS["target_pose"]: "geometry_msgs/msg/PoseStamped",
        TOPICS["markers"]: "visualization_msgs/msg/MarkerArray",
        TOPICS["metrics"]: "tethernet_msgs/msg/CaptureMetrics",
        TOPICS["result"]: "tethernet_msgs/msg/EpisodeResult",
        TOPICS["verdict"]: "tethernet_msgs/msg/EpisodeResult",
        TOPICS["clock"]: "rosgraph_msgs/msg/Clock",
        TOPICS["cancel"]: "std_msgs/msg/String",
        TOPICS["true_measurement"]: "tethernet_msgs/msg/Measurement",
        TOPICS["measurement"]: "tethernet_msgs/msg/Measurement",
        TOPICS["closing_decision"]: "tethernet_msgs/msg/ClosingDecision",
        TOPICS["launch_decision"]: "tethernet_msgs/msg/LaunchDecision",
        TOPICS["sensed_target_pose"]: "geometry_msgs/msg/PoseWithCovarianceStamped",
        TOPICS["sensed_target_twist"]: "geometry_msgs/msg/TwistWithCovarianceStamped",
        TOPICS["sensed_net_point"]: "geometry_msgs/msg/PointStamped",
    }
    assert TOPICS["cancel"] not in msgs                 # nothing canceled
    for key in ("true_measurement", "measurement", "closing_decision", "sensed_target_pose"):
        assert TOPICS[key] not in msgs, key             # the policy ran in the kernel
    # one setup, one of each command, one result, one verdict
    for key in ("setup", "launch_command", "closing_command", "result", "verdict"):
        assert len(msgs[TOPICS[key]]) == 1, key

    sample = NOISE.sample(SEED)
    setup = msgs[TOPICS["setup"]][0]
    assert setup.seed == SEED and not setup.nominal and setup.episode_id == bag.name
    assert setup.design.corner_mass == DESIGN.m_c
    assert list(setup.design.launch_velocity) == list(DESIGN.V_e)
    assert json.loads(setup.sim_config_json) == {"settle_time": 2.0}
    actions, world = actions_for(DESIGN, sample), world_for(DESIGN, sample)
    launch = msgs[TOPICS["launch_command"]][0]
    assert np.array_equal(np.asarray(launch.corner_velocities).reshape(4, 3), actions.corner_velocities)
    assert launch.distance_to_target == world.distance and launch.target_rotation == world.rotation
    assert msgs[TOPICS["closing_command"]][0].closing_displacement == actions.closing_displacement

    # states: every publish step from 0 to the final step, then clock/pose/metrics alike
    scen = scenario_for(DESIGN, sample, CONFIG)
    every = int(round(1.0 / (PUBLISH_RATE * scen.dt)))
    final_step = int(round(reference.completion_time / scen.dt))
    states = msgs[TOPICS["net_state"]]
    assert [m.step for m in states] == expected_steps(final_step, every)
    n = len(states)
    for key in ("clock", "target_pose", "metrics"):
        assert len(msgs[TOPICS[key]]) == n, key
    assert [m.sim_time for m in msgs[TOPICS["metrics"]]] == [m.sim_time for m in states]
    last = states[-1]
    assert last.sim_time == reference.completion_time
    assert (last.num_net_nodes, last.num_corner_masses, last.num_tether_nodes) == (289, 4, scen.n_bodies - 293)
    pos = np.asarray(last.positions).reshape(-1, 3)
    assert pos.shape == (scen.n_bodies, 3) and len(last.velocities) == 3 * scen.n_bodies
    assert last.closing_active and sum(last.locked) == reference.locked_pairs
    # the core's CQI of the recorded final state is the settled CQI
    tgt = scen.target
    terms = capture_quality_index(pos[:289], scen.bodies.mass[:289],
                                  [last.target_pose.position.x, last.target_pose.position.y,
                                   last.target_pose.position.z],
                                  tgt.volume, tgt.area, tgt.min_surface_distance)
    assert terms.cqi == reference.settled_cqi
    assert msgs[TOPICS["metrics"]][-1].cqi == reference.settled_cqi
    assert msgs[TOPICS["metrics"]][-1].locked_pairs == reference.locked_pairs
    res, ver = msgs[TOPICS["result"]][0], msgs[TOPICS["verdict"]][0]
    for r in (res, ver):
        assert r.settled_cqi == reference.settled_cqi and r.locked_pairs == reference.locked_pairs
        assert r.success == reference.success and r.completion_time == reference.completion_time
    # markers: at the marker steps and the final state; net threads and the ring
    marker_every = int(round(1.0 / (MARKER_RATE * scen.dt)))
    markers = msgs[TOPICS["markers"]]
    assert len(markers) == len([s for s in expected_steps(final_step, every)
                                if s % marker_every == 0 or s == final_step])
    ma = markers[-1].markers
    assert [m.ns for m in ma] == ["net_rows", "net_columns", "corner_threads", "closing_ring",
                                  "corner_masses", "main_tether", "target", "chaser",
                                  "target_spin"]
    assert [len(m.points) for m in ma] == [289, 289, 8, 24, 4, scen.n_bodies - 293 + 1, 0, 0, 2]
    # every grid thread is a segment of the row or the column snake
    pts = {(round(p.x, 12), round(p.y, 12), round(p.z, 12)) for p in ma[0].points}
    assert len(pts) == 289 and (ma[0].points[0].x, ma[0].points[0].y, ma[0].points[0].z) == tuple(pos[0])
    seg = set()
    for m in ma[:2]:
        q = [(p.x, p.y, p.z) for p in m.points]
        seg |= {frozenset(e) for e in zip(q[:-1], q[1:])}
    for a, b in grid_thread_pairs(17).tolist():
        assert frozenset((tuple(pos[a]), tuple(pos[b]))) in seg
    assert markers[-1].markers[0].header.stamp == last.header.stamp


def test_bag_with_mcap_ros2_and_metadata(captured):
    import yaml
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    _, bag = captured
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["version"] == 9 and meta["storage_identifier"] == "mcap"
    assert meta["relative_file_paths"] == [f"{bag.name}_0.mcap"]
    assert not (bag / MARKER).exists()
    counts: dict[str, int] = {}
    with open(bag / meta["relative_file_paths"][0], "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        for schema, channel, _message, decoded in reader.iter_decoded_messages():
            assert schema.encoding == "ros2msg" and channel.message_encoding == "cdr"
            assert decoded is not None
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if schema.name == "tethernet_msgs/msg/NetState":
                assert len(decoded.positions) == 3 * (decoded.num_net_nodes + decoded.num_corner_masses
                                                      + decoded.num_tether_nodes)
            assert "offered_qos_profiles" in channel.metadata
    listed = {t["topic_metadata"]["name"]: t["message_count"] for t in meta["topics_with_message_count"]}
    assert counts == {t: n for t, n in listed.items() if n}
    assert listed[TOPICS["cancel"]] == 0
    assert sum(counts.values()) == meta["message_count"]
    latched = {TOPICS["result"], TOPICS["verdict"]}
    for t in meta["topics_with_message_count"]:
        tm = t["topic_metadata"]
        assert tm["type_description_hash"] == type_hash(tm["type"])   # rosidl's (test_ros_bags)
        # offered QoS: `ros2 bag play` latches the result and the verdict again
        (qos,) = tm["offered_qos_profiles"]
        assert qos["durability"] == ("transient_local" if tm["name"] in latched else "volatile")
        assert (qos["depth"] == 1) == (tm["name"] in latched)


# --- replay ------------------------------------------------------------------------------------
def run_cli(*args, cwd=None, domain_id: str | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    if domain_id is not None:
        env["ROS_DOMAIN_ID"] = domain_id
    return subprocess.run([sys.executable, "-m", "tethernet_ros.cli", *args], capture_output=True,
                          text=True, cwd=cwd, env=env, timeout=300)


def test_replay_good_bag(captured, reference):
    _, bag = captured
    out = run_cli("replay", str(bag), "--json")
    assert out.returncode == 0, out.stderr
    rep = json.loads(out.stdout)
    assert rep["ok"] and rep["complete"] and rep["problems"] == []
    assert rep["matches_result"] and rep["matches_verdict"]
    assert rep["metrics_max_cqi_diff"] == 0.0 and rep["metrics_locked_pair_mismatches"] == 0
    assert rep["recomputed"]["settled_cqi"] == reference.settled_cqi
    # every message of the bag is accounted for: read, or skipped (types replay does not use)
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    listed = {t["topic_metadata"]["name"]: t["message_count"] for t in meta["topics_with_message_count"]}
    assert rep["messages"] == meta["message_count"] == rep["messages_read"] + rep["messages_skipped"]
    assert {t: c["read"] + c["skipped"] for t, c in rep["topics"].items()} == listed
    skipped = {t for t, c in rep["topics"].items() if c["skipped"]}
    assert skipped == {TOPICS["markers"], TOPICS["target_pose"], TOPICS["clock"]}
    assert all(rep["topics"][t]["read"] == 0 for t in skipped)
    assert rep["topics"][TOPICS["markers"]]["skipped"] == listed[TOPICS["markers"]] > 0
    text = run_cli("replay", str(bag))
    assert text.returncode == 0 and "replay agrees with the recorded result" in text.stdout
    assert (f"{rep['messages']} messages ({rep['messages_read']} read, {rep['messages_skipped']} "
            "skipped") in text.stdout
    assert f"{listed[TOPICS['markers']]} skipped" in text.stdout
    # the text names the target (issue 54: it did not)
    assert "  target            zenit-2 (revolution)" in text.stdout


def test_a_setup_heard_again_is_a_repeat(suite, captured):
    """The setup handshake (docs/ros.md): the capture node sends a setup again until the
    episode runs, so a node hears a setup twice.  The episode's setup sent once more after
    it ended starts nothing (without the keys, the simulation would run it again: the
    actuator sends its commands again, under the same stamp), and the next capture is
    served as before."""
    from rclpy.serialization import deserialize_message
    from tethernet_msgs.msg import EpisodeSetup

    from tethernet_ros.ros.qos import command_qos

    _, bag = captured
    (raw,) = [m.data for m in read_bag(bag).by_topic(TOPICS["setup"])]   # recorded once
    setup = deserialize_message(raw, EpisodeSetup)
    pub = suite._node.create_publisher(EpisodeSetup, TOPICS["setup"], command_qos())
    try:
        # sim, monitor, actuator, sensor and the recorder, as the suite counts them
        assert suite.spin_until(lambda: pub.get_subscription_count() >= 4, timeout=30)
        suite.metrics.clear()
        pub.publish(setup)
        suite.spin_until(lambda: False, timeout=3.0)
        assert suite.metrics == [], f"{len(suite.metrics)} states judged: the episode ran again"
    finally:
        suite._node.destroy_publisher(pub)
    result, _ = suite.capture(DESIGN, SEED, bag_name="after_a_repeat")
    assert result.success == captured[0].success
    assert result.settled_cqi == captured[0].settled_cqi


def test_replay_truncated_and_corrupted(captured, tmp_path):
    from mcap.reader import make_reader

    from tethernet_ros.bags import copy_truncated

    _, bag = captured
    total = read_bag(bag, decode=False)
    cut = copy_truncated(bag, tmp_path / "cut", 0.5)
    out = run_cli("replay", str(cut), "--json")
    assert out.returncode == 1 and "Traceback" not in out.stderr
    rep = json.loads(out.stdout)
    assert not rep["complete"] and not rep["ok"]
    assert any("truncated" in p for p in rep["problems"])
    assert 0 < rep["messages_read"] < len(total.messages)
    assert 0 < rep["states"] and rep["recomputed"] is None      # the end was cut off
    text = run_cli("replay", str(cut))
    assert text.returncode == 1 and "truncated" in text.stdout and "Traceback" not in text.stderr

    # 256 bytes zeroed inside the chunk at (or after) the file's middle: its CRC finds it
    # (outside the chunks, zeros could fall in an index and change no message)
    bad = copy_truncated(bag, tmp_path / "bad", 1.0)
    f = next(bad.glob("*.mcap"))
    data = bytearray(f.read_bytes())
    with open(f, "rb") as fh:
        chunks = make_reader(fh).get_summary().chunk_indexes
    chunk = next(c for c in chunks if c.chunk_start_offset + c.chunk_length > len(data) // 2)
    mid = chunk.chunk_start_offset + chunk.chunk_length // 2
    assert chunk is not chunks[0]
    data[mid:mid + 256] = bytes(256)
    f.write_bytes(bytes(data))
    out = run_cli("replay", str(bad), "--json")
    assert out.returncode == 1 and "Traceback" not in out.stderr
    rep = json.loads(out.stdout)
    assert not rep["ok"] and rep["problems"]
    assert 0 < rep["messages_read"] < len(total.messages)

    missing = run_cli("replay", str(tmp_path / "nothing"))
    assert missing.returncode == 2 and "does not exist" in missing.stderr


# --- faults --------------------------------------------------------------------------------------
def test_bad_requests_are_refused_and_the_node_keeps_serving(suite, reference):
    cases = []
    r = suite.request(DESIGN, SEED)
    r.design.corner_mass = float("nan")
    cases.append((r, "design.corner_mass"))
    r = suite.request(DESIGN, SEED)
    r.design.launch_velocity = [1.0, 1.0, -3.0]
    cases.append((r, "design.launch_velocity[2]"))
    r = suite.request(DESIGN, SEED)
    r.design.net_side = 1e9
    cases.append((r, "design.net_side"))
    r = suite.request(DESIGN, SEED)
    r.noise.speed_scale = float("inf")
    cases.append((r, "noise.speed_scale"))
    r = suite.request(DESIGN, SEED)
    r.noise.orientation_axis = "x"
    cases.append((r, "noise.orientation_axis"))
    cases.append((suite.request(DESIGN, SEED, bag_name="../escape"), "bag_name"))
    cases.append((suite.request(DESIGN, SEED, bag_name="time-min_seed3"), "bag_name"))  # exists
    cases.append((suite.request(DESIGN, SEED, target="hubble"), "target"))
    cases.append((suite.request(DESIGN, SEED, target=str(ROOT / "missing.stl")), "target"))
    cases.append((suite.request(DESIGN, SEED, target="envisat", target_mass=-5.0), "target_mass"))
    cases.append((suite.request(DESIGN, SEED, target_mass=100.0), "target_mass"))
    for req, field in cases:
        resp = suite.call(req, timeout=30)
        assert resp.status == RunCapture.Response.REJECTED, field
        assert resp.result == EpisodeResult() and resp.bag_path == ""     # nothing ran
        assert resp.error.startswith(field), resp.error
        assert "\n" not in resp.error
    # ... and the next valid request (nominal, no bag) is served
    nominal = run_episode(DESIGN, None, CONFIG, record_trace=False)
    result, bag = suite.capture(DESIGN, None, record_bag=False)
    assert bag is None
    assert_same_result(result, nominal)
    assert result.seed is None


def test_a_request_names_its_target(suite, tmp_path):
    """A mesh target named in the request: the episode against the Zenit-2's mesh, equal to
    the library's bit for bit; its bag's setup carries the file's name and hash."""
    config = CONFIG.replace(target=TargetConfig(name="zenit-2-cylinder"))
    expected = run_episode(DESIGN, NOISE.sample(SEED), config, record_trace=False)
    result, bag = suite.capture(DESIGN, SEED, bag_name="mesh_target",
                                target="zenit-2-cylinder")
    assert_same_result(result, expected)
    from rosbags.highlevel import AnyReader

    with AnyReader([Path(bag)]) as reader:
        conns = [c for c in reader.connections if c.topic == TOPICS["setup"]]
        setups = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(conns)]
    target = json.loads(setups[0].sim_config_json)["target"]
    assert target["name"] == "zenit-2-cylinder"
    assert target["mesh_sha256"] == config.target.mesh_sha256 and len(target["mesh_sha256"]) == 64
    # tethernet replay rebuilds the episode against the same mesh and names it
    report = json.loads(subprocess.run([str(ROOT / ".venv/bin/tethernet"), "replay", str(bag),
                                        "--json"], capture_output=True, text=True).stdout)
    assert report["target"]["name"] == "zenit-2-cylinder"
    assert report["target"]["mesh_sha256"] == config.target.mesh_sha256


def test_request_without_noise_settings_gets_the_nominal_spreads(suite):
    """A request that gives a design and a seed and leaves the noise settings out (the
    message defaults: every scale 1.0) runs with the nominal spreads: the library's
    episode of that seed, bit for bit, not a noise-free one."""
    from tethernet_ros.ros.conversions import design_msg

    seed = 5
    req = RunCapture.Request()
    req.design = design_msg(DESIGN)
    req.seed = seed
    resp = suite.call(req, timeout=300)
    assert resp.status == RunCapture.Response.SUCCEEDED and resp.error == "", resp.error
    assert resp.bag_path == ""                            # record_bag left out: false
    ref = run_episode(DESIGN, NoiseModel().sample(seed), CONFIG, record_trace=False)
    r = resp.result
    assert r.seed == seed and not r.nominal
    assert r.settled_cqi == ref.settled_cqi and r.locked_pairs == ref.locked_pairs
    assert r.completion_time == ref.completion_time and r.closing_time == ref.closing_time
    assert r.success == ref.success and r.failure_reason == ref.failure_reason
    noise_free = run_episode(DESIGN, NoiseModel().with_scales(
        **{k: 0.0 for k in NoiseModel().scales}).sample(seed), CONFIG, record_trace=False)
    assert (r.closing_time, r.settled_cqi) != (noise_free.closing_time, noise_free.settled_cqi)


def test_a_cancelled_call_leaves_the_episode(suite):
    """RosSuite.call returns once its ``cancel`` event is set (RosBackend's suites when the
    run stops, e.g. on SIGTERM), without waiting for the episode's response; the suite
    then refuses calls (the abandoned episode's states would mix with the next one's)
    until it is started again, and then serves the next request with its own episode."""
    import threading

    from tethernet_ros.ros.suite import RosCaptureError

    class AfterThreeStates(threading.Event):
        def is_set(self):                      # set once the episode is under way
            return len(suite.metrics) >= 3

    req = suite.request(load_design("baseline"), 5, record_bag=False)
    with pytest.raises(RosCaptureError, match="cancelled"):
        suite.call(req, timeout=120, cancel=AfterThreeStates())
    with pytest.raises(RosCaptureError, match="abandoned an episode"):
        suite.call(suite.request(DESIGN, SEED, record_bag=False), timeout=120)
    suite.stop()
    suite.start()
    resp = suite.call(suite.request(DESIGN, SEED, record_bag=False), timeout=120)
    assert resp.status == RunCapture.Response.SUCCEEDED, resp.error
    assert resp.result.seed == SEED
    assert suite.metrics and all(m.sim_time <= resp.result.completion_time + 1e-9
                                 for m in suite.metrics)


def test_requested_criterion_and_tow_acceleration_equal_the_library(suite):
    """A RunCapture request that asks for criterion 'held' at a towing acceleration gives
    the library's result bit for bit (every result field, the tug's verdict, its holding
    force and ladder; docs/model.md §17); the bag records the criterion and `tethernet
    replay` names it; a bad criterion, a bad acceleration and a pull above the tether's
    breaking load are each REJECTED in one line naming the field, and the suite serves
    the next request."""
    accel = 0.02
    cfg = SimConfig.from_dict({"settle_time": CONFIG.settle_time, "criterion": "held",
                               "tug": {"tow_acceleration": accel}})
    ref = run_episode(DESIGN, NOISE.sample(SEED), cfg, record_trace=False)
    assert ref.criterion == "held" and ref.tug is not None
    assert ref.tug["peak_force"] == accel * 8300.0
    result, bag = suite.capture(DESIGN, SEED, bag_name="held_seed3", criterion="held",
                                tow_acceleration=accel)
    for f in RESULT_FIELDS:
        if f not in ("wall_time", "seed", "settled_terms"):      # (the message has no terms)
            assert getattr(result, f) == getattr(ref, f) or (
                isinstance(getattr(ref, f), float) and math.isnan(getattr(ref, f))), f
    assert result.tug == ref.tug and result.criterion == "held"
    report = json.loads(run_cli("replay", str(bag), "--json").stdout)
    assert report["ok"], report["problems"]
    assert report["criterion"] == "held" and report["recorded_tug"] == ref.tug
    text = run_cli("replay", str(bag)).stdout
    assert "[criterion held]" in text and "holding force" in text or not ref.tug["held"]
    for fields, words in (({"criterion": "tug"},
                           r"^criterion: got 'tug'; must be one of 'source', 'held'"),
                          ({"criterion": "held", "tow_acceleration": -0.05},
                           r"^tow_acceleration: got -0\.05; must be an acceleration in "
                           r"\[1e-4, 10\] m/s\^2$"),
                          ({"criterion": "held", "tow_acceleration": float("nan")},
                           r"^tow_acceleration: got nan; must be an acceleration in"),
                          ({"criterion": "held", "tow_acceleration": 6.0},
                           r"^tow_acceleration: got 6 m/s\^2, a pull of 4\.98e\+04 N on the "
                           r"8300 kg target; must be at most 4\.996 m/s\^2")):
        req = suite.request(DESIGN, SEED, record_bag=False)
        for k, v in fields.items():
            setattr(req, k, v)
        resp = suite.call(req, timeout=60)
        assert resp.status == RunCapture.Response.REJECTED, fields
        assert re.match(words, resp.error), resp.error
    again, _ = suite.capture(DESIGN, SEED, record_bag=False)
    assert again.criterion == "source" and again.tug is None
    plain = run_episode(DESIGN, NOISE.sample(SEED), CONFIG, record_trace=False)
    assert (again.success, again.settled_cqi) == (plain.success, plain.settled_cqi)


def test_sim_node_killed_mid_episode(suite):
    """Last in the module: it leaves the suite without a simulation node."""
    req = suite.request(load_design("baseline"), 5, bag_name="killed")
    suite.metrics.clear()
    future = suite.client.call_async(req)
    assert suite.spin_until(lambda: len(suite.metrics) >= 3, timeout=120), "no states arrived"
    suite.kill("sim_node")
    assert suite.spin_until(future.done, timeout=30), "the service did not answer"
    resp = future.result()
    assert resp.status == RunCapture.Response.ABORTED
    assert resp.result == EpisodeResult()             # no result: all zero
    # noticed by its liveliness (tests/test_ros_dead_node.py), not by the stall timeout
    assert resp.error.startswith("sim_node (no live publisher"), resp.error
    bag = Path(resp.bag_path)
    assert bag.name == "killed.partial" and (bag / MARKER).is_file()
    assert "left the suite during the episode" in (bag / MARKER).read_text()
    assert not (bag / "metadata.yaml").exists() and not bag.with_name("killed").exists()
    contents = read_bag(bag)
    assert not contents.complete and any("incomplete" in p for p in contents.problems)
    assert contents.counts()[TOPICS["setup"]] == 1
    out = run_cli("replay", str(bag))
    assert out.returncode == 1 and "INCOMPLETE" in out.stdout and "Traceback" not in out.stderr
    # the capture node still answers, saying what is missing (DDS may still list the dead
    # node for a while; its liveliness is gone at once)
    resp = suite.call(suite.request(DESIGN, SEED, record_bag=False), timeout=60,
                      check_processes=False)
    assert resp.error.startswith("suite not ready"), resp.error
    assert "sim_node" in resp.error


# --- the command line ----------------------------------------------------------------------------
def test_cli_capture_via_ros_default_scenario(tmp_path):
    """`tethernet capture --via ros` with the default configuration (settle time 20 s)."""
    ref = run_episode(DESIGN, NOISE.sample(SEED), SimConfig(), record_trace=False)
    out = run_cli("capture", "--design", "time-min", "--seed", str(SEED), "--via", "ros",
                  "--json", "--bag-name", "cli", cwd=tmp_path,
                  # not the module suite's domain (it may still be running)
                  domain_id=str((int(os.environ.get("ROS_DOMAIN_ID", "0")) + 1) % 200 + 1))
    assert out.returncode == 0, out.stderr[-2000:]
    got = json.loads(out.stdout)
    assert got["success"] == ref.success and got["locked_pairs"] == ref.locked_pairs
    assert got["settled_cqi"] == ref.settled_cqi
    assert got["completion_time"] == ref.completion_time
    assert got["closing_time"] == ref.closing_time
    assert Path(got["bag_path"]) == (tmp_path / "bags" / "cli").resolve()
    meta = yaml.safe_load((tmp_path / "bags" / "cli" / "metadata.yaml").read_text())
    topics = {t["topic_metadata"]["name"] for t in meta["rosbag2_bagfile_information"]["topics_with_message_count"]}
    assert topics == {TOPICS[k] for k in [*DEFAULTS["capture_node"]["record_topics"],
                                          *ALWAYS_RECORDED]}


def test_tug_via_ros_equals_library(tmp_path):
    """The tug test through the nodes (`capture --via ros --tug`): the capture's verdict and
    the test's, bit for bit the library's; the bag carries it and `tethernet replay`
    reports it, and the monitor judged the settle time's state (docs/model.md §17)."""
    from tethernet_ros.core.tug import TugConfig

    (tmp_path / "short.yaml").write_text("settle_time: 2.0\ntug: {hold_time: 3.0}\n")
    config = SimConfig(settle_time=2.0, tether_order="chain",
                       tug=TugConfig(enabled=True, peak_tension=4000.0, hold_time=3.0))
    ref = run_episode(DESIGN, NOISE.sample(SEED), config, record_trace=False)
    assert ref.tug is not None
    out = run_cli("capture", "--design", "time-min", "--seed", str(SEED), "--via", "ros",
                  "--config", str(tmp_path / "short.yaml"), "--tug", "4000", "--json",
                  "--bag-name", "tug", cwd=tmp_path,
                  domain_id=str((int(os.environ.get("ROS_DOMAIN_ID", "0")) + 2) % 200 + 1))
    assert out.returncode == 0, out.stderr[-2000:]
    got = json.loads(out.stdout)
    assert got["tug"] == ref.tug
    assert got["settled_cqi"] == ref.settled_cqi and got["success"] == ref.success
    assert got["completion_time"] == ref.completion_time
    report = json.loads(subprocess.run([str(ROOT / ".venv/bin/tethernet"), "replay",
                                        str(tmp_path / "bags" / "tug"), "--json"],
                                       capture_output=True, text=True).stdout)
    assert report["ok"], report["problems"]
    assert report["recorded_tug"] == ref.tug

