"""Launch policies: when the chaser fires its one-shot net, decided from what it senses of
the tumbling target (docs/model.md §16).  A policy is its settings (:class:`LaunchConfig`)
and one numba function, ``kernel.launch.decide_launch``, which runs inside the kernel while
the lane waits, or is left to a controller outside it ('external').

- ``immediate`` (the default): fire at once, as every result before launch policies did.
- ``predictive``: at each decision, predict by torque-free rotation, from the sensed
  attitude and angular velocity and the inertia of the target's shape, the attitude over
  the window in which the net wraps the target (from the moment the net's centre of mass
  is planned to reach the target's centre to the end of closing), and fire once the long
  axis has been predicted, at every measurement for ``confirm_time``, to stay within
  ``max_tilt_deg`` of the plane across the line of sight all through it.
  The tumbling study (docs/studies/tumbling.md) found the net fails on a stage met end-on.
- ``external``: a controller outside the kernel fires (the ROS suite's launch controller).

Whatever the policy, the chaser fires once ``max_wait`` s have passed.  The episode's
times (closing, completion T) count from the first moment the chaser could have fired, so
waiting costs Case 2's objective honestly.  Units: SI; angles in the settings in deg.
"""
from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import asdict, dataclass

import numpy as np

from . import detmath
from .checks import check_choice, check_numbers, declared_floats, finite_numbers
from .kernel.launch import LAUNCH_POLICIES, LaunchModel, decide_launch_one, immediate_launch
from .kernel.policy_table import KERNEL, NONE, spec
from .kernel.sensing import N_CHANNELS

__all__ = ["LAUNCH_POLICIES", "LaunchConfig", "LaunchError", "LaunchPolicy", "launch_model"]

#: (low, high, words) of the numeric settings
_LIMITS = {
    "max_wait": (0.0, 3600.0, "a time in [0, 3600] s"),
    "max_tilt_deg": (0.1, 90.0, "an angle in [0.1, 90] deg"),
    "confirm_time": (0.0, 60.0, "a time in [0, 60] s"),
}


#: the largest aim offset along x or y (m): about the Zenit-2's length (10.4 m), twice its
#: half-length, beyond which a net aimed there meets nothing of a stage its size
MAX_AIM_OFFSET = 10.0


class LaunchError(ValueError):
    """A launch setting is outside its allowed range (message names the field)."""


@dataclass(frozen=True)
class LaunchConfig:
    """kind: one of ``LAUNCH_POLICIES``; max_wait (s): the chaser fires by then whatever the
    policy says (default 360 s: half a turn at 0.5 deg/s, the slowest tumble studied, so a
    flat spin shows every attitude within it); max_tilt_deg: the largest angle between the
    long axis and the plane across the line of sight the predictive policy accepts
    (default 30 deg, |a_z| <= 0.5: the bin in which the tumbling study's Case choices
    captured 57-59 of 59 samples); confirm_time (s): the predictive policy fires once the
    attitude has been found favourable at every measurement for this long (default 1 s:
    with noisy sensing the first measurement below the limit comes early, a noise dip,
    docs/model.md §16).  The policy decides at every measurement (the sensing rate,
    ``core.sensing``), as the closing policy does.  aim_offset (m): (x, y), the point
    the chaser aims its net at, beside the target's centre across the line of sight
    (default (0, 0): at the centre; each in [-MAX_AIM_OFFSET, MAX_AIM_OFFSET]); whatever
    the policy, the net flies along the line of sight and the target's centre sits at
    -aim_offset from it (docs/model.md §16)."""

    kind: str = "immediate"
    max_wait: float = 360.0
    max_tilt_deg: float = 30.0
    confirm_time: float = 1.0
    aim_offset: tuple = (0.0, 0.0)

    def __post_init__(self):
        declared_floats(self)
        check_choice("launch", "kind", self.kind, LAUNCH_POLICIES, LaunchError)
        check_numbers("launch", self, _LIMITS, LaunchError)
        v = self.aim_offset
        t = finite_numbers(v)
        if t is None or len(t) != 2 or not all(abs(c) <= MAX_AIM_OFFSET for c in t):
            raise LaunchError(f"launch field 'aim_offset': got {v!r}; must be 2 numbers "
                              f"(x, y) in [-{MAX_AIM_OFFSET:g}, {MAX_AIM_OFFSET:g}] m")
        object.__setattr__(self, "aim_offset", t)

    def to_dict(self) -> dict:
        """The settings as plain values; an aim at the centre is left out, so that the
        configurations before the aim offset keep their run keys."""
        d = asdict(self)
        d["aim_offset"] = list(self.aim_offset)
        if not any(self.aim_offset):
            del d["aim_offset"]
        return d

    @property
    def index(self) -> int:
        return LAUNCH_POLICIES.index(self.kind)

    @property
    def immediate(self) -> bool:
        """Whether there is nothing to decide: the chaser fires at once."""
        return spec("launch", self.kind).decider == NONE

    @property
    def built_in(self) -> bool:
        """Whether the chaser waits and a policy of the project decides (not 'immediate'
        nor 'external'): the kernel's, or its copy outside the kernel."""
        return spec("launch", self.kind).decider == KERNEL


def launch_model(launch: LaunchConfig, dt: float, window, inertia) -> LaunchModel:
    """The kernel's launch constants (``kernel.launch.LaunchModel``) for a step of ``dt``
    s: the prediction's ``window`` (start, end) (s after the launch: the planned arrival of the
    net at the target's centre and the planned end of closing,
    ``scenario.planned_window``; None for a policy that predicts nothing, 'external');
    ``inertia``: the shape's principal moments (kg m^2)."""
    if launch.immediate:
        return immediate_launch()
    start, end = (0.0, 0.0) if window is None else window
    return LaunchModel(policy=launch.index,
                       max_wait=int(round(launch.max_wait / dt)),
                       cos_limit=detmath.sin(launch.max_tilt_deg * math.pi / 180.0),
                       confirm=int(round(launch.confirm_time / dt)),
                       window_start=float(start), window_end=float(end),
                       inertia=np.ascontiguousarray(inertia, dtype=np.float64))


class LaunchPolicy:
    """The launch policy of one episode outside the kernel (the ROS actuator node): the
    kernel's ``decide_launch`` for the episode's launch constants (``launch`` of its
    model, built with the episode's own configuration), so the same measurements give the
    same decision, bit for bit."""

    def __init__(self, launch: LaunchModel):
        self._model = namedtuple("LaunchPolicyModel", "launch")(launch)
        self._since = np.full(1, -1, dtype=np.int64)     # the kernel's E_FAVOURABLE_SINCE

    def decide(self, meas: np.ndarray | None, age: float, step: int) -> bool:
        """Whether to fire at ``step`` (the mission's clock), given the newest measurement
        (None: none has arrived yet), taken ``age`` s ago."""
        valid = meas is not None
        values = np.asarray(meas if valid else np.zeros(N_CHANNELS), dtype=np.float64)
        return bool(decide_launch_one(self._model, self._since, valid, values, float(age),
                                      int(step)))
