"""Closing policies: when to start closing the net, decided from what the chaser senses
(``core.sensing``) at each measurement (docs/model.md §14).  A policy is its settings (a
field of :class:`PolicyConfig`) and one numba function, ``kernel.policy.decide``, which runs
inside the kernel at the kernel's speed, or is left to a controller outside it ('external':
a ROS node, a user's own).

- ``threshold`` (the source's rule): close when the sensed z_rel = z(net point) -
  z(target) reaches the closing displacement d_c (+ its noise).  With ideal sensing at
  every step it is the source's trigger, bit for bit.
- ``adaptive``: the same threshold measured from the target's far side instead of its
  centre.  From the sensed attitude and angular velocity it predicts, over the next
  ``closing_time`` seconds, the largest half-depth of the stage along the line of sight
  (e(a) = (L/2) |a_z| + R sqrt(1 - a_z^2) for its long axis a), and closes when z_rel
  reaches d_c + e_max - R: the margin by which the net passes beyond the stage is then the
  one d_c gives a stage lying across the line of sight (e = R).  It also closes at the
  net's apex (``apex``): when z_rel, already past the target's centre, stops growing
  between two measurements, since the net will not get any farther.
"""
from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import dataclass

import numpy as np

from .checks import declared_floats
from .kernel.policy import POLICIES, decide_one, new_policy_data

__all__ = ["POLICIES", "Policy", "PolicyConfig", "PolicyError"]


class PolicyError(ValueError):
    """A policy setting is outside its allowed range (message names the field)."""


@dataclass(frozen=True)
class PolicyConfig:
    """kind: one of ``POLICIES``; closing_time (s): the adaptive policy's horizon, the
    time the drawstring takes to close the mouth (docs/model.md §14 gives its source);
    apex: the adaptive policy also closes at the net's apex."""

    kind: str = "threshold"
    closing_time: float = 0.6
    apex: bool = True

    def __post_init__(self):
        declared_floats(self)
        if self.kind not in POLICIES:
            raise PolicyError(f"policy field 'kind': got {self.kind!r}; must be one of "
                              f"{', '.join(POLICIES)}")
        t = self.closing_time
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t) \
                or not 0.0 <= t <= 60.0:
            raise PolicyError(f"policy field 'closing_time': got {t!r}; must be a time in "
                              "[0, 60] s")
        if not isinstance(self.apex, bool):
            raise PolicyError(f"policy field 'apex': got {self.apex!r}; must be true or false")

    @property
    def index(self) -> int:
        return POLICIES.index(self.kind)


class Policy:
    """The closing policy of one episode outside the kernel (the ROS actuator node): the
    kernel's ``decide`` on its own memory, for the episode's model and closing
    displacement, so the same measurements give the same decision, bit for bit."""

    def __init__(self, model, close_threshold: float):
        self._model = namedtuple("PolicyModel", "control target")(model.control, model.target)
        self._data = namedtuple("PolicyLane", "close_threshold policy")(
            np.array([float(close_threshold)]), new_policy_data())

    def decide(self, meas: np.ndarray) -> bool:
        """Whether closing starts now, given the newest measurement."""
        return bool(decide_one(self._model, self._data, np.asarray(meas, dtype=np.float64)))
