"""The nodes' ROS parameters: default, description and allowed values of each (the one
home of every parameter's range), declaring them with descriptors, and refusing bad values.

config/tethernet.yaml mirrors the defaults (tests/test_ros_bags.py checks that they
agree).  Rates are in Hz of *simulated* time; timeouts in wall-clock seconds; SI units.
The actuator's noise spreads default to the core's NoiseModel (docs/noise.md §1), and the
ranges of ``settle_time`` and ``horizon`` are the core's (``core/config.py``): a value the
core would refuse is refused here too, with the same words.

Every parameter is declared with a ParameterDescriptor: its description, its range
(FloatingPointRange / IntegerRange for numbers) and, in ``additional_constraints``, the
rule in words.  Parameters that a node reads only when it starts (topic and service
names, queue depths, frame ids, the recorded topics) are read-only: ``ros2 param set``
refuses them instead of doing nothing.  A value outside its range is refused by rclpy
(which checks the descriptor's range first); every other rule by the node's
set-parameters callback, whose reason reads ``<name>: got X; must be ...``.  A bad value
in a parameter file stops the node at start with that line.
"""
from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass
from collections.abc import Callable

from ..core.config import _LIMITS as CONFIG_LIMITS
from ..core.config import ConfigError, SimConfig
from ..core.kernel.policy_table import KERNEL, policies
from ..core.noise import SPREAD_FIELDS, NoiseError, NoiseModel
from .names import ACTION, SERVICE, TOPIC_TYPES, TOPICS

FLOAT_MAX = sys.float_info.max


@dataclass(frozen=True)
class Param:
    """One parameter: ``default`` (its type is the parameter's type), ``description``,
    and its rule: ``low``/``high`` (inclusive range of a number), ``must`` (the rule in
    words, completing "must be ..."), ``check`` (value -> '' or what is wrong, for rules
    a range cannot say); ``read_only``: read once, at start-up."""

    default: object
    description: str
    low: float | int | None = None
    high: float | int | None = None
    must: str = ""
    check: Callable[[object], str] | None = None
    read_only: bool = False

    def problem(self, value) -> str:
        """'' if ``value`` is allowed, else what is wrong ("got X; must be ...")."""
        if self.low is not None and not (isinstance(value, (int, float))
                                         and math.isfinite(value)
                                         and self.low <= value <= self.high):
            return f"got {value!r}; must be {self.must}"
        if self.check is not None:
            return self.check(value)
        return ""


def number(default, description: str, low, high, unit: str = "", note: str = "",
           read_only: bool = False) -> Param:
    """A number in [low, high] (``unit`` after the range, ``note`` after that)."""
    text = f"{'an integer' if isinstance(default, int) else 'a number'} in [{low:g}, {high:g}]"
    text += f" {unit}" if unit else ""
    text += f" ({note})" if note else ""
    return Param(default, description, low, high, text, read_only=read_only)


def from_config(name: str, description: str) -> Param:
    """A SimConfig field's parameter: the core's range and words (core/config.py)."""
    low, high, what = CONFIG_LIMITS[name]
    return Param(float(getattr(SimConfig(), name)), description, float(low), float(high), what)


def _spread_problem(field: str) -> Callable[[object], str]:
    def check(value) -> str:
        try:
            NoiseModel(**{field: value})
        except NoiseError as exc:
            return str(exc).split(": ", 1)[-1]       # "got X; must be ..."
        return ""
    return check


def spread(field: str, description: str) -> Param:
    """A noise spread: the core's rule (NoiseModel: a finite number >= 0)."""
    return Param(float(getattr(NoiseModel(), field)), description, 0.0, FLOAT_MAX,
                 "a finite number >= 0", check=_spread_problem(field))


def _nonempty(value) -> str:
    return "" if isinstance(value, str) and value.strip() else \
        f"got {value!r}; must be a non-empty string"


def _ros_name(value) -> str:
    from rclpy.validate_topic_name import validate_topic_name

    try:
        validate_topic_name(value)
    except Exception as exc:  # noqa: BLE001 - InvalidTopicNameException and the like
        return f"got {value!r}; must be a valid ROS name ({str(exc).splitlines()[0]})"
    return ""


def _one_of(allowed) -> Callable[[object], str]:
    def check(value) -> str:
        return "" if value in allowed else \
            f"got {value!r}; must be one of {', '.join(repr(a) for a in allowed)}"
    return check


def _topic_keys(value) -> str:
    unknown = [k for k in value if k not in TOPIC_TYPES]
    return f"got unknown {unknown}; must be topic keys of {list(TOPIC_TYPES)}" if unknown else ""


def _json_object(value) -> str:
    try:
        data = json.loads(value or "{}")
    except ValueError:
        data = None
    return "" if isinstance(data, dict) else \
        f"got {value!r}; must be a JSON object of SimConfig fields"


def text(default: str, description: str, check=_nonempty, must: str = "a non-empty string",
         read_only: bool = False) -> Param:
    return Param(default, description, must=must, check=check, read_only=read_only)


FRAME = text("chaser", "frame id of the messages' headers", read_only=True)


def _shared() -> dict[str, Param]:
    """Parameters of every node: the topic names."""
    return {f"topics.{k}": text(v, f"topic {k} ({TOPIC_TYPES[k]})", _ros_name,
                                "a valid ROS topic name", read_only=True)
            for k, v in TOPICS.items()}


def _capture_topics() -> list[str]:
    """The topics recorded by default: all but /clock and the target pose (the states
    carry both); the loop's topics of lockstep episodes (names.ALWAYS_RECORDED adds the
    measurements and decisions) and the sensed state in standard messages among them."""
    return ["setup", "launch_command", "closing_command", "net_state", "markers", "metrics",
            "result", "verdict", "sensed_target_pose", "sensed_target_twist",
            "sensed_net_point"]


#: every node's parameters (nested names use '.')
PARAMETERS: dict[str, dict[str, Param]] = {
    "sim_node": {
        "publish_rate": number(10.0, "rate of NetState, target pose and /clock (Hz of sim "
                               "time); read at each episode", 0.01, 1000.0, "Hz"),
        "marker_rate": number(2.0, "rate of the MarkerArray for Foxglove / RViz (Hz of sim "
                              "time; 0: none); read at each episode", 0.0, 1000.0, "Hz",
                              "0: no markers"),
        "real_time_factor": number(0.0, "> 0: pace each episode at this multiple of real "
                                   "time; 0: as fast as it runs", 0.0, 1000.0,
                                   note="0: as fast as possible"),
        "frame_id": FRAME,
        "queue_depth": number(1000, "reliable keep-last depth of the state topics", 1, 100000,
                              read_only=True),
        "min_state_subscribers": number(2, "state subscribers (monitor + recorder) to wait "
                                        "for before the first step", 0, 100),
        "min_truth_subscribers": number(2, "lockstep episodes: true-measurement subscribers "
                                        "(sensor + recorder) to wait for before the first "
                                        "step", 0, 100),
        "match_timeout": number(5.0, "wait at most this long for those subscribers (s, "
                                "wall)", 0.0, 3600.0, "s"),
        "decision_timeout": number(5.0, "lockstep episodes: wait at most this long for the "
                                   "controller's ClosingDecision of a control step (s, wall; "
                                   "the first decision of an episode: match_timeout more); "
                                   "then the episode ends, failed (keep the sum below the "
                                   "capture node's stall_timeout)", 0.01, 3600.0, "s"),
        "warm_up": Param(True, "load the numba kernels at start-up, not in the first episode",
                         read_only=True),
    },
    "monitor_node": {
        "queue_depth": number(1000, "reliable keep-last depth of the state topics", 1, 100000,
                              read_only=True),
        "frame_id": FRAME,
    },
    "actuator_node": {
        "noise.sigma_distance": spread("sigma_distance", "D_rnd: standard deviation of the "
                                       "distance to the target (m); each request scales it"),
        "noise.sigma_orientation_deg": spread("sigma_orientation_deg", "alpha_rnd: standard "
                                              "deviation of the target orientation (deg)"),
        "noise.sigma_speed": spread("sigma_speed", "v_rnd: standard deviation of each corner "
                                    "mass's launch speed (m/s)"),
        "noise.sigma_polar_deg": spread("sigma_polar_deg", "theta_rnd: standard deviation of "
                                        "each launch direction's polar tilt (deg)"),
        "noise.azimuth_range_deg": spread("azimuth_range_deg", "phi_rnd ~ U(0, range): the "
                                          "launch tilt's azimuth (deg)"),
        "noise.sigma_closing": spread("sigma_closing", "d_rnd: standard deviation of the "
                                      "closing displacement (m)"),
        "noise.sigma_spin_rate": spread("sigma_spin_rate", "standard deviation of the "
                                        "target's spin rate, relative to it (-)"),
        "noise.sigma_spin_axis_deg": spread("sigma_spin_axis_deg", "standard deviation of the "
                                            "tilt of the target's spin axis (deg)"),
        "noise.spin_phase_range_deg": spread("spin_phase_range_deg", "the initial spin "
                                             "phase's range: U(0, range) (deg)"),
        "noise.sigma_target_mass": spread("sigma_target_mass", "standard deviation of the "
                                          "target's mass, relative to it (-; 0: known)"),
        "noise.sigma_target_inertia": spread("sigma_target_inertia", "standard deviation of "
                                             "each principal moment of the target, relative "
                                             "(-; 0: known)"),
        "noise.sigma_target_com": spread("sigma_target_com", "standard deviation of the "
                                         "target's centre of mass along each body axis (m; "
                                         "0: known)"),
        "builtin_policy": Param(True, "answer lockstep episodes' measurements with the "
                                "policies of the episode's configuration (closing: "
                                f"{' or '.join(policies('closing', KERNEL))}; launch: "
                                f"{' or '.join(policies('launch', KERNEL))}); false: leave "
                                "the decisions to another node (a user's controller, "
                                "docs/ros.md)", read_only=True),
        "min_command_subscribers": number(3, "command subscribers (sim + monitor + recorder) "
                                          "to wait for before sending (and every other one "
                                          "the graph shows)", 0, 100),
        "match_timeout": number(5.0, "wait at most this long for those subscribers (s, "
                                "wall)", 0.0, 3600.0, "s"),
        "frame_id": FRAME,
    },
    "sensor_node": {
        "queue_depth": number(1000, "reliable keep-last depth of the measurement topics", 1,
                              100000, read_only=True),
        "min_measurement_subscribers": number(2, "measurement subscribers (a controller + "
                                              "the recorder) to wait for before an "
                                              "episode's first measurement (and every other "
                                              "one the graph shows)", 0, 100),
        "match_timeout": number(5.0, "wait at most this long for the controller to match "
                                "before an episode's first measurement (s, wall)", 0.0,
                                3600.0, "s"),
        "frame_id": FRAME,
    },
    "capture_node": {
        "bag_dir": text("bags", "folder of the bags: <bag_dir>/<name>/"),
        "compression": text("zstd", "MCAP chunk compression of the bags",
                            _one_of(("zstd", "none")), "'zstd' or 'none'"),
        "settle_time": from_config("settle_time", "settling time after closing activation "
                                   "at which the settled CQI and n_L are read (s, sim)"),
        "horizon": from_config("horizon", "simulated time by which closing must trigger "
                               "(s, sim)"),
        "sim_config": text("{}", "JSON object of further SimConfig fields (core/config.py; "
                           "tumble, sensing and policy are objects of their fields)",
                           _json_object, "a JSON object of SimConfig fields"),
        "lockstep": Param(False, "run each episode's closing policy through ROS: the "
                          "simulation waits every control period for a ClosingDecision "
                          "(sensor_node, then actuator_node's policy or a user's "
                          "controller); false: inside the kernel (faster; the same result). "
                          "A sim_config policy 'external' always runs so"),
        "start_timeout": number(60.0, "wait at most this long for the first state of an "
                                "episode (s, wall)", 0.1, 86400.0, "s"),
        "stall_timeout": number(15.0, "an episode without a new state for this long is "
                                "aborted (s, wall)", 0.1, 86400.0, "s"),
        "episode_timeout": number(3600.0, "the longest a whole episode may take (s, wall)",
                                  1.0, 604800.0, "s"),
        "ready_timeout": number(30.0, "wait at most this long for the other nodes before an "
                                "episode (s, wall)", 0.0, 3600.0, "s"),
        "drain_time": number(0.0, "extra quiet time before a bag is closed (s, wall; "
                             "completeness is checked by stamps)", 0.0, 60.0, "s"),
        "record_topics": Param(_capture_topics(), "topics recorded in bags (keys of the "
                               "topics.* parameters; those replay needs are always added)",
                               must="topic keys", check=_topic_keys, read_only=True),
        "service": text(SERVICE, "name of the RunCapture service", _ros_name,
                        "a valid ROS service name", read_only=True),
        "action": text(ACTION, "name of the Capture action", _ros_name,
                       "a valid ROS action name", read_only=True),
    },
}
for _node in PARAMETERS.values():
    _node.update(_shared())

#: parameter defaults per node
DEFAULTS: dict[str, dict] = {node: {k: p.default for k, p in params.items()}
                             for node, params in PARAMETERS.items()}


class ParameterError(ValueError):
    """A parameter value is not allowed (one line: ``<name>: got X; must be ...``)."""


def problem(node_name: str, name: str, value) -> str:
    """'' if ``value`` is allowed for parameter ``name`` of ``node_name``, else the line
    ``<name>: got X; must be ...``."""
    spec = PARAMETERS[node_name].get(name)
    if spec is None:
        return ""
    what = spec.problem(value)
    return f"{name}: {what}" if what else ""


def set_by_the_run(node: str, name: str) -> bool:
    """Whether a Monte Carlo command sets this parameter itself from the episode's
    configuration, noise model and controller (RosSuite's node_parameters): a command
    line's override would make the results differ from their run key's."""
    return (node, name) in {("capture_node", "settle_time"), ("capture_node", "horizon"),
                            ("capture_node", "sim_config"), ("capture_node", "bag_dir"),
                            ("capture_node", "lockstep"), ("actuator_node", "builtin_policy")} \
        or (node == "actuator_node" and name.startswith("noise."))


def parse_override(item: str) -> tuple[str, str, object]:
    """``NODE.NAME=VALUE`` (a command line's node parameter) as (node, name, value), the
    value of the parameter's type (bool: true/false), checked against its rule; raises
    ParameterError naming what is wrong and what is allowed."""
    where, sep, raw = item.partition("=")
    node, _, name = where.partition(".")
    if not sep or not name:
        raise ParameterError(f"{item!r}: expected NODE.NAME=VALUE, e.g. "
                             "sim_node.decision_timeout=20")
    if node not in PARAMETERS:
        raise ParameterError(f"{item!r}: no node {node!r}; nodes: {', '.join(PARAMETERS)}")
    spec = PARAMETERS[node].get(name)
    if spec is None:
        raise ParameterError(f"{item!r}: {node} has no parameter {name!r}; its parameters: "
                             f"{', '.join(PARAMETERS[node])}")
    if set_by_the_run(node, name):
        raise ParameterError(f"{node}.{name}: set by the command itself (from --config, the "
                             "noise options, --lockstep or --controller), not by --node-param")
    kind = type(spec.default)
    try:
        if kind is bool:
            if raw.lower() not in ("true", "false"):
                raise ValueError(raw)
            value = raw.lower() == "true"
        else:
            value = kind(raw)
    except ValueError:
        raise ParameterError(f"{node}.{name}: got {raw!r}; must be "
                             + ("true or false" if kind is bool else f"of type {kind.__name__}")
                             + (f" ({spec.must})" if spec.must else "")) from None
    what = problem(node, name, value)
    if what:
        raise ParameterError(f"{node}.{what}")
    return node, name, value


def descriptor(name: str, spec: Param):
    """The ParameterDescriptor of a parameter: description, range, rule in words."""
    from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor

    d = ParameterDescriptor(name=name, description=spec.description, read_only=spec.read_only,
                            additional_constraints=f"must be {spec.must}" if spec.must else "")
    if spec.low is not None and isinstance(spec.default, float):
        d.floating_point_range = [FloatingPointRange(from_value=float(spec.low),
                                                     to_value=float(spec.high), step=0.0)]
    elif spec.low is not None:
        d.integer_range = [IntegerRange(from_value=int(spec.low), to_value=int(spec.high),
                                        step=1)]
    return d


def describe_builtin(node) -> None:
    """Describe rclpy's own ``use_sim_time`` parameter of ``node``."""
    from rcl_interfaces.msg import ParameterDescriptor
    from rclpy.parameter import Parameter

    node.set_descriptor("use_sim_time", ParameterDescriptor(
        name="use_sim_time", type=Parameter.Type.BOOL.value,
        description="rclpy's: take the node clock from /clock; the suite's messages carry "
                    "simulated time in their stamps whatever it says"))


def sim_config_of(values: dict) -> SimConfig:
    """The capture node's SimConfig: its ``sim_config`` JSON object with its
    ``settle_time`` and ``horizon`` parameters.  Raises ConfigError naming the parameter
    (``sim_config`` for a field of the JSON object)."""
    text = values.get("sim_config") or "{}"
    try:
        data = json.loads(text)
    except ValueError:
        data = None
    if not isinstance(data, dict):
        raise ConfigError(f"sim_config: got {text!r}; must be a JSON object of SimConfig fields")
    data["settle_time"] = float(values["settle_time"])
    data["horizon"] = float(values["horizon"])
    if data.get("early_call"):
        # the monitor judges a state at its end step without the call's check
        raise ConfigError("sim_config: field 'early_call' is not supported through ROS (the "
                          "capture monitor reads the settled state at the settle time); "
                          "leave it false")
    try:
        return SimConfig.from_dict(data)
    except (ConfigError, TypeError, ValueError) as exc:
        line = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        for name in ("settle_time", "horizon"):
            if line.startswith(f"config field '{name}':"):
                raise ConfigError(f"{name}: {line.split(': ', 1)[1]}") from None
        raise ConfigError(f"sim_config: {line}") from None


def sim_config_problem(values: dict) -> str:
    """'' if the capture node's parameters ``values`` give a valid SimConfig, else why not."""
    try:
        sim_config_of(values)
    except ConfigError as exc:
        return str(exc)
    return ""


def declare(node, node_name: str, check: Callable[[dict], str] | None = None) -> None:
    """Declare every parameter of ``node_name`` (a key of PARAMETERS) on ``node`` with its
    descriptor, and refuse bad values then and later (``ros2 param set``).

    check: a further rule over the node's parameters as they would be after a change
    (name -> value; '' or the line that says what is wrong), e.g. the capture node's
    SimConfig.  Raises ParameterError (one line) if a value given at start-up (parameter
    file, ``-p``) is not allowed.

    Each parameter is declared with its description only, so that a start-up value is
    judged by the callback below (its reason names the parameter and its rule); then the
    full descriptor (range, read-only) is set.
    """
    from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
    from rclpy.exceptions import InvalidParameterValueException
    from rclpy.parameter import Parameter

    specs = PARAMETERS[node_name]

    def current() -> dict:
        return {k: (node.get_parameter(k).value if node.has_parameter(k) else p.default)
                for k, p in specs.items()}

    refused = [""]

    def on_set(params) -> SetParametersResult:
        changes = {p.name: p.value for p in params}
        reason = next((r for r in (problem(node_name, k, v) for k, v in changes.items()) if r), "")
        if not reason and check is not None and any(name in specs for name in changes):
            reason = check({**current(), **changes})
        refused[0] = reason
        return SetParametersResult(successful=not reason, reason=reason)

    node.add_on_set_parameters_callback(on_set)
    describe_builtin(node)
    for name, spec in specs.items():
        try:
            node.declare_parameter(name, spec.default,
                                   ParameterDescriptor(description=spec.description))
        except InvalidParameterValueException as exc:
            raise ParameterError(refused[0] or str(exc)) from None
        full = descriptor(name, spec)
        full.type = Parameter.Type.from_parameter_value(spec.default).value
        node.set_descriptor(name, full)


def param(node, key: str):
    return node.get_parameter(key).value


def topic(node, key: str) -> str:
    return node.get_parameter(f"topics.{key}").value


def node_spreads(node) -> dict[str, float]:
    """The actuator node's noise spreads (its ``noise.*`` parameters)."""
    return {k: float(param(node, f"noise.{k}")) for k in SPREAD_FIELDS}
