"""Launch policies: when the chaser fires its one-shot net, decided from what it senses of
the tumbling target (docs/model.md §16).  A policy is its settings (:class:`LaunchConfig`)
and one numba function, ``kernel.launch.decide_launch``, which runs inside the kernel while
the lane waits, or is left to a controller outside it ('external').

- ``immediate`` (the default): fire at once, as every result before launch policies did.
- ``predictive``: at each decision, predict by torque-free rotation, from the sensed
  attitude and angular velocity and the inertia of the target's shape, the attitude over
  the window in which the net wraps the target (from the moment the net's centre of mass
  is planned to reach the target's centre to the end of closing), and fire when the long
  axis stays within ``max_tilt_deg`` of the plane across the line of sight all through it.
  The tumbling study (docs/studies/tumbling.md) found the net fails on a stage met end-on.
- ``external``: a controller outside the kernel fires (the ROS suite's launch controller).

Whatever the policy, the chaser fires once ``max_wait`` s have passed.  The episode's
times (closing, completion T) count from the first moment the chaser could have fired, so
waiting costs Case 2's objective honestly.  Units: SI; angles in the settings in deg.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import detmath
from .kernel.launch import LAUNCH_POLICIES, LaunchModel, immediate_launch
from .kernel.model import steps_every

__all__ = ["LAUNCH_POLICIES", "LaunchConfig", "LaunchError", "launch_model", "planned_window"]

#: (low, high, words) of the numeric settings
_LIMITS = {
    "max_wait": (0.0, 3600.0, "a time in [0, 3600] s"),
    "max_tilt_deg": (0.1, 90.0, "an angle in [0.1, 90] deg"),
    "rate_hz": (0.01, 1000.0, "a rate in [0.01, 1000] Hz"),
}


class LaunchError(ValueError):
    """A launch setting is outside its allowed range (message names the field)."""


@dataclass(frozen=True)
class LaunchConfig:
    """kind: one of ``LAUNCH_POLICIES``; max_wait (s): the chaser fires by then whatever the
    policy says (default 360 s: half a turn at 0.5 deg/s, the slowest tumble studied, so a
    flat spin shows every attitude within it); max_tilt_deg: the largest angle between the
    long axis and the plane across the line of sight the predictive policy accepts
    (default 30 deg, |a_z| <= 0.5: the bin in which the tumbling study's Case choices
    captured 57-59 of 59 samples); rate_hz: decisions per second (rounded to a whole number
    of sensing periods)."""

    kind: str = "immediate"
    max_wait: float = 360.0
    max_tilt_deg: float = 30.0
    rate_hz: float = 10.0

    def __post_init__(self):
        if self.kind not in LAUNCH_POLICIES:
            raise LaunchError(f"launch field 'kind': got {self.kind!r}; must be one of "
                              f"{', '.join(LAUNCH_POLICIES)}")
        for name, (lo, hi, what) in _LIMITS.items():
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                    or not lo <= v <= hi:
                raise LaunchError(f"launch field '{name}': got {v!r}; must be {what}")

    @property
    def index(self) -> int:
        return LAUNCH_POLICIES.index(self.kind)

    @property
    def immediate(self) -> bool:
        return self.kind == "immediate"


def planned_window(design, config) -> tuple[float, float]:
    """(arrival, closing) (s after the launch) of the design's planned capture: when the
    net's centre of mass reaches the target's centre, and when closing starts, in the
    nominal episode (no noise, the target at rest, ideal sensing, fired at once; its
    flight only, up to closing).  This is what the chaser plans from its own design; the
    net slows as it spreads, so a constant-speed estimate from the launch momentum comes
    7-24 % early on the reference designs (docs/model.md §16).  Computed once per design
    and configuration in a process."""
    from .policies import PolicyConfig
    from .sensing import SensingConfig
    from .tumble import TumbleConfig

    plan = config.replace(launch=LaunchConfig(), tumble=TumbleConfig(), sensing=SensingConfig(),
                          policy=PolicyConfig(**{**vars(config.policy)}), state_rate=0.0)
    key = (repr(design), repr(plan))
    if key not in _WINDOWS:
        if len(_WINDOWS) >= 256:
            _WINDOWS.clear()
        _WINDOWS[key] = _planned_window(design, plan)
    return _WINDOWS[key]


_WINDOWS: dict = {}


def _planned_window(design, plan) -> tuple[float, float]:
    from .episode import CaptureSimulation, EpisodeClock
    from .scenario import scenario_for

    sim = CaptureSimulation(scenario_for(design, None, plan))
    clock = EpisodeClock(plan, sim.dt)
    arrival = math.nan
    end = sim.horizon_steps
    while not sim.closing_active and sim.step < end:
        sim.advance(clock.next_stop(sim.step, end) - sim.step)
        if math.isnan(arrival) and sim.net_centre_of_mass()[2] >= sim.s.target_body.pos[2]:
            arrival = sim.time
        if sim.divergence():
            break
    if not sim.closing_active:
        raise LaunchError(f"launch: the design's planned capture never closes within the "
                          f"{plan.horizon:g} s horizon; a launch policy needs a planned "
                          "closing time")
    close = float(sim.closing_time)
    return (close if math.isnan(arrival) else min(arrival, close)), close


def launch_model(launch: LaunchConfig, sensing_period: int, dt: float, design, config,
                 inertia) -> LaunchModel:
    """The kernel's launch constants (``kernel.launch.LaunchModel``): decisions every
    ``rate_hz`` on whole sensing periods (``sensing_period`` steps of ``dt`` s); the
    window from the planned arrival of the net at the target's centre to the planned end
    of closing (:func:`planned_window`, then the closing policy's ``closing_time``);
    ``inertia``: the shape's principal moments (kg m^2)."""
    if launch.immediate:
        return immediate_launch()
    period = sensing_period * max(1, int(round(steps_every(launch.rate_hz, dt) / sensing_period)))
    start, close = planned_window(design, config)
    end = close + config.policy.closing_time
    return LaunchModel(policy=launch.index, period=period,
                       max_wait=int(round(launch.max_wait / dt)),
                       cos_limit=detmath.sin(launch.max_tilt_deg * math.pi / 180.0),
                       window_start=float(start), window_end=float(end),
                       inertia=np.ascontiguousarray(inertia, dtype=np.float64))

