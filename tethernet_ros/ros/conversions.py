"""Conversions between tethernet_msgs / common_interfaces messages and the core's objects:
``<thing>_msg(...)`` builds a message, ``<thing>_from_msg(msg)`` reads one back.

Readers use attribute access only, so they accept rclpy messages as well as messages
decoded from a bag by mcap-ros2-support or rosbags.  Builders import the rclpy message
classes lazily.  Readers of request fields validate them: RequestError names the field.

Units: SI; times in s (builtin_interfaces/Time: sec + nanosec).  Quaternions are
(w, x, y, z) in the core and (x, y, z, w) in geometry_msgs.  NetState body order is the
core's body layout (core/layout.py): 289 net nodes (row-major), 4 corner masses, then
the main tether's lumped masses from the net centre toward the chaser, whose last entry
is the winch body on the chaser (so ``num_tether_nodes`` = tether_segments).
"""
from __future__ import annotations

import array
import json
import math
from dataclasses import dataclass

import numpy as np

from ..core.config import SimConfig
from ..core.design import Design, DesignError
from ..core.episode import EpisodeResult
from ..core.noise import (NOISE_SOURCES, SPREAD_FIELDS, NoiseError, NoiseModel, NoiseSample,
                          check_orientation_axis, check_scale)
from ..core.scenario import Actions, World
from ..core.sensing import C_NET, C_OMEGA, C_QUAT, C_TGT, C_VEL, N_CHANNELS, SensingConfig
from ..core.tumble import TumbleConfig, TumbleError
from .names import SUCCEEDED
from .state import Setup, StateArrays

#: core design field -> Design.msg field
DESIGN_FIELDS = {"m_c": "corner_mass", "L_n": "net_side", "r_n": "thread_radius",
                 "d_L": "distance_to_target", "V_e": "launch_velocity",
                 "d_c": "closing_displacement"}
#: noise source -> NoiseSettings.msg field
NOISE_FIELDS = {s: f"{s}_scale" for s in NOISE_SOURCES}


class RequestError(ValueError):
    """A request or setup field is invalid; the message names the field (one line)."""

    def __init__(self, field: str, message: str):
        super().__init__(f"{field}: {message}")
        self.field = field


# --- time -------------------------------------------------------------------------------
def split_time(t: float) -> tuple[int, int]:
    """(sec, nanosec) of a non-negative time ``t`` in s."""
    ns = int(round(max(t, 0.0) * 1e9))
    return ns // 1_000_000_000, ns % 1_000_000_000


def set_time(msg_time, t: float):
    """Set a builtin_interfaces/Time to ``t`` s; returns it."""
    msg_time.sec, msg_time.nanosec = split_time(t)
    return msg_time


def time_from_msg(msg_time) -> float:
    """Seconds of a builtin_interfaces/Time."""
    return msg_time.sec + 1e-9 * msg_time.nanosec


# --- design -----------------------------------------------------------------------------
def design_msg(design: Design):
    from tethernet_msgs.msg import Design as DesignMsg

    m = DesignMsg()
    m.corner_mass = float(design.m_c)
    m.net_side = float(design.L_n)
    m.thread_radius = float(design.r_n)
    m.distance_to_target = float(design.d_L)
    m.launch_velocity = [float(v) for v in design.V_e]
    m.closing_displacement = float(design.d_c)
    return m


def design_from_msg(m, prefix: str = "design") -> Design:
    """Core Design of a Design message; RequestError naming ``design.<field>`` if invalid."""
    try:
        ve = [float(v) for v in m.launch_velocity]
        if len(ve) != 3:
            raise RequestError(f"{prefix}.launch_velocity", f"expected 3 values, got {len(ve)}")
        return Design(m_c=float(m.corner_mass), L_n=float(m.net_side), r_n=float(m.thread_radius),
                      d_L=float(m.distance_to_target), V_e=tuple(ve),
                      d_c=float(m.closing_displacement))
    except DesignError as exc:
        core = exc.field.split("[")[0]
        name = DESIGN_FIELDS.get(core, core)
        index = exc.field[len(core):]
        detail = str(exc).split(": ", 1)[1] if ": " in str(exc) else str(exc)
        raise RequestError(f"{prefix}.{name}{index}", f"({exc.field}) {detail}") from None


# --- noise settings ---------------------------------------------------------------------
def noise_settings_msg(model: NoiseModel | None):
    """NoiseSettings of a model's scale factors and axis (None: the nominal spreads,
    every scale 1.0 and axis 'z', which are also the message's defaults)."""
    from tethernet_msgs.msg import NoiseSettings

    model = NoiseModel() if model is None else model
    m = NoiseSettings()
    for source, name in NOISE_FIELDS.items():
        setattr(m, name, float(model.scales[source]))
    m.orientation_axis = model.orientation_axis
    return m


def noise_settings_from_msg(settings, prefix: str = "noise") -> tuple[dict[str, float], str]:
    """(scale factor per noise source, orientation axis) of a NoiseSettings message;
    RequestError names the field if a factor is not in [0, 100] or the axis not z / y."""
    scales = {}
    for source, name in NOISE_FIELDS.items():
        v = float(getattr(settings, name, 1.0))      # (a bag from before the source: 1.0)
        try:
            scales[source] = check_scale(v, "a scale factor")
        except NoiseError as exc:
            raise RequestError(f"{prefix}.{name}", str(exc).split(": ", 1)[1]) from None
    axis = settings.orientation_axis or "z"
    try:
        check_orientation_axis(axis, "the orientation axis")
    except NoiseError as exc:
        raise RequestError(f"{prefix}.orientation_axis", str(exc).split(": ", 1)[1]) from None
    return scales, axis


def noise_model_from_msg(settings, spreads: dict | None = None,
                         prefix: str = "noise") -> NoiseModel:
    """NoiseModel of a NoiseSettings message with the given spreads (NoiseModel field ->
    value; the core's defaults where absent).  RequestError names the field."""
    scales, axis = noise_settings_from_msg(settings, prefix)
    try:
        return NoiseModel(orientation_axis=axis, scales=scales, **(spreads or {}))
    except NoiseError as exc:
        raise RequestError(prefix, str(exc)) from None


# --- tumble -------------------------------------------------------------------------------
def tumble_msg(tumble: TumbleConfig):
    """Tumble message of a TumbleConfig (a vector axis in ``axis_vector``, ``axis`` '')."""
    from tethernet_msgs.msg import Tumble

    m = Tumble()
    m.rate_deg_s = float(tumble.rate_deg_s)
    m.phase_deg = float(tumble.phase_deg)
    if isinstance(tumble.axis, str):
        m.axis = tumble.axis
    else:
        m.axis = ""
        m.axis_vector = [float(c) for c in tumble.axis]
    return m


def tumble_from_msg(m, prefix: str = "tumble") -> TumbleConfig:
    """TumbleConfig of a Tumble message; RequestError names ``tumble.<field>`` and its range."""
    axis = m.axis if m.axis else tuple(float(c) for c in m.axis_vector)
    try:
        return TumbleConfig(rate_deg_s=float(m.rate_deg_s), axis=axis,
                            phase_deg=float(m.phase_deg))
    except TumbleError as exc:
        text = str(exc)
        field = text.split("'")[1] if text.startswith("tumble field '") else "tumble"
        if field == "axis" and not m.axis:
            field = "axis_vector"
        detail = text.split(": ", 1)[1] if ": " in text else text
        if field == "axis":
            detail = detail.replace("or a vector [x, y, z]", "or '' with axis_vector")
        raise RequestError(f"{prefix}.{field}", detail) from None


def config_with_tumble(config: SimConfig, request) -> SimConfig:
    """The episode's SimConfig: ``config`` with the request's tumble where it sets one
    (``set_tumble``) and its target where it names one; RequestError names a bad tumble
    or target field."""
    if getattr(request, "set_tumble", False):
        config = config.replace(tumble=tumble_from_msg(request.tumble))
    target = target_from_request(request)
    return config if target is None else config.replace(target=target)


def target_from_request(request):
    """The TargetConfig a request's ``target`` and ``target_mass`` name (None: the
    configured target); RequestError names the bad field."""
    from ..core.target import TargetConfig, TargetError, target_fields

    name = getattr(request, "target", "") or ""
    mass = float(getattr(request, "target_mass", 0.0) or 0.0)
    if not name:
        if mass != 0.0:
            raise RequestError("target_mass", "given without a target; name the target too")
        return None
    if not (math.isfinite(mass) and mass >= 0.0):
        raise RequestError("target_mass", f"got {mass!r}; must be a mass > 0 kg (0: the "
                           "catalogue's)")
    try:
        return TargetConfig(**target_fields(name), **({"mass": mass} if mass > 0 else {}))
    except TargetError as exc:
        text = str(exc)
        field = "target_mass" if "'mass'" in text else "target"
        raise RequestError(field, text) from None


# --- episode setup ----------------------------------------------------------------------
def config_overrides(config: SimConfig) -> dict:
    """The SimConfig fields that differ from the defaults (field -> value)."""
    base = SimConfig().to_dict()
    return {k: v for k, v in config.to_dict().items() if v != base[k]}


def config_from_json(text: str, field: str = "sim_config_json") -> SimConfig:
    data = json.loads(text) if text and text.strip() else {}
    if not isinstance(data, dict):
        raise ValueError(f"{field}: expected a JSON object of SimConfig fields")
    return SimConfig.from_dict(data)


def setup_msg(episode_id: str, design: Design, seed: int | None, noise: NoiseModel | None,
              config: SimConfig, wall_time: float, nominal: bool | None = None,
              lockstep: bool = False):
    """EpisodeSetup of one episode, stamped with ``wall_time`` (s).  nominal: no noise
    (default: when ``seed`` is None); a nominal setup still carries the request's seed;
    lockstep: the closing policy runs through ROS (docs/ros.md)."""
    from tethernet_msgs.msg import EpisodeSetup

    m = EpisodeSetup()
    set_time(m.header.stamp, wall_time)
    m.header.frame_id = "chaser"
    m.episode_id = episode_id
    m.design = design_msg(design)
    m.nominal = seed is None if nominal is None else bool(nominal)
    m.seed = 0 if seed is None else int(seed)
    m.noise = noise_settings_msg(noise)
    m.sim_config_json = json.dumps(config_overrides(config), sort_keys=True)
    m.lockstep = bool(lockstep)
    return m


def setup_from_msg(m) -> Setup:
    nominal = bool(m.nominal)
    scales, axis = (None, "z") if nominal else noise_settings_from_msg(m.noise)
    return Setup(episode_id=m.episode_id, design=design_from_msg(m.design),
                 seed=None if nominal else int(m.seed), noise_scales=scales,
                 orientation_axis=axis, config=config_from_json(m.sim_config_json),
                 stamp=(int(m.header.stamp.sec), int(m.header.stamp.nanosec)),
                 request_seed=int(m.seed), lockstep=bool(getattr(m, "lockstep", False)))


# --- actuator commands --------------------------------------------------------------------
def noise_sample_msg(sample: NoiseSample | None, model: NoiseModel | None):
    """NoiseSample message of a draw and the model it was drawn with (None, None: nominal;
    the spreads are then the core's defaults, every scale 1.0)."""
    from tethernet_msgs.msg import NoiseSample as NoiseSampleMsg

    m = NoiseSampleMsg()
    m.nominal = sample is None or sample.is_nominal
    model = NoiseModel() if model is None else model
    if sample is not None and not sample.is_nominal:
        m.seed = int(sample.seed)
        for name in ("distance_offset", "orientation_angle", "closing_offset",
                     "spin_rate_offset", "spin_axis_tilt", "spin_axis_azimuth", "spin_phase",
                     "spin_transverse_angle"):
            setattr(m, name, float(getattr(sample, name)))
        for name in ("speed_offsets", "polar_angles", "azimuth_angles"):
            setattr(m, name, [float(v) for v in getattr(sample, name)])
        m.orientation_axis = sample.orientation_axis
    else:
        m.orientation_axis = model.orientation_axis
    for name, value in model.spreads().items():
        setattr(m, name, float(value))
    m.scales = noise_settings_msg(model)
    return m


def noise_sample_from_msg(m) -> tuple[NoiseSample, dict[str, float]]:
    """(the core's NoiseSample, the spreads by NoiseModel field) of a NoiseSample message."""
    if m.nominal:
        sample = NoiseSample.nominal(m.orientation_axis or "z")
    else:
        sample = NoiseSample(
            seed=int(m.seed), distance_offset=float(m.distance_offset),
            orientation_angle=float(m.orientation_angle),
            speed_offsets=tuple(float(v) for v in m.speed_offsets),
            polar_angles=tuple(float(v) for v in m.polar_angles),
            azimuth_angles=tuple(float(v) for v in m.azimuth_angles),
            closing_offset=float(m.closing_offset), orientation_axis=m.orientation_axis or "z",
            spin_rate_offset=float(m.spin_rate_offset), spin_axis_tilt=float(m.spin_axis_tilt),
            spin_axis_azimuth=float(m.spin_axis_azimuth), spin_phase=float(m.spin_phase),
            spin_transverse_angle=float(m.spin_transverse_angle))
    return sample, {k: float(getattr(m, k)) for k in SPREAD_FIELDS}


def launch_command_msg(actions: Actions, world: World, seed: int | None, key: tuple[int, int],
                       frame_id: str = "chaser", sample: NoiseSample | None = None,
                       model: NoiseModel | None = None):
    """LaunchCommand: noisy corner velocities and the target placement and tumble the
    actuator drew, with the draw itself (``sample`` of ``model``; None: nominal).  Its
    header stamp is the EpisodeSetup's stamp (the episode's correlation key)."""
    from tethernet_msgs.msg import LaunchCommand

    m = LaunchCommand()
    m.header.stamp.sec, m.header.stamp.nanosec = key
    m.header.frame_id = frame_id
    m.seed = 0 if seed is None else int(seed)
    m.corner_velocities = array.array("d", np.ascontiguousarray(actions.corner_velocities,
                                                                dtype=float).tobytes())
    m.distance_to_target = float(world.distance)
    m.target_rotation = float(world.rotation)
    m.rotation_axis = world.rotation_axis
    m.spin_rate = float(world.spin_rate)
    m.spin_axis = [float(c) for c in world.spin_axis]
    m.spin_phase = float(world.spin_phase)
    m.noise = noise_sample_msg(sample, model)
    return m


def closing_command_msg(actions: Actions, key: tuple[int, int], frame_id: str = "chaser"):
    """ClosingCommand: the noisy closing displacement (m), stamped like the launch."""
    from tethernet_msgs.msg import ClosingCommand

    m = ClosingCommand()
    m.header.stamp.sec, m.header.stamp.nanosec = key
    m.header.frame_id = frame_id
    m.closing_displacement = float(actions.closing_displacement)
    return m


def commands_from_msgs(launch, closing) -> tuple[Actions, World]:
    """The core's Actions and World of a LaunchCommand and a ClosingCommand."""
    cv = np.array(np.asarray(launch.corner_velocities, dtype=float)).reshape(4, 3)
    actions = Actions(corner_velocities=cv, closing_displacement=float(closing.closing_displacement))
    spin = {}
    rate = float(getattr(launch, "spin_rate", 0.0))       # (a bag from before the tumble: 0)
    if rate != 0.0:
        spin = dict(spin_rate=rate, spin_axis=tuple(float(c) for c in launch.spin_axis),
                    spin_phase=float(launch.spin_phase))
    world = World(distance=float(launch.distance_to_target), rotation=float(launch.target_rotation),
                  rotation_axis=launch.rotation_axis or "z", **spin)
    return actions, world


# --- states -------------------------------------------------------------------------------
def _vec(v) -> np.ndarray:
    return np.array([v.x, v.y, v.z], dtype=float)


def net_state_msg(state: StateArrays, frame_id: str = "chaser"):
    """NetState of a state snapshot (header stamp: sim time)."""
    from tethernet_msgs.msg import NetState

    m = NetState()
    set_time(m.header.stamp, state.sim_time)
    m.header.frame_id = frame_id
    m.sim_time = state.sim_time
    m.step = state.step
    m.positions = array.array("d", np.ascontiguousarray(state.positions).tobytes())
    m.velocities = array.array("d", np.ascontiguousarray(state.velocities).tobytes())
    m.num_net_nodes = state.num_net_nodes
    m.num_corner_masses = state.num_corner_masses
    m.num_tether_nodes = len(state.positions) - state.num_net_nodes - state.num_corner_masses
    p, q = m.target_pose.position, m.target_pose.orientation
    p.x, p.y, p.z = (float(v) for v in state.target_position)
    q.w, q.x, q.y, q.z = (float(v) for v in state.target_quaternion)
    lin, ang = m.target_twist.linear, m.target_twist.angular
    lin.x, lin.y, lin.z = (float(v) for v in state.target_velocity)
    ang.x, ang.y, ang.z = (float(v) for v in state.target_omega)
    m.closing_active = bool(state.closing_active)
    m.closing_start_time = float(state.closing_start_time)
    m.locked = [bool(v) for v in state.locked]
    return m


def net_state_from_msg(m) -> StateArrays:
    pos = np.asarray(m.positions, dtype=float)
    vel = np.asarray(m.velocities, dtype=float)
    q = m.target_pose.orientation
    return StateArrays(
        step=int(m.step), sim_time=float(m.sim_time),
        positions=pos.reshape(-1, 3), velocities=vel.reshape(-1, 3),
        target_position=_vec(m.target_pose.position),
        target_quaternion=np.array([q.w, q.x, q.y, q.z], dtype=float),
        target_velocity=_vec(m.target_twist.linear), target_omega=_vec(m.target_twist.angular),
        closing_active=bool(m.closing_active), closing_start_time=float(m.closing_start_time),
        locked=np.array([bool(v) for v in m.locked], dtype=bool),
        num_net_nodes=int(m.num_net_nodes), num_corner_masses=int(m.num_corner_masses))


def target_pose_msg(state: StateArrays, frame_id: str = "chaser"):
    """PoseStamped of the target's centre of mass (m) and attitude (header stamp: sim time)."""
    from geometry_msgs.msg import PoseStamped

    m = PoseStamped()
    set_time(m.header.stamp, state.sim_time)
    m.header.frame_id = frame_id
    m.pose.position.x, m.pose.position.y, m.pose.position.z = \
        (float(v) for v in state.target_position)
    o = m.pose.orientation
    o.w, o.x, o.y, o.z = (float(v) for v in state.target_quaternion)
    return m


def clock_msg(t: float):
    """rosgraph_msgs/Clock at sim time ``t`` (s)."""
    from rosgraph_msgs.msg import Clock

    m = Clock()
    set_time(m.clock, t)
    return m


# --- the closed loop: measurements and decisions --------------------------------------------
def measurement_msg(values, step: int, sim_time: float, episode_id: str,
                    closing_displacement: float, frame_id: str = "chaser"):
    """Measurement of a core measurement vector (``core.sensing``, N_CHANNELS; None: none
    has reached the controller yet, ``valid`` false), taken at ``step`` (sim time s)."""
    from tethernet_msgs.msg import Measurement

    m = Measurement()
    set_time(m.header.stamp, sim_time)
    m.header.frame_id = frame_id
    m.episode_id = episode_id
    m.step = int(step)
    m.closing_displacement = float(closing_displacement)
    m.valid = values is not None
    if values is None:
        m.target_orientation.w = 0.0
        return m
    v = [float(x) for x in values]
    m.net_point.x, m.net_point.y, m.net_point.z = v[C_NET:C_NET + 3]
    m.target_position.x, m.target_position.y, m.target_position.z = v[C_TGT:C_TGT + 3]
    q = m.target_orientation
    q.w, q.x, q.y, q.z = v[C_QUAT:C_QUAT + 4]
    w = m.target_angular_velocity
    w.x, w.y, w.z = v[C_OMEGA:C_OMEGA + 3]
    u = m.target_velocity
    u.x, u.y, u.z = v[C_VEL:C_VEL + 3]
    return m


def measurement_from_msg(m) -> np.ndarray | None:
    """The core's measurement vector (N_CHANNELS,) of a Measurement (None if not valid);
    the same bits as were sent."""
    if not m.valid:
        return None
    out = np.empty(N_CHANNELS)
    p, t, q = m.net_point, m.target_position, m.target_orientation
    w, u = m.target_angular_velocity, m.target_velocity
    out[C_NET:C_NET + 3] = (p.x, p.y, p.z)
    out[C_TGT:C_TGT + 3] = (t.x, t.y, t.z)
    out[C_QUAT:C_QUAT + 4] = (q.w, q.x, q.y, q.z)
    out[C_OMEGA:C_OMEGA + 3] = (w.x, w.y, w.z)
    out[C_VEL:C_VEL + 3] = (u.x, u.y, u.z)
    return out


def decision_msg(measurement, close: bool, controller: str):
    """ClosingDecision answering a Measurement (same stamp, episode and step)."""
    from tethernet_msgs.msg import ClosingDecision

    m = ClosingDecision()
    m.header = measurement.header
    m.episode_id = measurement.episode_id
    m.step = measurement.step
    m.close = bool(close)
    m.controller = controller
    return m


def _diagonal(variances: list[float]) -> list[float]:
    n = len(variances)
    out = [0.0] * (n * n)
    for i, v in enumerate(variances):
        out[i * n + i] = float(v)
    return out


def sensed_msgs(values, sim_time: float, sensing: SensingConfig, frame_id: str = "chaser"):
    """(PoseWithCovarianceStamped of the target, TwistWithCovarianceStamped of the target,
    PointStamped of the net's reference point) of a sensed measurement vector.  The
    covariances are the sensor's noise (``sensing.sigma_*``): position sigma_position^2
    per axis (0 for a 'planned' target position, which is no measurement), attitude
    sigma_attitude^2 (rad^2) per axis of the small rotation, velocity sigma_velocity^2 and
    angular velocity sigma_rate^2 ((rad/s)^2) per axis; no correlations."""
    from geometry_msgs.msg import PointStamped, PoseWithCovarianceStamped, \
        TwistWithCovarianceStamped

    deg = math.pi / 180.0
    v = [float(x) for x in values]
    pose = PoseWithCovarianceStamped()
    twist = TwistWithCovarianceStamped()
    point = PointStamped()
    for m in (pose, twist, point):
        set_time(m.header.stamp, sim_time)
        m.header.frame_id = frame_id
    p, q = pose.pose.pose.position, pose.pose.pose.orientation
    p.x, p.y, p.z = v[C_TGT:C_TGT + 3]
    q.w, q.x, q.y, q.z = v[C_QUAT:C_QUAT + 4]
    sp = sensing.sigma_position ** 2 if sensing.target_position == "sensed" else 0.0
    sa = (sensing.sigma_attitude_deg * deg) ** 2
    pose.pose.covariance = _diagonal([sp, sp, sp, sa, sa, sa])
    lin, ang = twist.twist.twist.linear, twist.twist.twist.angular
    lin.x, lin.y, lin.z = v[C_VEL:C_VEL + 3]
    ang.x, ang.y, ang.z = v[C_OMEGA:C_OMEGA + 3]
    sv, sr = sensing.sigma_velocity ** 2, (sensing.sigma_rate_deg_s * deg) ** 2
    twist.twist.covariance = _diagonal([sv, sv, sv, sr, sr, sr])
    point.point.x, point.point.y, point.point.z = v[C_NET:C_NET + 3]
    return pose, twist, point


# --- metrics and results ------------------------------------------------------------------
#: CaptureMetrics fields that are the core's CQITerms
TERM_FIELDS = ("cqi", "volume_term", "area_term", "distance_term", "hull_volume", "hull_area",
               "com_distance")


def metrics_msg(terms, sim_time: float, locked_pairs: int, closing_active: bool,
                frame_id: str = "chaser"):
    """CaptureMetrics of core CQITerms (None: state not finite -> NaN terms)."""
    from tethernet_msgs.msg import CaptureMetrics

    m = CaptureMetrics()
    set_time(m.header.stamp, sim_time)
    m.header.frame_id = frame_id
    m.sim_time = float(sim_time)
    for name in TERM_FIELDS:
        setattr(m, name, getattr(terms, name) if terms else math.nan)
    m.locked_pairs = int(locked_pairs)
    m.closing_active = bool(closing_active)
    return m


def metrics_from_cdr(data: bytes):
    """The CaptureMetrics message of its serialized (CDR) bytes."""
    from rclpy.serialization import deserialize_message
    from tethernet_msgs.msg import CaptureMetrics

    return deserialize_message(data, CaptureMetrics)


def terms_from_msg(m) -> dict[str, float]:
    """The CQI terms of a CaptureMetrics message, by name."""
    return {name: getattr(m, name) for name in TERM_FIELDS}


def episode_result_msg(result: EpisodeResult, episode_id: str, nominal: bool,
                       sim_time: float = 0.0, seed: int | None = None):
    """EpisodeResult message of a core result, stamped with ``sim_time`` (s).  seed: the
    seed to report (the request's, also when nominal); default the result's (0 if None)."""
    from tethernet_msgs.msg import EpisodeResult as ResultMsg

    m = ResultMsg()
    set_time(m.header.stamp, sim_time)
    m.header.frame_id = "chaser"
    m.episode_id = episode_id
    if seed is None:
        seed = 0 if result.seed is None else result.seed
    m.seed = int(seed)
    m.nominal = bool(nominal)
    m.success = bool(result.success)
    m.settled_cqi = float(result.settled_cqi)
    m.locked_pairs = int(result.locked_pairs)
    ct = result.closing_time
    m.closing_time = -1.0 if ct is None or not math.isfinite(ct) else float(ct)
    m.completion_time = float(result.completion_time)
    m.mass = float(result.mass)
    m.failure_reason = result.failure_reason
    m.wall_time = float(result.wall_time)
    steps = getattr(result, "steps", -1)
    m.steps = -1 if steps is None else int(steps)
    pen = getattr(result, "max_penetration", math.nan)
    m.max_penetration = math.nan if pen is None else float(pen)
    return m


def episode_result_from_msg(m) -> EpisodeResult:
    """Core EpisodeResult of a message (a message recorded before it carried ``steps``
    and ``max_penetration``: -1 and NaN)."""
    return EpisodeResult(
        success=bool(m.success), settled_cqi=float(m.settled_cqi), locked_pairs=int(m.locked_pairs),
        closing_time=float(m.closing_time) if m.closing_time >= 0 else math.nan,
        completion_time=float(m.completion_time), mass=float(m.mass),
        failure_reason=m.failure_reason, wall_time=float(m.wall_time),
        seed=None if m.nominal else int(m.seed), steps=int(getattr(m, "steps", -1)),
        max_penetration=float(getattr(m, "max_penetration", math.nan)))


# --- the RunCapture service and the Capture action ------------------------------------------
@dataclass
class Outcome:
    """How one RunCapture request or Capture goal ended.  status: names.SUCCEEDED,
    REJECTED, ABORTED or CANCELED; error: '' when SUCCEEDED, else why (one line);
    result: the EpisodeResult message (SUCCEEDED only); bag_path: '' if none."""

    status: int
    error: str = ""
    result: object = None
    bag_path: str = ""


def capture_reply(reply, outcome: Outcome):
    """Fill a RunCapture.Response or Capture.Result (the same fields) from an Outcome;
    the result stays all zero unless SUCCEEDED.  Returns ``reply``."""
    reply.status = int(outcome.status)
    reply.error = outcome.error
    reply.bag_path = outcome.bag_path
    if outcome.status == SUCCEEDED and outcome.result is not None:
        reply.result = outcome.result
    return reply


def capture_feedback_msg(metrics, states: int, wall_time: float):
    """Capture.Feedback of the latest CaptureMetrics message (None: none yet), the states
    heard so far and the wall time since the goal started (s)."""
    from tethernet_msgs.action import Capture

    fb = Capture.Feedback()
    fb.states = int(states)
    fb.wall_time = float(wall_time)
    if metrics is not None:
        fb.sim_time = float(metrics.sim_time)
        fb.cqi = float(metrics.cqi)
        fb.locked_pairs = int(metrics.locked_pairs)
        fb.closing_active = bool(metrics.closing_active)
    else:
        fb.cqi = math.nan
    return fb


def cancel_msg(episode_id: str):
    """The cancel topic's message (std_msgs/String): the id of the episode to stop."""
    from std_msgs.msg import String

    return String(data=episode_id)
