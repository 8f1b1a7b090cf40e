"""Conversions between tethernet_msgs / common_interfaces messages and the core's objects.

Readers (``*_from_msg``) use attribute access only, so they accept rclpy messages as well
as messages decoded from a bag by mcap-ros2-support or rosbags.  Builders (``*_msg``)
import the rclpy message classes lazily.

Units: SI.  Quaternions are (w, x, y, z) in the core and (x, y, z, w) in geometry_msgs.
NetState body order: the core's body layout (core/scenario.py): 289 net nodes (row-major),
4 corner masses, then the main tether's lumped masses from the net centre toward the
chaser, whose last entry is the winch body on the chaser (so ``num_tether_nodes`` =
tether_segments).
"""
from __future__ import annotations

import array
import math
from dataclasses import dataclass

import numpy as np

from ..core.config import SimConfig
from ..core.design import Design, DesignError
from ..core.episode import EpisodeResult
from ..core.noise import NOISE_SOURCES, NoiseError, NoiseModel
from ..core.scenario import Actions, World

#: core design field -> Design.msg field
DESIGN_FIELDS = {"m_c": "corner_mass", "L_n": "net_side", "r_n": "thread_radius",
                 "d_L": "distance_to_target", "V_e": "launch_velocity",
                 "d_c": "closing_displacement"}
#: noise source -> NoiseSettings.msg field
NOISE_FIELDS = {s: f"{s}_scale" for s in NOISE_SOURCES}


class RequestError(ValueError):
    """A RunCapture request field is invalid; the message names the field (one line)."""

    def __init__(self, field: str, message: str):
        super().__init__(f"{field}: {message}")
        self.field = field


# --- time -----------------------------------------------------------------------------
def split_time(t: float) -> tuple[int, int]:
    """(sec, nanosec) of a non-negative time in s."""
    ns = int(round(max(t, 0.0) * 1e9))
    return ns // 1_000_000_000, ns % 1_000_000_000


def stamp(msg_time, t: float):
    """Set a builtin_interfaces/Time to ``t`` seconds; returns it."""
    msg_time.sec, msg_time.nanosec = split_time(t)
    return msg_time


def stamp_seconds(msg_time) -> float:
    return msg_time.sec + 1e-9 * msg_time.nanosec


# --- design and noise -------------------------------------------------------------------
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


def noise_settings_msg(model: NoiseModel | None):
    """NoiseSettings of a model's scale factors and axis (all 1.0 / 'z' for None)."""
    from tethernet_msgs.msg import NoiseSettings

    m = NoiseSettings()
    scales = model.scales if model is not None else {s: 1.0 for s in NOISE_SOURCES}
    for source, name in NOISE_FIELDS.items():
        setattr(m, name, float(scales[source]))
    m.orientation_axis = model.orientation_axis if model is not None else "z"
    return m


def noise_model_from_msg(settings, spreads: dict | None = None, prefix: str = "noise") -> NoiseModel:
    """NoiseModel with the message's scale factors and axis and the given spreads
    (NoiseModel field -> value; SPEC defaults where absent).  RequestError names the field."""
    scales = {}
    for source, name in NOISE_FIELDS.items():
        v = float(getattr(settings, name))
        if not math.isfinite(v) or not 0.0 <= v <= 100.0:
            raise RequestError(f"{prefix}.{name}", f"got {v}; must be a finite factor in [0, 100]")
        scales[source] = v
    axis = settings.orientation_axis or "z"
    if axis not in ("z", "y"):
        raise RequestError(f"{prefix}.orientation_axis", f"got {axis!r}; must be 'z' or 'y'")
    try:
        return NoiseModel(orientation_axis=axis, scales=scales, **(spreads or {}))
    except NoiseError as exc:
        raise RequestError(f"{prefix}", str(exc)) from None


def config_json(config: SimConfig) -> str:
    """JSON of the SimConfig fields that differ from the SPEC defaults."""
    import json

    base = SimConfig().to_dict()
    d = config.to_dict()
    return json.dumps({k: v for k, v in d.items() if v != base[k]}, sort_keys=True)


def config_from_json(text: str) -> SimConfig:
    import json

    data = json.loads(text) if text and text.strip() else {}
    if not isinstance(data, dict):
        raise ValueError("sim_config_json: expected a JSON object of SimConfig fields")
    return SimConfig.from_dict(data)


def setup_msg(episode_id: str, design: Design, seed: int | None, noise: NoiseModel | None,
              config: SimConfig, wall_time: float):
    from tethernet_msgs.msg import EpisodeSetup

    m = EpisodeSetup()
    stamp(m.header.stamp, wall_time)
    m.header.frame_id = "chaser"
    m.episode_id = episode_id
    m.design = design_msg(design)
    m.nominal = seed is None
    m.seed = 0 if seed is None else int(seed)
    m.noise = noise_settings_msg(noise)
    m.sim_config_json = config_json(config)
    return m


@dataclass(frozen=True)
class Setup:
    """An EpisodeSetup in core terms."""

    episode_id: str
    design: Design
    seed: int | None
    noise_settings: object
    config: SimConfig
    stamp: tuple[int, int]

    def noise_model(self, spreads: dict | None = None) -> NoiseModel | None:
        return None if self.seed is None else noise_model_from_msg(self.noise_settings, spreads)


def setup_from_msg(m) -> Setup:
    return Setup(episode_id=m.episode_id, design=design_from_msg(m.design),
                 seed=None if m.nominal else int(m.seed), noise_settings=m.noise,
                 config=config_from_json(m.sim_config_json),
                 stamp=(int(m.header.stamp.sec), int(m.header.stamp.nanosec)))


class CommandBuffer:
    """The latest launch and closing commands per episode stamp (a few episodes kept):
    a command may arrive before the EpisodeSetup it answers (different writers)."""

    def __init__(self, keep: int = 8):
        self.keep = keep
        self._by_stamp: dict[tuple[int, int], dict] = {}

    def put(self, header, kind: str, msg) -> None:
        key = (int(header.stamp.sec), int(header.stamp.nanosec))
        self._by_stamp.setdefault(key, {})[kind] = msg
        while len(self._by_stamp) > self.keep:
            self._by_stamp.pop(next(iter(self._by_stamp)))

    def get(self, key: tuple[int, int]):
        d = self._by_stamp.get(tuple(key), {})
        return d.get("launch"), d.get("closing")


def same_stamp(header, key: tuple[int, int]) -> bool:
    return (int(header.stamp.sec), int(header.stamp.nanosec)) == tuple(key)


# --- actuator commands ------------------------------------------------------------------
def launch_command_msg(actions: Actions, world: World, seed: int | None, key: tuple[int, int],
                       frame_id: str = "chaser"):
    """LaunchCommand: noisy corner velocities and the target placement the actuator drew.
    Its header stamp is the EpisodeSetup's stamp (the episode's correlation key)."""
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
    return m


def closing_command_msg(actions: Actions, key: tuple[int, int], frame_id: str = "chaser"):
    from tethernet_msgs.msg import ClosingCommand

    m = ClosingCommand()
    m.header.stamp.sec, m.header.stamp.nanosec = key
    m.header.frame_id = frame_id
    m.closing_displacement = float(actions.closing_displacement)
    return m


def actions_world_from_msgs(launch, closing) -> tuple[Actions, World]:
    cv = np.array(np.asarray(launch.corner_velocities, dtype=float)).reshape(4, 3)
    actions = Actions(corner_velocities=cv, closing_displacement=float(closing.closing_displacement))
    world = World(distance=float(launch.distance_to_target), rotation=float(launch.target_rotation),
                  rotation_axis=launch.rotation_axis or "z")
    return actions, world


# --- states -----------------------------------------------------------------------------
@dataclass
class StateArrays:
    """One NetState as arrays (SI; quaternion w, x, y, z); also the snapshot of a running
    simulation that the sim node hands to its publishing thread."""

    step: int
    sim_time: float
    positions: np.ndarray       # (N, 3)
    velocities: np.ndarray      # (N, 3)
    target_position: np.ndarray
    target_quaternion: np.ndarray
    target_velocity: np.ndarray
    target_omega: np.ndarray
    closing_active: bool
    closing_start_time: float
    locked: np.ndarray          # (12,) bool
    num_net_nodes: int = 0
    num_corner_masses: int = 0


def state_arrays(sim) -> StateArrays:
    """Snapshot (copies) of a CaptureSimulation's current state."""
    s = sim.s
    b, t = s.bodies, s.target_body
    ct = sim.closing_time
    return StateArrays(
        step=sim.step, sim_time=sim.time,
        positions=np.array(b.x, dtype=float), velocities=np.array(b.v, dtype=float),
        target_position=np.array(t.pos, dtype=float),
        target_quaternion=np.array(t.quat, dtype=float),
        target_velocity=np.array(t.vel, dtype=float),
        target_omega=np.array(t.omega, dtype=float),
        closing_active=sim.closing_active,
        closing_start_time=-1.0 if ct is None else float(ct),
        locked=np.array(s.drawstring.locked, dtype=bool),
        num_net_nodes=len(s.net_nodes), num_corner_masses=len(s.corner_bodies))


def _vec(v) -> np.ndarray:
    return np.array([v.x, v.y, v.z], dtype=float)


def net_state_msg(state: StateArrays, frame_id: str = "chaser"):
    """NetState of a state snapshot (:func:`state_arrays`; header stamp: sim time)."""
    from tethernet_msgs.msg import NetState

    m = NetState()
    stamp(m.header.stamp, state.sim_time)
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


def state_from_msg(m) -> StateArrays:
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
    from geometry_msgs.msg import PoseStamped

    m = PoseStamped()
    stamp(m.header.stamp, state.sim_time)
    m.header.frame_id = frame_id
    m.pose.position.x, m.pose.position.y, m.pose.position.z = \
        (float(v) for v in state.target_position)
    o = m.pose.orientation
    o.w, o.x, o.y, o.z = (float(v) for v in state.target_quaternion)
    return m


def clock_msg(t: float):
    from rosgraph_msgs.msg import Clock

    m = Clock()
    stamp(m.clock, t)
    return m


# --- metrics and results ----------------------------------------------------------------
def metrics_msg(terms, sim_time: float, locked_pairs: int, closing_active: bool,
                frame_id: str = "chaser"):
    """CaptureMetrics of core CQITerms (None: state not finite -> NaN terms)."""
    from tethernet_msgs.msg import CaptureMetrics

    m = CaptureMetrics()
    stamp(m.header.stamp, sim_time)
    m.header.frame_id = frame_id
    m.sim_time = float(sim_time)
    nan = math.nan
    m.cqi = terms.cqi if terms else nan
    m.volume_term = terms.volume_term if terms else nan
    m.area_term = terms.area_term if terms else nan
    m.distance_term = terms.distance_term if terms else nan
    m.hull_volume = terms.hull_volume if terms else nan
    m.hull_area = terms.hull_area if terms else nan
    m.com_distance = terms.com_distance if terms else nan
    m.locked_pairs = int(locked_pairs)
    m.closing_active = bool(closing_active)
    return m


def episode_result_msg(result: EpisodeResult, episode_id: str, nominal: bool, sim_time: float = 0.0):
    from tethernet_msgs.msg import EpisodeResult as ResultMsg

    m = ResultMsg()
    stamp(m.header.stamp, sim_time)
    m.header.frame_id = "chaser"
    m.episode_id = episode_id
    m.seed = 0 if result.seed is None else int(result.seed)
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
    return m


def episode_result_from_msg(m) -> EpisodeResult:
    """Core EpisodeResult of a message.  ``steps`` (-1) and ``max_penetration`` (NaN) are
    not carried by the message."""
    return EpisodeResult(
        success=bool(m.success), settled_cqi=float(m.settled_cqi), locked_pairs=int(m.locked_pairs),
        closing_time=float(m.closing_time) if m.closing_time >= 0 else math.nan,
        completion_time=float(m.completion_time), mass=float(m.mass),
        failure_reason=m.failure_reason, wall_time=float(m.wall_time),
        seed=None if m.nominal else int(m.seed), steps=-1, max_penetration=math.nan)


def compare_results(a, b) -> str:
    """'' if two results (core or message; closing_time NaN and -1 both mean 'never')
    agree exactly on success, settled CQI, n_L, closing time, T and failure reason; else
    a one-line description of the first difference."""
    def ct(r):
        v = r.closing_time
        return math.nan if v is None or (isinstance(v, float) and not math.isnan(v) and v < 0) else v
    for name, va, vb in (("success", a.success, b.success),
                         ("settled_cqi", a.settled_cqi, b.settled_cqi),
                         ("locked_pairs", a.locked_pairs, b.locked_pairs),
                         ("closing_time", ct(a), ct(b)),
                         ("completion_time", a.completion_time, b.completion_time),
                         ("failure_reason", a.failure_reason, b.failure_reason)):
        if isinstance(va, float) or isinstance(vb, float):
            fa, fb = float(va), float(vb)
            if (math.isnan(fa) and math.isnan(fb)) or fa == fb:
                continue
        elif va == vb:
            continue
        return f"{name} differs: {va!r} vs {vb!r}"
    return ""


# --- markers ----------------------------------------------------------------------------
class MarkerBuilder:
    """visualization_msgs/MarkerArray of a scenario, in frame ``frame_id``:

    net_rows, net_columns   LINE_STRIPs snaking through the grid by rows and by columns:
                            together every grid thread (edge threads twice), 2 x 289 points
    corner_threads          LINE_LIST, net corner -> corner mass
    closing_ring            LINE_LIST of the 12 drawstring pairs, green when locked
    corner_masses           SPHERE_LIST
    main_tether             LINE_STRIP, net centre -> winch
    target                  CYLINDER (the stage's long axis is its body x)
    chaser                  CUBE behind the launch point

    Topology is taken once from the Scenario; positions on every call."""

    def __init__(self, scenario, frame_id: str = "chaser"):
        s = scenario
        self.frame_id = frame_id
        n = s.grid.n
        grid = np.arange(n * n).reshape(n, n)          # node (i, j) = n i + j
        rows = [grid[i] if i % 2 == 0 else grid[i, ::-1] for i in range(n)]
        cols = [grid[:, j] if j % 2 == 0 else grid[::-1, j] for j in range(n)]
        self.row_snake = np.concatenate(rows)
        self.col_snake = np.concatenate(cols)
        net = set(int(i) for i in s.net_nodes)
        corners = set(int(i) for i in s.corner_bodies)
        self.corner_threads = np.array([(a, b) for a, b in s.links.pairs.tolist()
                                        if (a in net and b in corners) or (b in net and a in corners)],
                                       dtype=np.int64).reshape(-1, 2)
        self.tether_chain = np.array([s.tether.centre, *s.tether.nodes, s.tether.winch])
        self.ring_pairs = s.drawstring.pairs
        self.corners = s.corner_bodies
        self.winch = s.tether.winch
        tc = s.config.target
        self.target_scale = (tc.diameter, tc.diameter, tc.length)
        self.chaser_side = s.config.chaser_side

    @staticmethod
    def _points(xyz):
        from geometry_msgs.msg import Point

        return [Point(x=a, y=b, z=c) for a, b, c in xyz.tolist()]

    def build(self, state: StateArrays):
        """MarkerArray of a state snapshot (:func:`state_arrays`)."""
        from std_msgs.msg import ColorRGBA
        from visualization_msgs.msg import Marker, MarkerArray

        x = state.positions
        out = MarkerArray()

        def marker(ns, mid, mtype, rgba, scale):
            mk = Marker()
            stamp(mk.header.stamp, state.sim_time)
            mk.header.frame_id = self.frame_id
            mk.ns, mk.id, mk.type, mk.action = ns, mid, mtype, Marker.ADD
            mk.pose.orientation.w = 1.0
            mk.scale.x, mk.scale.y, mk.scale.z = scale
            mk.color = ColorRGBA(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3])
            out.markers.append(mk)
            return mk

        yellow = (0.9, 0.9, 0.2, 1.0)
        marker("net_rows", 0, Marker.LINE_STRIP, yellow, (0.03, 0.0, 0.0)).points = \
            self._points(x[self.row_snake])
        marker("net_columns", 1, Marker.LINE_STRIP, yellow, (0.03, 0.0, 0.0)).points = \
            self._points(x[self.col_snake])
        marker("corner_threads", 2, Marker.LINE_LIST, yellow, (0.03, 0.0, 0.0)).points = \
            self._points(x[self.corner_threads].reshape(-1, 3))
        mk = marker("closing_ring", 3, Marker.LINE_LIST, (1.0, 0.2, 0.2, 1.0), (0.08, 0.0, 0.0))
        mk.points = self._points(x[self.ring_pairs].reshape(-1, 3))
        green, red = ColorRGBA(r=0.1, g=0.9, b=0.1, a=1.0), ColorRGBA(r=1.0, g=0.2, b=0.2, a=1.0)
        mk.colors = [green if lk else red for lk in state.locked for _ in (0, 1)]
        marker("corner_masses", 4, Marker.SPHERE_LIST, (0.2, 0.4, 1.0, 1.0), (0.3, 0.3, 0.3)).points = \
            self._points(x[self.corners])
        marker("main_tether", 5, Marker.LINE_STRIP, (0.8, 0.8, 0.8, 1.0), (0.03, 0.0, 0.0)).points = \
            self._points(x[self.tether_chain])
        mk = marker("target", 6, Marker.CYLINDER, (0.6, 0.6, 0.65, 0.8), self.target_scale)
        p, o = mk.pose.position, mk.pose.orientation
        p.x, p.y, p.z = (float(v) for v in state.target_position)
        # the cylinder marker's axis is its local z; the stage's long axis is body x
        o.w, o.x, o.y, o.z = _quat_mul(state.target_quaternion, (math.sqrt(0.5), 0.0, math.sqrt(0.5), 0.0))
        mk = marker("chaser", 7, Marker.CUBE, (0.3, 0.3, 0.3, 1.0), (self.chaser_side,) * 3)
        # the winch sits at the launch point on the cube's +z face
        cx, cy, cz = (float(v) for v in x[self.winch])
        mk.pose.position.x, mk.pose.position.y, mk.pose.position.z = cx, cy, cz - self.chaser_side / 2
        return out


def _quat_mul(a, b) -> tuple[float, float, float, float]:
    aw, ax, ay, az = (float(v) for v in a)
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)
