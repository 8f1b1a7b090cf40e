"""EpisodeSetup.msg and what a request sets of it: the tumble (Tumble.msg), the target, the
configuration's JSON."""
from __future__ import annotations

import json
import math

from ...core.config import SimConfig
from ...core.design import Design
from ...core.noise import NoiseModel
from ...core.tumble import TumbleConfig, TumbleError
from ..state import Setup
from .design import design_from_msg, design_msg
from .noise import noise_settings_from_msg, noise_settings_msg
from .errors import RequestError, detail
from .stamps import set_time


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
        said = detail(exc)
        if field == "axis":
            said = said.replace("or a vector [x, y, z]", "or '' with axis_vector")
        raise RequestError(f"{prefix}.{field}", said) from None


def config_with_tumble(config: SimConfig, request) -> SimConfig:
    """The episode's SimConfig: ``config`` with the request's tumble where it sets one
    (``set_tumble``), its launch where it sets one (``set_launch``) and its target where
    it names one; RequestError names a bad tumble, launch or target field."""
    if getattr(request, "set_tumble", False):
        config = config.replace(tumble=tumble_from_msg(request.tumble))
    launch = launch_from_request(request, config.launch)
    if launch is not None:
        config = config.replace(launch=launch)
    target = target_from_request(request, config.target)
    config = config if target is None else config.replace(target=target)
    return criterion_from_request(request, config)


def criterion_from_request(request, config: SimConfig) -> SimConfig:
    """``config`` with the request's ``criterion`` (empty: the configured one; 'held' turns
    the tug test on, ``config.with_criterion``) and ``tow_acceleration`` (0: the
    configured one); RequestError names a bad field and its range."""
    from dataclasses import replace

    from ...core.config import CRITERIA, ConfigError
    from ...core.tug import TugError

    criterion = str(getattr(request, "criterion", "") or "")
    if criterion:
        if criterion not in CRITERIA:
            raise RequestError("criterion", f"got {criterion!r}; must be one of "
                               f"{', '.join(repr(c) for c in CRITERIA)} (empty: the capture "
                               "node's configured one)")
        try:
            config = SimConfig.from_dict({**config_overrides(config), "criterion": criterion})
        except ConfigError as exc:
            raise RequestError("criterion", str(exc)) from None
    accel = float(getattr(request, "tow_acceleration", 0.0))
    if accel != 0.0:
        try:
            config = config.replace(tug=replace(config.tug, tow_acceleration=accel))
        except TugError as exc:
            raise RequestError("tow_acceleration", detail(exc)) from None
    return config


def check_pull(design: Design, config: SimConfig) -> None:
    """RequestError naming ``tow_acceleration`` (or the configuration's peak_tension) when
    the required pull on the nominal target exceeds the tether's breaking load."""
    from ...core.scenario import nominal_pull
    from ...core.tug import TugError

    try:
        nominal_pull(design, config)
    except TugError as exc:
        text = str(exc)
        field = "tow_acceleration" if "'tow_acceleration'" in text else "sim_config tug.peak_tension"
        raise RequestError(field, detail(exc)) from None


#: the LaunchConfig fields a RunCapture request or Capture goal carries (with
#: ``set_launch``) -> its field; the others come from the capture node's configuration
LAUNCH_REQUEST_FIELDS = {"kind": "launch_policy", "max_wait": "launch_max_wait",
                         "max_tilt_deg": "launch_max_tilt_deg"}


def launch_from_request(request, base=None):
    """The LaunchConfig a request sets (``set_launch``: ``launch_policy``,
    ``launch_max_wait`` and ``launch_max_tilt_deg``, 0 keeping ``base``'s limit, over
    ``base``'s other settings; None: the configured launch); RequestError names the bad
    field and its range."""
    from dataclasses import replace

    from ...core.launch import LaunchConfig, LaunchError

    if not getattr(request, "set_launch", False):
        return None
    fields = {"kind": str(request.launch_policy), "max_wait": float(request.launch_max_wait)}
    tilt = float(getattr(request, "launch_max_tilt_deg", 0.0))
    if tilt != 0.0:
        fields["max_tilt_deg"] = tilt
    try:
        return replace(base or LaunchConfig(), **fields)
    except LaunchError as exc:
        text = str(exc)
        field = next((req for name, req in LAUNCH_REQUEST_FIELDS.items()
                      if f"'{name}'" in text), "launch_policy")
        raise RequestError(field, detail(exc)) from None


def target_from_request(request, base=None):
    """The TargetConfig a request's ``target``, ``target_mass`` and ``target_units`` name
    (None: the configured target); a target named anew keeps only where ``base`` (the
    configured target) is turned, ``attitude_deg``, as the CLI's --target does, and a mesh
    file without a unit is read in ``base``'s when ``base`` is a mesh file (else m);
    RequestError names the bad field."""
    from ...core.target import TargetConfig, TargetError, target_fields

    name = getattr(request, "target", "") or ""
    mass = float(getattr(request, "target_mass", 0.0) or 0.0)
    units = str(getattr(request, "target_units", "") or "")
    if not name:
        if mass != 0.0:
            raise RequestError("target_mass", "given without a target; name the target too")
        if units:
            raise RequestError("target_units", "given without a target; name the mesh file too")
        return None
    if not (math.isfinite(mass) and mass >= 0.0):
        raise RequestError("target_mass", f"got {mass!r}; must be a mass > 0 kg (0: the "
                           "catalogue's)")
    try:
        fields = target_fields(name)
        if units and not fields["mesh"]:
            raise RequestError("target_units", f"got {units!r} for the catalogue target "
                               f"{name!r}; a unit is given for a mesh file only")
        if fields["mesh"]:
            # a mesh file is read in the request's unit, else the configured target's
            fields["units"] = units or (base.units if base is not None and base.mesh else "m")
        turned = {} if base is None else {"attitude_deg": base.attitude_deg}
        return TargetConfig(**fields, **turned, **({"mass": mass} if mass > 0 else {}))
    except TargetError as exc:
        text = str(exc)
        field = ("target_mass" if "'mass'" in text else
                 "target_units" if "'units'" in text or "give units" in text else "target")
        raise RequestError(field, text) from None


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
