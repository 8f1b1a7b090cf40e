"""What the chaser senses (docs/model.md §14): the target's pose and twist and the net's
position, at a rate, with a latency and noise.  The default is ideal: every step, no
latency, no noise, the net's centre of mass against the target's, which is exactly the
quantity the source's closing trigger reads.

A measurement is a vector of ``N_CHANNELS`` numbers: the net's reference point (m), the
target's position (m; or where the chaser believes it is), its attitude quaternion
(w, x, y, z), world angular velocity (rad/s) and velocity (m/s).  The net's reference
point is one of ``NET_POINTS``: the centre of mass of the grid nodes ('com', the
source's), the centre node, the centroid of the four corner masses, or the centre of mass
of the grid nodes and corner masses.  The chaser takes the target's position as sensed,
or as the planned distance d_L on the line of sight ('planned', which the distance noise
then makes wrong).

The noise is Gaussian, drawn inside the kernel from a per-episode counter-based generator
seeded with the episode's noise seed: the same bits on every machine.  The numba parts
(measurement, noise, buffer, generator) are ``kernel.sensing``; this module holds the
settings and the sensor outside the kernel, and names the measurement's channels for its
users.  Units: SI; angles in the settings in deg.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .checks import check_choice, check_numbers, declared_floats
from .kernel.model import steps_every
from .kernel.sensing import (C_NET, C_OMEGA, C_QUAT, C_TGT, C_VEL, N_CHANNELS, TARGET_POSITIONS,
                             det_log, measure_one, new_sensor_data, next_normal, next_uniform,
                             seed_state, sensor_slots, truth_of_lane)

__all__ = ["C_NET", "C_OMEGA", "C_QUAT", "C_TGT", "C_VEL", "N_CHANNELS", "NET_POINTS",
           "TARGET_POSITIONS", "SensingConfig", "SensingError", "Sensor", "det_log",
           "next_normal", "next_uniform", "seed_state", "true_measurement"]

NET_POINTS = ("com", "centre", "corners", "com_corners")
NET_COM, NET_CENTRE, NET_CORNERS, NET_COM_CORNERS = range(4)

#: (low, high, words) of the numeric settings
_LIMITS = {
    "rate_hz": (0.0, 1000.0, "a rate in [0, 1000] Hz (0: every step)"),
    "latency": (0.0, 5.0, "a latency in [0, 5] s"),
    "sigma_position": (0.0, 10.0, "a standard deviation in [0, 10] m"),
    "sigma_attitude_deg": (0.0, 90.0, "a standard deviation in [0, 90] deg"),
    "sigma_rate_deg_s": (0.0, 60.0, "a standard deviation in [0, 60] deg/s"),
    "sigma_velocity": (0.0, 10.0, "a standard deviation in [0, 10] m/s"),
}


class SensingError(ValueError):
    """A sensing setting is outside its allowed range (message names the field)."""


@dataclass(frozen=True)
class SensingConfig:
    """net_point: the net's reference point (``NET_POINTS``); target_position: 'sensed' or
    'planned'; rate_hz: measurements per second (0: every step); latency (s): a measurement
    reaches the controller this long after it was taken; sigma_position (m, net point and
    target position, per axis), sigma_attitude_deg (a random small rotation, per axis),
    sigma_rate_deg_s (angular velocity, per axis), sigma_velocity (m/s, per axis)."""

    net_point: str = "com"
    target_position: str = "sensed"
    rate_hz: float = 0.0
    latency: float = 0.0
    sigma_position: float = 0.0
    sigma_attitude_deg: float = 0.0
    sigma_rate_deg_s: float = 0.0
    sigma_velocity: float = 0.0

    def __post_init__(self):
        declared_floats(self)
        check_choice("sensing", "net_point", self.net_point, NET_POINTS, SensingError)
        check_choice("sensing", "target_position", self.target_position, TARGET_POSITIONS,
                     SensingError)
        check_numbers("sensing", self, _LIMITS, SensingError)

    @property
    def noiseless(self) -> bool:
        return not (self.sigma_position or self.sigma_attitude_deg or self.sigma_rate_deg_s
                    or self.sigma_velocity)

    def period_steps(self, dt: float) -> int:
        """Steps between measurements (at least 1)."""
        return 1 if self.rate_hz == 0 else steps_every(self.rate_hz, dt)

    def latency_steps(self, dt: float) -> int:
        return int(round(self.latency / dt))


def true_measurement(model, data, lane: int) -> np.ndarray:
    """The true measurement (N_CHANNELS,) of one lane now (what an ideal sensor gives)."""
    return truth_of_lane(model, data, lane)


class Sensor:
    """The sensor of one episode outside the kernel (the ROS sensor node): the same noise,
    buffer and latency as the kernel's for the same control settings and seed, so the
    same true measurements give the same sensed ones, bit for bit."""

    def __init__(self, control, seed_state_: int):
        self.control = control
        self.state = new_sensor_data(sensor_slots(control), seed_state_)
        #: the step the last measurement returned was taken at (-1: none yet)
        self.taken = -1

    def measure(self, truth: np.ndarray, step: int) -> np.ndarray | None:
        """The measurement the controller has at ``step`` (the mission's clock,
        ``kernel.measure``) after a true measurement taken then (None until the first has
        arrived); its ``taken`` says when it was taken."""
        got = measure_one(self.control, self.state, np.asarray(truth, dtype=np.float64), int(step))
        self.taken = int(got[N_CHANNELS])
        return None if self.taken < 0 else got[:N_CHANNELS].copy()

    def age(self, step: int, dt: float) -> float:
        """How old (s) the last measurement returned is at ``step``, for a step of ``dt``
        s, as the kernel's launch wait reckons it; 0 before the first has arrived."""
        return 0.0 if self.taken < 0 else (int(step) - self.taken) * dt
