"""The tethernet_msgs interface package, built by scripts/setup.sh, used through real rclpy.

Checks that every message and the service are generated with the agreed fields and types,
that they survive CDR serialisation, and that a NetState publish/subscribe and a RunCapture
service round trip work between two nodes in one process (Fast DDS, own domain, see
conftest.py). Runs in a few seconds.
"""
import math
import time

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy", reason="ROS 2 wheels not installed: run scripts/setup.sh")
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.qos import QoSProfile, ReliabilityPolicy, HistoryPolicy  # noqa: E402
from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402

from tethernet_msgs.msg import (  # noqa: E402
    CaptureMetrics,
    ClosingCommand,
    ClosingDecision,
    Design,
    EpisodeResult,
    TugLevel,
    TugOutcome,
    EpisodeSetup,
    LaunchCommand,
    LaunchDecision,
    Measurement,
    NetState,
    NoiseSample,
    NoiseSettings,
    Tumble,
)
from tethernet_msgs.action import Capture  # noqa: E402
from tethernet_msgs.srv import RunCapture  # noqa: E402

from tethernet_ros.ros import names  # noqa: E402

pytestmark = [pytest.mark.ros, pytest.mark.timeout(60)]

N_NET, N_CORNER, N_TETHER = 17 * 17, 4, 10
N_BODIES = N_NET + N_CORNER + N_TETHER

EXPECTED_FIELDS = {
    NetState: {
        "header": "std_msgs/Header", "sim_time": "double", "step": "uint32",
        "launch_step": "uint32", "positions": "sequence<double>", "velocities": "sequence<double>",
        "num_net_nodes": "uint32", "num_corner_masses": "uint32", "num_tether_nodes": "uint32",
        "target_pose": "geometry_msgs/Pose", "target_twist": "geometry_msgs/Twist",
        "closing_active": "boolean", "closing_start_time": "double", "locked": "sequence<boolean>",
    },
    CaptureMetrics: {
        "header": "std_msgs/Header", "sim_time": "double", "cqi": "double",
        "volume_term": "double", "area_term": "double", "distance_term": "double",
        "hull_volume": "double", "hull_area": "double", "com_distance": "double",
        "locked_pairs": "uint32", "closing_active": "boolean",
    },
    LaunchCommand: {
        "header": "std_msgs/Header", "seed": "uint64", "corner_velocities": "sequence<double>",
        "distance_to_target": "double", "target_rotation": "double", "rotation_axis": "string",
        "spin_rate": "double", "spin_axis": "double[3]", "spin_phase": "double",
        "noise": "tethernet_msgs/NoiseSample",
    },
    EpisodeSetup: {
        "header": "std_msgs/Header", "episode_id": "string", "design": "tethernet_msgs/Design",
        "seed": "uint64", "nominal": "boolean", "noise": "tethernet_msgs/NoiseSettings",
        "sim_config_json": "string", "lockstep": "boolean",
    },
    Tumble: {"rate_deg_s": "double", "axis": "string", "axis_vector": "double[3]",
             "phase_deg": "double"},
    NoiseSample: {
        "nominal": "boolean", "seed": "uint64", "distance_offset": "double",
        "orientation_angle": "double", "orientation_axis": "string",
        "speed_offsets": "double[4]", "polar_angles": "double[4]", "azimuth_angles": "double[4]",
        "closing_offset": "double", "spin_rate_offset": "double", "spin_axis_tilt": "double",
        "spin_axis_azimuth": "double", "spin_phase": "double", "spin_transverse_angle": "double",
        "target_mass_offset": "double", "target_inertia_offsets": "double[3]",
        "target_com_offset": "double[3]", "sigma_target_mass": "double",
        "sigma_target_inertia": "double", "sigma_target_com": "double",
        "sigma_distance": "double", "sigma_orientation_deg": "double", "sigma_speed": "double",
        "sigma_polar_deg": "double", "azimuth_range_deg": "double", "sigma_closing": "double",
        "sigma_spin_rate": "double", "sigma_spin_axis_deg": "double",
        "spin_phase_range_deg": "double", "scales": "tethernet_msgs/NoiseSettings",
    },
    Measurement: {
        "header": "std_msgs/Header", "episode_id": "string", "step": "uint32",
        "launched": "boolean", "age": "double", "valid": "boolean",
        "closing_displacement": "double", "net_point": "geometry_msgs/Point",
        "target_position": "geometry_msgs/Point",
        "target_orientation": "geometry_msgs/Quaternion",
        "target_angular_velocity": "geometry_msgs/Vector3",
        "target_velocity": "geometry_msgs/Vector3",
    },
    ClosingDecision: {"header": "std_msgs/Header", "episode_id": "string", "step": "uint32",
                      "close": "boolean", "controller": "string"},
    LaunchDecision: {"header": "std_msgs/Header", "episode_id": "string", "step": "uint32",
                     "launch": "boolean", "controller": "string"},
    ClosingCommand: {"header": "std_msgs/Header", "closing_displacement": "double"},
    EpisodeResult: {
        "header": "std_msgs/Header", "episode_id": "string", "seed": "uint64",
        "nominal": "boolean", "success": "boolean", "settled_cqi": "double",
        "locked_pairs": "uint32", "closing_time": "double", "completion_time": "double",
        "mass": "double", "failure_reason": "string", "wall_time": "double",
        "steps": "int64", "max_penetration": "double", "launch_time": "double",
        "tug_tested": "boolean", "tug": "tethernet_msgs/TugOutcome", "criterion": "string",
    },
    TugOutcome: {
        "held": "boolean", "reason": "string", "peak_tension": "double",
        "largest_slip": "double", "net_offset": "double", "follow_ratio": "double",
        "slid_share": "double", "closed_pairs": "uint32", "peak_force": "double",
        "take_up_time": "double", "duration": "double", "holding_force": "double",
        "ladder": "sequence<tethernet_msgs/TugLevel>",
    },
    TugLevel: {"force": "double", "held": "boolean", "reason": "string",
               "peak_tension": "double"},
    Design: {
        "corner_mass": "double", "net_side": "double", "thread_radius": "double",
        "distance_to_target": "double", "launch_velocity": "double[3]",
        "closing_displacement": "double",
    },
    NoiseSettings: {
        "distance_scale": "double", "orientation_scale": "double", "speed_scale": "double",
        "polar_scale": "double", "azimuth_scale": "double", "closing_scale": "double",
        "spin_scale": "double", "target_scale": "double", "orientation_axis": "string",
    },
    RunCapture.Request: {
        "design": "tethernet_msgs/Design", "seed": "uint64", "nominal": "boolean",
        "noise": "tethernet_msgs/NoiseSettings", "record_bag": "boolean", "bag_name": "string",
        "set_tumble": "boolean", "tumble": "tethernet_msgs/Tumble", "target": "string",
        "target_mass": "double", "target_units": "string", "set_launch": "boolean",
        "launch_policy": "string",
        "launch_max_wait": "double", "launch_max_tilt_deg": "double", "criterion": "string",
        "tow_acceleration": "double",
    },
    RunCapture.Response: {
        "status": "uint8", "error": "string", "result": "tethernet_msgs/EpisodeResult",
        "bag_path": "string",
    },
    Capture.Goal: {
        "design": "tethernet_msgs/Design", "seed": "uint64", "nominal": "boolean",
        "noise": "tethernet_msgs/NoiseSettings", "record_bag": "boolean", "bag_name": "string",
        "set_tumble": "boolean", "tumble": "tethernet_msgs/Tumble", "target": "string",
        "target_mass": "double", "target_units": "string", "set_launch": "boolean",
        "launch_policy": "string",
        "launch_max_wait": "double", "launch_max_tilt_deg": "double", "criterion": "string",
        "tow_acceleration": "double",
    },
    Capture.Result: {
        "status": "uint8", "error": "string", "result": "tethernet_msgs/EpisodeResult",
        "bag_path": "string",
    },
    Capture.Feedback: {
        "sim_time": "double", "cqi": "double", "locked_pairs": "uint32",
        "closing_active": "boolean", "states": "uint32", "wall_time": "double",
    },
}


def _baseline_design() -> Design:
    d = Design()
    d.corner_mass = 0.5
    d.net_side = 20.0
    d.thread_radius = 0.001
    d.distance_to_target = 20.0
    d.launch_velocity = [0.40, 0.40, 2.00]
    d.closing_displacement = 0.5
    return d


def _net_state(step: int) -> NetState:
    m = NetState()
    m.header.frame_id = "chaser"
    m.sim_time = 0.001 * step
    m.step = step
    m.positions = [float(step) + 1e-3 * i for i in range(3 * N_BODIES)]
    m.velocities = [-0.5 * i for i in range(3 * N_BODIES)]
    m.num_net_nodes, m.num_corner_masses, m.num_tether_nodes = N_NET, N_CORNER, N_TETHER
    m.target_pose.position.z = 20.0
    m.target_pose.orientation.w = 1.0
    m.target_twist.angular.x = 0.01
    m.closing_active = step >= 10
    m.closing_start_time = 0.010 if step >= 10 else -1.0
    m.locked = [i < step % 13 for i in range(12)]
    return m


def _all_messages():
    noise = NoiseSettings(distance_scale=1.0, orientation_scale=1.0, speed_scale=2.0,
                          polar_scale=0.1, azimuth_scale=1.0, closing_scale=10.0,
                          spin_scale=0.5, orientation_axis="y")
    result = EpisodeResult(episode_id="ep-1", seed=7, nominal=False, success=True,
                           settled_cqi=1.25, locked_pairs=11, closing_time=9.5,
                           completion_time=29.5, mass=2.38, failure_reason="", wall_time=3.2,
                           steps=29500, max_penetration=1.13e-4)
    return [
        _net_state(3),
        CaptureMetrics(sim_time=12.0, cqi=1.9, volume_term=0.1, area_term=0.2,
                       distance_term=1.6, hull_volume=150.0, hull_area=220.0,
                       com_distance=3.5, locked_pairs=12, closing_active=True),
        LaunchCommand(seed=2**63 + 5, corner_velocities=[0.4, 0.4, 2.0] * 4,
                      distance_to_target=20.1, target_rotation=math.radians(30.0),
                      rotation_axis="z"),
        ClosingCommand(closing_displacement=0.47),
        result,
        _baseline_design(),
        noise,
        RunCapture.Request(design=_baseline_design(), seed=11, nominal=True, noise=noise,
                           record_bag=True, bag_name="baseline_11", set_tumble=True,
                           tumble=Tumble(rate_deg_s=2.5, axis="", axis_vector=[0.0, 1.0, 1.0],
                                         phase_deg=45.0)),
        Measurement(episode_id="ep-1", step=40, valid=True, closing_displacement=2.26),
        ClosingDecision(episode_id="ep-1", step=40, close=True, controller="mine"),
        RunCapture.Response(status=RunCapture.Response.SUCCEEDED, error="", result=result,
                            bag_path="bags/baseline_11"),
        Capture.Result(status=Capture.Result.CANCELED, error="canceled by the client",
                       bag_path="bags/x.partial"),
        Capture.Feedback(sim_time=3.5, cqi=4.25, locked_pairs=2, closing_active=True, states=36,
                         wall_time=0.12),
    ]


@pytest.mark.parametrize("msg_type", list(EXPECTED_FIELDS), ids=lambda t: t.__qualname__)
def test_generated_fields(msg_type):
    assert msg_type.get_fields_and_field_types() == EXPECTED_FIELDS[msg_type]


def test_status_constants_agree():
    """RunCapture's and Capture's status constants are names.py's (0 is never sent)."""
    for cls in (RunCapture.Response, Capture.Result):
        for name in ("SUCCEEDED", "REJECTED", "ABORTED"):
            assert getattr(cls, name) == getattr(names, name), (cls, name)
        assert cls().status == 0
    assert Capture.Result.CANCELED == names.CANCELED
    assert not hasattr(RunCapture.Response, "CANCELED")          # a service call cannot be
    assert set(names.STATUS_NAMES) == {1, 2, 3, 4}


@pytest.mark.parametrize("msg", _all_messages(), ids=lambda m: type(m).__qualname__)
def test_build_and_cdr_round_trip(msg):
    back = deserialize_message(serialize_message(msg), type(msg))
    assert back == msg


def test_defaults():
    # Note: Jazzy's generated setters only validate types and sizes when
    # ROS_PYTHON_CHECK_FIELDS=1; validation of user input belongs to the service edge.
    d = Design()
    assert list(d.launch_velocity) == [0.0, 0.0, 0.0]
    s = NetState()
    assert len(s.positions) == 0 and len(s.locked) == 0 and s.closing_active is False
    assert s.target_pose.orientation.w == 1.0
    assert RunCapture.Response().result.failure_reason == ""
    # noise settings left out of a request are the nominal spreads, not "no noise"
    n = RunCapture.Request().noise
    assert [n.distance_scale, n.orientation_scale, n.speed_scale, n.polar_scale,
            n.azimuth_scale, n.closing_scale, n.spin_scale, n.target_scale] == [1.0] * 8
    assert n.orientation_axis == "z" and RunCapture.Request().nominal is False
    # a request that leaves its tumble out keeps the capture node's configuration
    r = RunCapture.Request()
    assert r.set_tumble is False and r.tumble.axis == "flat" and r.tumble.rate_deg_s == 0.0


def test_loop_messages_carry_the_bits():
    """A measurement crosses Measurement (and CDR) bit for bit, NaN and -0.0 included; the
    tumble and the noise draw round-trip; bad tumble fields are named with their range."""
    from tethernet_ros.core.noise import NoiseModel
    from tethernet_ros.core.sensing import N_CHANNELS
    from tethernet_ros.core.tumble import TumbleConfig
    from tethernet_ros.ros import conversions as conv

    rng = np.random.default_rng(1)
    values = rng.standard_normal(N_CHANNELS) * 10.0 ** rng.integers(-300, 300, N_CHANNELS)
    values[1], values[7] = math.nan, -0.0
    m = conv.measurement_msg(values, 120, 0.12, "ep", 2.25)
    back = conv.measurement_from_msg(deserialize_message(serialize_message(m), Measurement))
    assert back.tobytes() == values.tobytes()
    empty = conv.measurement_msg(None, 20, 0.02, "ep", 2.25)
    assert conv.measurement_from_msg(empty) is None and not empty.valid
    for t in (TumbleConfig(), TumbleConfig(rate_deg_s=12.5, axis="los", phase_deg=-30.0),
              TumbleConfig(rate_deg_s=60.0, axis=(0.0, 3.0, 4.0))):
        assert conv.tumble_from_msg(conv.tumble_msg(t)) == t
    for fields, words in (({"rate_deg_s": 60.5}, r"^tumble\.rate_deg_s: got 60\.5; must be a rate "
                                                 r"in \[0, 60\] deg/s$"),
                          ({"axis": ""}, r"^tumble\.axis_vector: got the zero vector"),
                          ({"axis": "up"}, r"^tumble\.axis: got 'up'; must be one of .*axis_vector"),
                          ({"phase_deg": math.inf}, r"^tumble\.phase_deg: got inf")):
        msg = Tumble(**fields)
        with pytest.raises(conv.RequestError, match=words):
            conv.tumble_from_msg(msg)
    model = NoiseModel(sigma_spin_rate=0.3, sigma_target_mass=0.05, sigma_target_inertia=0.1,
                       sigma_target_com=0.2, scales={"spin": 2.0, "target": 0.5})
    sample = model.sample(17)
    drawn, spreads = conv.noise_sample_from_msg(conv.noise_sample_msg(sample, model))
    assert drawn == sample and spreads == model.spreads()
    assert conv.noise_sample_msg(None, None).nominal
    # the target's drawn mass properties reach the simulation node's world
    from tethernet_ros.core.design import REFERENCE_DESIGNS
    from tethernet_ros.core.scenario import actions_for, world_for

    design = REFERENCE_DESIGNS["time-min"]
    launch = conv.launch_command_msg(actions_for(design, sample), world_for(design, sample),
                                     17, (1, 2), sample=sample, model=model)
    closing = conv.closing_command_msg(actions_for(design, sample), (1, 2))
    _, world = conv.commands_from_msgs(launch, closing)
    assert world == world_for(design, sample)
    assert world.target_mass_offset != 0.0 and all(world.target_com_offset)


@pytest.fixture()
def ros_pair():
    """Two nodes on a private rclpy context, spun by one executor."""
    context = rclpy.Context()
    context.init()
    executor = SingleThreadedExecutor(context=context)
    a = rclpy.create_node("tethernet_test_a", context=context)
    b = rclpy.create_node("tethernet_test_b", context=context)
    executor.add_node(a)
    executor.add_node(b)
    try:
        yield a, b, executor
    finally:
        executor.shutdown()
        a.destroy_node()
        b.destroy_node()
        context.try_shutdown()


def _spin_until(executor, predicate, timeout=5.0):
    deadline = time.monotonic() + timeout
    while not predicate() and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.02)
    return predicate()


def test_net_state_publish_subscribe(ros_pair):
    a, b, executor = ros_pair
    qos = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE,
                     history=HistoryPolicy.KEEP_LAST)
    received = []
    b.create_subscription(NetState, "net_state", received.append, qos)
    pub = a.create_publisher(NetState, "net_state", qos)
    assert _spin_until(executor, lambda: pub.get_subscription_count() > 0)

    sent = [_net_state(i) for i in range(20)]
    for m in sent:
        pub.publish(m)
        executor.spin_once(timeout_sec=0.0)
    assert _spin_until(executor, lambda: len(received) == len(sent))
    assert [m.step for m in received] == list(range(20))
    assert received == sent
    assert len(received[-1].positions) == 3 * N_BODIES
    assert list(received[-1].locked) == [i < 19 % 13 for i in range(12)]


def test_run_capture_service_round_trip(ros_pair):
    a, b, executor = ros_pair

    def handle(request, response):
        m_c = request.design.corner_mass
        if not 0.0 < m_c <= 100.0:
            response.status = RunCapture.Response.REJECTED
            response.error = f"design.corner_mass={m_c} kg outside (0, 100] kg"
            return response
        response.status = RunCapture.Response.SUCCEEDED
        response.result.seed = request.seed
        response.result.nominal = request.nominal
        response.result.mass = 4.0 * m_c
        response.result.success = True
        response.result.locked_pairs = 12
        if request.record_bag:
            response.bag_path = "bags/" + request.bag_name
        return response

    b.create_service(RunCapture, "run_capture", handle)
    client = a.create_client(RunCapture, "run_capture")
    assert _spin_until(executor, client.service_is_ready)

    def call(request):
        future = client.call_async(request)
        executor.spin_until_future_complete(future, timeout_sec=5.0)
        assert future.done(), "service call timed out"
        return future.result()

    ok = call(RunCapture.Request(design=_baseline_design(), seed=2**40 + 3, nominal=False,
                                 record_bag=True, bag_name="b1"))
    assert ok.status == RunCapture.Response.SUCCEEDED and ok.error == ""
    assert ok.result.seed == 2**40 + 3 and ok.result.nominal is False
    assert ok.result.mass == pytest.approx(2.0)
    assert ok.result.locked_pairs == 12 and ok.bag_path == "bags/b1"

    bad_design = _baseline_design()
    bad_design.corner_mass = -1.0
    bad = call(RunCapture.Request(design=bad_design, seed=1))
    assert bad.status == RunCapture.Response.REJECTED and "corner_mass" in bad.error


def test_markers_draw_the_target_as_it_is():
    """The Zenit-2 as a cylinder primitive, as before; a mesh target as a TRIANGLE_LIST of
    its body-frame triangles posed by the target's attitude."""
    from visualization_msgs.msg import Marker

    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.design import REFERENCE_DESIGNS
    from tethernet_ros.core.episode import CaptureSimulation
    from tethernet_ros.core.scenario import scenario_for
    from tethernet_ros.core.target import TargetConfig
    from tethernet_ros.ros.markers import MarkerBuilder
    from tethernet_ros.ros.state import state_arrays

    def target_marker(cfg):
        sim = CaptureSimulation(scenario_for(REFERENCE_DESIGNS["time-min"], None, cfg))
        out = MarkerBuilder(sim.s).build(state_arrays(sim))
        return sim, next(m for m in out.markers if m.ns == "target")

    _, m = target_marker(SimConfig())
    assert m.type == Marker.CYLINDER and (m.scale.x, m.scale.z) == (3.9, 10.4)
    sim, m = target_marker(SimConfig(target=TargetConfig(name="envisat",
                                                         attitude_deg=(0.0, 0.0, 30.0))))
    assert m.type == Marker.TRIANGLE_LIST and len(m.points) == 3 * len(sim.s.target.faces)
    q = sim.s.target_body.quat
    assert [m.pose.orientation.w, m.pose.orientation.x, m.pose.orientation.y,
            m.pose.orientation.z] == [float(c) for c in q]
    first = sim.s.target.vertices[sim.s.target.faces[0, 0]]
    assert [m.points[0].x, m.points[0].y, m.points[0].z] == [float(c) for c in first]
