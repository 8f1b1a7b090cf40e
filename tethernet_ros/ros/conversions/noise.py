"""NoiseSettings.msg and NoiseSample.msg from and to the core's noise model and draws."""
from __future__ import annotations

from ...core.noise import (NOISE_SOURCES, SPREAD_FIELDS, NoiseError, NoiseModel, NoiseSample,
                          check_orientation_axis, check_scale)
from .errors import RequestError


#: noise source -> NoiseSettings.msg field
NOISE_FIELDS = {s: f"{s}_scale" for s in NOISE_SOURCES}

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
                     "spin_transverse_angle", "target_mass_offset"):
            setattr(m, name, float(getattr(sample, name)))
        for name in ("speed_offsets", "polar_angles", "azimuth_angles", "target_inertia_offsets",
                     "target_com_offset"):
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
            spin_transverse_angle=float(m.spin_transverse_angle),
            # (a bag from before the target's noise: none)
            target_mass_offset=float(getattr(m, "target_mass_offset", 0.0)),
            target_inertia_offsets=tuple(float(v) for v in getattr(m, "target_inertia_offsets",
                                                                   (0.0, 0.0, 0.0))),
            target_com_offset=tuple(float(v) for v in getattr(m, "target_com_offset",
                                                              (0.0, 0.0, 0.0))))
    return sample, {k: float(getattr(m, k, 0.0)) for k in SPREAD_FIELDS}
