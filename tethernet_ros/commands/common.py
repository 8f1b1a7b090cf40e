"""Arguments and helpers shared by several commands."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from optimizer.jsonio import json_clean

from ..core.config import CRITERIA
from ..core.design import REFERENCE_DESIGNS, Design, read_design_file
from ..core.kernel.policy_table import choices_help, controller_policy, selectable
from ..core.noise import NOISE_SOURCES, ORIENTATION_AXES, SCALE_RANGE, NoiseError, NoiseModel
from ..core.sensing import NET_POINTS
from ..core.tumble import AXES, TRANSVERSE
from ..errors import UserError

#: the tumble's named axes (core/tumble.py), for --tumble-axis
TUMBLE_AXES = (*AXES, TRANSVERSE)
#: the closing and launch policies a flag can name (core/kernel/policy_table.py; not
#: 'external', which needs a controller node: --via ros --controller)
CLI_POLICIES = selectable("closing")
CLI_LAUNCH_POLICIES = selectable("launch")
#: --target-*-sigma flags: their NoiseModel spreads and help
TARGET_SPREAD_FIELDS = {"--target-mass-sigma": "sigma_target_mass",
                        "--target-inertia-sigma": "sigma_target_inertia",
                        "--target-com-sigma": "sigma_target_com"}
TARGET_SPREAD_FLAGS = {
    "--target-mass-sigma": "standard deviation of the target's mass, relative (e.g. 0.05)",
    "--target-inertia-sigma": "standard deviation of each principal moment, relative",
    "--target-com-sigma": "standard deviation of the centre of mass along each body axis (m)"}
#: command-line flag -> the nested SimConfig field it sets
SCENARIO_FLAGS = {
    "--tumble-rate": ("tumble", "rate_deg_s"), "--tumble-axis": ("tumble", "axis"),
    "--tumble-phase": ("tumble", "phase_deg"), "--policy": ("policy", "kind"),
    "--net-point": ("sensing", "net_point"), "--sensing-rate": ("sensing", "rate_hz"),
    "--latency": ("sensing", "latency"), "--target": ("target", None),
    "--target-mass": ("target", "mass"), "--target-units": ("target", "units"),
    "--target-attitude": ("target", "attitude_deg"),
    "--launch-policy": ("launch", "kind"), "--launch-max-wait": ("launch", "max_wait"),
    "--launch-max-tilt": ("launch", "max_tilt_deg"), "--launch-confirm": ("launch", "confirm_time"),
    "--tug": ("tug", "peak_tension"), "--tow-acceleration": ("tug", "tow_acceleration"),
}


def add_design_argument(p: argparse.ArgumentParser) -> None:
    p.add_argument("--design", required=True, metavar="NAME|FILE.yaml",
                   help="reference design (baseline, suboptimal, mass-min, time-min) or a YAML "
                        "file with keys m_c, L_n, r_n, d_L, V_e, d_c (and optionally a tumble: "
                        "mapping: rate_deg_s, axis, phase_deg; a target: mapping: name or "
                        "mesh, mass, units, com, inertia, attitude_deg; a launch: mapping: "
                        "kind, max_wait, max_tilt_deg, confirm_time, aim_offset)")


def add_noise_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--noise-scale", action="append", default=[], metavar="SOURCE=FACTOR",
                   help=f"multiply one noise source's spread; sources: {', '.join(NOISE_SOURCES)} "
                        "(repeatable)")
    p.add_argument("--orientation-axis", choices=ORIENTATION_AXES, default="z",
                   help="axis of the target-orientation noise (default z, the line of sight)")
    g = p.add_argument_group("the target's uncertain mass properties (docs/noise.md §1; "
                             "default 0: known)")
    for flag, what in TARGET_SPREAD_FLAGS.items():
        g.add_argument(flag, type=float, default=None, metavar="SIGMA", help=what)


def add_target_file_arguments(g) -> None:
    """--target-mass and --target-units: what a target's name or file leaves open."""
    g.add_argument("--target-mass", type=float, default=None, metavar="KG",
                   help="the target's mass (kg; default the catalogue's, 8300 for zenit-2; "
                        "a mesh file needs one)")
    g.add_argument("--target-units", default=None, metavar="m|cm|mm|in|ft",
                   help="the length unit of a --target mesh file (default m)")


def add_config_argument(p: argparse.ArgumentParser) -> None:
    """--config and the scenario's options (tumble, sensing, closing policy), which set
    the nested SimConfig fields over --config and a design file's ``tumble:``."""
    p.add_argument("--config", default=None, metavar="FILE.yaml",
                   help="simulation settings overriding the defaults of docs/model.md (SimConfig fields, "
                        "e.g. settle_time: 20.0, dt_safety: 0.5, target: {nozzle: true}, "
                        "tumble: {rate_deg_s: 2}, sensing: {rate_hz: 50}, policy: {kind: adaptive})")
    g = p.add_argument_group("scenario", "the target's tumble, the sensing and the closing policy "
                             "(docs/model.md §1, §14); over --config and a design file's tumble:")
    g.add_argument("--target", default=None, metavar="NAME|FILE",
                   help="the target: zenit-2 (the source's stage, default), a catalogue name "
                        "(docs/targets.md) or a mesh "
                        "file (.stl, .obj, .ply, .glb, .gltf, .off; give --target-mass)")
    add_target_file_arguments(g)
    g.add_argument("--target-attitude", default=None, metavar="RX,RY,RZ",
                   help="the target's initial attitude, which face the chaser sees: turns "
                        "(deg) about the world x, then y, then z axis (default none)")
    g.add_argument("--tumble-rate", type=float, default=None, metavar="DEG_S",
                   help="the target's initial spin rate in [0, 60] deg/s (0: at rest, the default)")
    g.add_argument("--tumble-axis", default=None, metavar="|".join(TUMBLE_AXES) + "|X,Y,Z",
                   help="its spin axis in the target's body frame: flat (end over end, "
                        "default), los (about the line of sight), long (a roll), transverse "
                        "(random about the long axis), or a vector X,Y,Z")
    g.add_argument("--tumble-phase", type=float, default=None, metavar="DEG",
                   help="initial turn of the target about the spin axis (deg)")
    g.add_argument("--policy", choices=CLI_POLICIES, default=None,
                   help="closing policy (docs/model.md §14): " + choices_help("closing"))
    g.add_argument("--launch-policy", choices=CLI_LAUNCH_POLICIES, default=None,
                   help="launch policy (docs/model.md §16): " + choices_help("launch"))
    g.add_argument("--launch-max-wait", type=float, default=None, metavar="S",
                   help="the chaser fires by then whatever the policy says, in [0, 3600] s "
                        "(default 360)")
    g.add_argument("--launch-max-tilt", type=float, default=None, metavar="DEG",
                   help="the predictive policy's largest tilt of the long axis out of the "
                        "plane across the line of sight, in [0.1, 90] deg (default 30)")
    g.add_argument("--launch-confirm", type=float, default=None, metavar="S",
                   help="the predictive policy fires once the attitude has been favourable at "
                        "every measurement for this long, in [0, 60] s (default 1)")
    g.add_argument("--tug", type=float, default=None, metavar="N",
                   help="after the settle time, take up the slack and pull the tether with "
                        "a thrust of N newtons, and judge whether the net holds the target "
                        "(docs/model.md §17); sets tug: {enabled: true, peak_tension: N} and, "
                        "unless the config sets it, tether_order: chain")
    g.add_argument("--tow-acceleration", type=float, default=None, metavar="M_S2",
                   help="the tug test's required pull as a towing acceleration of the target "
                        "(m/s^2, in [1e-4, 10]; default 0.05: 415 N on the Zenit-2): the pull "
                        "is it times the target's mass (docs/model.md §17)")
    g.add_argument("--criterion", choices=CRITERIA, default=None,
                   help="what success means (docs/model.md §17): source, the source's settled "
                        "CQI and locked pairs (default); held, that and the tug test holding "
                        "the required pull (turns the tug test on, with tether_order: chain "
                        "unless the config sets it)")
    g.add_argument("--net-point", choices=NET_POINTS, default=None,
                   help="the net's sensed reference point (default com)")
    g.add_argument("--sensing-rate", type=float, default=None, metavar="HZ",
                   help="measurements per second in [0, 1000] (0: every step, the default)")
    g.add_argument("--latency", type=float, default=None, metavar="S",
                   help="sensing latency in [0, 5] s (default 0)")


def add_fidelity_argument(p: argparse.ArgumentParser) -> None:
    """--fidelity: simulate at the reference fidelity (the configuration as given, the
    default) or at exploration's (the implicit step at 2 ms with 8 sweeps and the early
    call; core/fidelity.py)."""
    from ..core.fidelity import FIDELITIES, REFERENCE

    p.add_argument("--fidelity", choices=FIDELITIES, default=REFERENCE,
                   help="reference: the configuration as given (default); exploration: the "
                        "same with the implicit step at 2 ms and 8 solver sweeps, and a "
                        "clear success called at half the settle time (early_call), at "
                        "0.39-0.61 of the CPU time, whose statistics matched the "
                        "reference's on the designs of docs/studies/fidelity.md (not a "
                        "reference-fidelity result; needs the default 1 ms implicit step "
                        "and 4 sweeps in --config, and early_call off)")


def fidelity_config(args, config):
    """``config`` at the --fidelity asked for (core.fidelity.at_fidelity: reference
    returns it unchanged); FidelityError naming --fidelity and the field it conflicts
    with."""
    from ..core.fidelity import REFERENCE, at_fidelity

    return at_fidelity(config, getattr(args, "fidelity", REFERENCE) or REFERENCE,
                       field="--fidelity")


def _three(text: str) -> list[float] | None:
    """The three numbers of 'a,b,c', or None."""
    try:
        v = [float(c) for c in text.split(",")]
    except ValueError:
        return None
    return v if len(v) == 3 else None


def three_numbers(flag: str, text: str) -> list[float]:
    """Three numbers 'a,b,c' of a flag; UserError naming it otherwise."""
    v = _three(text)
    if v is None:
        raise UserError(f"{flag} {text!r}: must be three numbers a,b,c")
    return v


def tumble_axis(text: str):
    """A --tumble-axis value: a name of TUMBLE_AXES, or three numbers 'x,y,z'."""
    if text in TUMBLE_AXES:
        return text
    values = _three(text)
    if values is None:
        raise UserError(f"--tumble-axis {text!r}: must be one of {', '.join(TUMBLE_AXES)} or "
                        "three numbers X,Y,Z (a body-frame vector)")
    return values


def scenario_overrides(args) -> tuple[dict, dict]:
    """(nested SimConfig values of the scenario flags given, e.g. {"tumble": {"rate_deg_s":
    2.0}}; flag of each value, e.g. {"tumble.rate_deg_s": "--tumble-rate"})."""
    values: dict = {}
    flags: dict = {}
    for flag, (group, field) in SCENARIO_FLAGS.items():
        v = getattr(args, flag[2:].replace("-", "_"), None)
        if v is None:
            continue
        if flag == "--tumble-axis":
            v = tumble_axis(v)
        if flag == "--target-attitude":
            v = three_numbers(flag, v)
        if flag == "--target":
            for k, x in target_fields(v).items():
                values.setdefault(group, {})[k] = x
                flags[f"{group}.{k}"] = flag
            continue
        values.setdefault(group, {})[field] = v
        flags[f"{group}.{field}"] = flag
        if flag == "--tug":
            values[group]["enabled"] = True
            flags[f"{group}.enabled"] = flag
    return values, flags


def target_fields(text: str) -> dict:
    """The TargetConfig fields of a --target value (core.target.target_fields)."""
    from ..core.target import TargetError, target_fields as fields_of

    try:
        return fields_of(text)
    except TargetError as exc:
        raise UserError(f"--target: {exc}") from None


def _design_scenario(args) -> tuple[dict, str]:
    """The scenario mappings of the --design file (read_design_file) and its name; ({}, '')
    for a reference design."""
    name = getattr(args, "design", None)
    if not name or name in REFERENCE_DESIGNS or not Path(name).is_file():
        return {}, ""
    return read_design_file(name)[1], name


def config_from_args(args, **overrides):
    """SimConfig from --config (if given), the --design file's ``tumble:``, ``target:`` and
    ``launch:`` over it, the scenario flags (--tumble-*, --policy, --launch-*, --net-point,
    --sensing-rate, --latency, ...) over that, and ``overrides`` applied on top.  A bad
    value is refused naming its flag (or file) and its range."""
    from ..core.config import ConfigError, SimConfig

    data = {}
    if getattr(args, "config", None):
        import yaml

        path = Path(args.config)
        if not path.is_file():
            raise UserError(f"--config: file {str(path)!r} does not exist")
        try:
            data = yaml.safe_load(path.read_text()) or {}
        except yaml.YAMLError:
            raise UserError(f"--config: file {str(path)!r} is not valid YAML") from None
        if not isinstance(data, dict):
            raise UserError(f"--config: file {str(path)!r} must hold a mapping of SimConfig fields")
    scenario, design_file = _design_scenario(args)
    layers = [({group: fields_}, {f"{group}.{k}": f"--design {design_file} ({group}:)"
                                  for k in fields_})
              for group, fields_ in scenario.items()]
    layers.append(scenario_overrides(args))
    where: dict = {}
    for values, flags in layers:
        for group, fields_ in values.items():
            base = data.get(group)
            base = dict(base) if isinstance(base, dict) else {}
            if group == "target" and "name" in fields_:
                # a target named anew keeps only where it is turned, not the mass, file
                # or mass properties of the one it replaces
                base = {k: v for k, v in base.items() if k == "attitude_deg"}
            data[group] = {**base, **fields_}
        where.update(flags)
    if getattr(args, "tug", None) is not None and "tether_order" not in data:
        data["tether_order"] = "chain"          # the tug test needs the straight tether
    if getattr(args, "criterion", None) is not None:
        data["criterion"] = args.criterion
        where["criterion"] = "--criterion"
    data.update(overrides)
    try:
        return SimConfig.from_dict(data)
    except TypeError as exc:
        raise ConfigError(f"config: {exc}") from None
    except ConfigError as exc:
        text = str(exc)
        for key, flag in where.items():
            group, field = key.split(".") if "." in key else ("config", key)
            if text.startswith(f"{group} field '{field}'") or \
                    (text.startswith(f"config field '{key}'")):
                raise ConfigError(f"{flag}: {text}") from None
        raise


def add_backend_arguments(p: argparse.ArgumentParser) -> None:
    """--workers / --scheduler: which EpisodeBackend runs the episodes."""
    p.add_argument("--workers", type=int, default=None, metavar="K",
                   help="local worker processes (default: all cores; 0: in this process)")
    p.add_argument("--scheduler", default=None, metavar="ADDR|local",
                   help="run on a Dask cluster at ADDR (tcp://host:8786), or 'local' for a "
                        "local Dask cluster of --workers processes")


def check_backend_arguments(args) -> None:
    if args.workers is not None and args.workers < 0:
        raise UserError(f"--workers {args.workers}: must be an integer >= 0 (0: in-process)")
    if args.scheduler is not None and args.workers == 0:
        raise UserError("--workers 0 (in-process) cannot be combined with --scheduler")


def add_ros_arguments(p: argparse.ArgumentParser, via: bool = True) -> None:
    """--via / --controller / --lockstep of the Monte Carlo commands: the episodes through
    the ROS 2 suite (--workers K: K suites side by side), the closing decided by a user's
    controller node or by the built-in policy through the ROS loop (``via``: add --via
    too)."""
    if via:
        p.add_argument("--via", choices=("library", "ros"), default="library",
                       help="ros: every episode through the ROS 2 node suite (RunCapture), its "
                            "result read back from its bag; --workers K runs K suites side "
                            "by side")
    p.add_argument("--controller", default=None, metavar="SCRIPT|module:Class",
                   help="with --via ros: your controller node decides when to close, in place "
                        "of the built-in policy (a console script or a Node class; docs/ros.md, "
                        "the controller contract), e.g. example_controller")
    p.add_argument("--node-param", action="append", default=[], metavar="NODE.NAME=VALUE",
                   help="with --via ros: a node parameter of every suite (repeatable), e.g. "
                        "sim_node.decision_timeout=20 for a slow controller on a loaded "
                        "machine (timeouts, rates, queue depths: docs/ros.md; those the "
                        "command sets from the configuration are refused)")
    p.add_argument("--lockstep", action="store_true",
                   help="with --via ros: the built-in closing policy runs through the ROS loop "
                        "(sensor_node, actuator_node) every control period, not in the kernel "
                        "(the same results, slower)")


def check_ros_arguments(args) -> None:
    if getattr(args, "via", "library") != "ros":
        for flag in ("controller", "lockstep", "node_param"):
            if getattr(args, flag, None):
                raise UserError(f"--{flag.replace('_', '-')} needs --via ros (it acts on the "
                                "ROS suite's nodes)")
        return
    if getattr(args, "scheduler", None) is not None:
        raise UserError("--via ros runs the episodes through ROS suites (--workers K of them); "
                        "it cannot be combined with --scheduler")


def controller_config(args, config):
    """The episodes' SimConfig with --controller: the policy 'external' (a controller
    outside the kernel decides; so its results file key differs from the built-in's)."""
    if not getattr(args, "controller", None):
        return config
    from dataclasses import replace

    return config.replace(policy=replace(config.policy, kind=controller_policy("closing")))


def controller_label(args) -> str:
    """'' or a results-file suffix naming --controller, e.g. '_ctl-example_controller'."""
    spec = getattr(args, "controller", None)
    if not spec:
        return ""
    name = spec.rsplit(":", 1)[-1] if ":" in spec else Path(spec).name
    return "_ctl-" + "".join(c if c.isalnum() or c in "-_." else "_" for c in name)


def node_params_from_args(args) -> dict | None:
    """--node-param NODE.NAME=VALUE items as RosSuite's extra parameters per node (None:
    none given); a bad item is a UserError naming it and what is allowed."""
    from ..ros.parameters import ParameterError, parse_override

    params: dict = {}
    for item in getattr(args, "node_param", None) or ():
        try:
            node, name, value = parse_override(item)
        except ParameterError as e:
            raise UserError(f"--node-param {e}") from None
        params.setdefault(node, {})[name] = value
    return params or None


def backend_from_args(args, bag_dir=None, keep_bags: bool = False):
    """The EpisodeBackend chosen by --via ros (RosBackend of --workers suites, default 1;
    ``bag_dir`` / ``keep_bags`` as RosBackend takes them), else by --workers /
    --scheduler."""
    if getattr(args, "via", "library") == "ros":
        from ..ros.backend import RosBackend

        return RosBackend(workers=args.workers or 1, lockstep=getattr(args, "lockstep", False),
                          controller=getattr(args, "controller", None),
                          params=node_params_from_args(args), bag_dir=bag_dir,
                          keep_bags=keep_bags)
    from ..montecarlo import make_backend

    return make_backend(workers=args.workers, scheduler=args.scheduler)


def design_from_args(args) -> Design:
    return read_design_file(args.design)[0]


def noise_model_from_args(args) -> NoiseModel:
    scales = {}
    for item in args.noise_scale:
        if "=" not in item:
            raise UserError(f"--noise-scale {item!r}: expected SOURCE=FACTOR, sources {list(NOISE_SOURCES)}")
        k, v = item.split("=", 1)
        try:
            scales[k.strip()] = float(v)
        except ValueError:
            raise UserError(f"--noise-scale {item!r}: FACTOR must be a number in "
                            f"[{SCALE_RANGE[0]:g}, {SCALE_RANGE[1]:g}]") from None
    spreads = {}
    for flag in TARGET_SPREAD_FLAGS:
        v = getattr(args, flag[2:].replace("-", "_"), None)
        if v is not None:
            spreads[TARGET_SPREAD_FIELDS[flag]] = v
    try:
        return NoiseModel(orientation_axis=args.orientation_axis, scales=scales, **spreads)
    except NoiseError as exc:
        text = str(exc)
        for flag, field in TARGET_SPREAD_FIELDS.items():
            if f"'{field}'" in text:
                raise UserError(f"{flag}: {text}") from None
        raise


def print_json(obj) -> None:
    print(json.dumps(json_clean(obj), indent=2, sort_keys=False))
