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
(splitmix64, Steele, Lea and Flood, OOPSLA 2014) seeded with the episode's noise seed, and
turned into normal variates by the polar method (Marsaglia and Bray, SIAM Review 6, 1964)
with a logarithm in IEEE operations only (:func:`det_log`): the same bits on every
machine.  Units: SI; angles in the settings in deg.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

NET_POINTS = ("com", "centre", "corners", "com_corners")
TARGET_POSITIONS = ("sensed", "planned")
NET_COM, NET_CENTRE, NET_CORNERS, NET_COM_CORNERS = range(4)
TARGET_SENSED, TARGET_PLANNED = range(2)

#: channels of a measurement
C_NET, C_TGT, C_QUAT, C_OMEGA, C_VEL = 0, 3, 6, 10, 13
N_CHANNELS = 16

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
        if self.net_point not in NET_POINTS:
            raise SensingError(f"sensing field 'net_point': got {self.net_point!r}; must be one "
                               f"of {', '.join(NET_POINTS)}")
        if self.target_position not in TARGET_POSITIONS:
            raise SensingError(f"sensing field 'target_position': got {self.target_position!r};"
                               f" must be one of {', '.join(TARGET_POSITIONS)}")
        for name, (lo, hi, what) in _LIMITS.items():
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                    or not lo <= v <= hi:
                raise SensingError(f"sensing field '{name}': got {v!r}; must be {what}")

    @property
    def noiseless(self) -> bool:
        return not (self.sigma_position or self.sigma_attitude_deg or self.sigma_rate_deg_s
                    or self.sigma_velocity)

    def period_steps(self, dt: float) -> int:
        """Steps between measurements (at least 1)."""
        from .episode import steps_every
        return 1 if self.rate_hz == 0 else steps_every(self.rate_hz, dt)

    def latency_steps(self, dt: float) -> int:
        return int(round(self.latency / dt))


# --- deterministic random numbers -------------------------------------------------------
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, _S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11)
_LN2 = 0.6931471805599453
_SQRT_HALF = 0.7071067811865476


@njit(cache=True, inline='always')
def next_uniform(state, l) -> float:
    """The next uniform in [0, 1) of lane l's splitmix64 generator (k / 2^53)."""
    z = state[l] + _GOLDEN
    state[l] = z
    z = (z ^ (z >> _S30)) * _MIX1
    z = (z ^ (z >> _S27)) * _MIX2
    z = z ^ (z >> _S31)
    return float(z >> _S11) * (1.0 / 9007199254740992.0)


@njit(cache=True, inline='always')
def det_log(x: float) -> float:
    """Natural logarithm of x > 0 in IEEE operations only: x = m 2^e with m in
    [1/sqrt 2, sqrt 2) by exact halvings and doublings, log m = 2 atanh(t) with
    t = (m - 1) / (m + 1), |t| < 0.172, by its series to t^27 (error below 1e-17)."""
    m = x
    e = 0
    while m >= 1.4142135623730951:
        m *= 0.5
        e += 1
    while m < _SQRT_HALF:
        m *= 2.0
        e -= 1
    t = (m - 1.0) / (m + 1.0)
    t2 = t * t
    s = 1.0 / 27.0
    for k in range(25, 0, -2):
        s = s * t2 + 1.0 / k
    return e * _LN2 + 2.0 * t * s


@njit(cache=True, inline='always')
def next_normal(state, l) -> float:
    """A standard normal variate of lane l's generator (polar method)."""
    while True:
        u = 2.0 * next_uniform(state, l) - 1.0
        v = 2.0 * next_uniform(state, l) - 1.0
        s = u * u + v * v
        if 0.0 < s < 1.0:
            return u * np.sqrt(-2.0 * det_log(s) / s)


def seed_state(seed: int | None) -> int:
    """The generator's initial state of an episode (its noise seed; 0 when nominal)."""
    return 0 if seed is None else int(seed) % (1 << 64)


# --- measurement ------------------------------------------------------------------------
@njit(cache=True, inline='always', error_model='numpy')
def truth_into(model, data, l, out):
    """The true measurement of lane l into out (N_CHANNELS,)."""
    ct = model.control
    x = data.bodies.x
    nodes = ct.ref_nodes
    wts = ct.ref_weights
    xs = 0.0
    ys = 0.0
    zs = 0.0
    for k in range(nodes.shape[0]):
        b = nodes[k]
        xs += wts[k] * x[b, 0, l]
        ys += wts[k] * x[b, 1, l]
        zs += wts[k] * x[b, 2, l]
    out[C_NET] = xs / ct.ref_total
    out[C_NET + 1] = ys / ct.ref_total
    out[C_NET + 2] = zs / ct.ref_total
    tg = data.target
    for c in range(3):
        out[C_TGT + c] = tg.pos[c, l]
        out[C_OMEGA + c] = tg.omega[c, l]
        out[C_VEL + c] = tg.vel[c, l]
    for c in range(4):
        out[C_QUAT + c] = tg.quat[c, l]
    if ct.target_position == TARGET_PLANNED:
        out[C_TGT] = 0.0
        out[C_TGT + 1] = 0.0
        out[C_TGT + 2] = ct.planned_z


@njit(cache=True, inline='always', error_model='numpy')
def add_noise(ct, state, l, out):
    """Add the sensor noise of ``ct`` (the model's control settings) to a measurement."""
    if ct.sigma_position > 0.0:
        for c in range(3):
            out[C_NET + c] += ct.sigma_position * next_normal(state, l)
        if ct.target_position == TARGET_SENSED:
            for c in range(3):
                out[C_TGT + c] += ct.sigma_position * next_normal(state, l)
    if ct.sigma_attitude > 0.0:
        hx = 0.5 * ct.sigma_attitude * next_normal(state, l)
        hy = 0.5 * ct.sigma_attitude * next_normal(state, l)
        hz = 0.5 * ct.sigma_attitude * next_normal(state, l)
        w, x, y, z = out[C_QUAT], out[C_QUAT + 1], out[C_QUAT + 2], out[C_QUAT + 3]
        nw = w - x * hx - y * hy - z * hz
        nx = x + w * hx + y * hz - z * hy
        ny = y - x * hz + w * hy + z * hx
        nz = z + x * hy - y * hx + w * hz
        n = np.sqrt(nw * nw + nx * nx + ny * ny + nz * nz)
        out[C_QUAT] = nw / n
        out[C_QUAT + 1] = nx / n
        out[C_QUAT + 2] = ny / n
        out[C_QUAT + 3] = nz / n
    if ct.sigma_rate > 0.0:
        for c in range(3):
            out[C_OMEGA + c] += ct.sigma_rate * next_normal(state, l)
    if ct.sigma_velocity > 0.0:
        for c in range(3):
            out[C_VEL + c] += ct.sigma_velocity * next_normal(state, l)


@njit(cache=True, inline='always', error_model='numpy')
def buffer_measurement(ct, sd, l, out, step) -> int:
    """Add noise to the true measurement ``out`` taken at ``step``, store it in lane l's
    sensor buffer ``sd``; return the slot of the newest measurement the controller has by
    now (taken at least the latency ago), or -1 if none has arrived yet."""
    add_noise(ct, sd.rng, l, out)
    slot = sd.head[l]
    for c in range(out.shape[0]):
        sd.buf[slot, c, l] = out[c]
    sd.taken[slot, l] = step
    sd.head[l] = (slot + 1) % sd.taken.shape[0]
    best = -1
    best_step = -1
    for s in range(sd.taken.shape[0]):
        t = sd.taken[s, l]
        if t >= 0 and t + ct.latency <= step and t > best_step:
            best = s
            best_step = t
    return best


@njit(cache=True, error_model='numpy')
def _truth_of_lane(model, data, l):
    out = np.zeros(N_CHANNELS)
    truth_into(model, data, l, out)
    return out


@njit(cache=True, error_model='numpy')
def _measure_one(ct, sd, truth, step):
    out = truth.copy()
    slot = buffer_measurement(ct, sd, 0, out, step)
    if slot < 0:
        return np.full(N_CHANNELS, np.nan)
    return sd.buf[slot, :, 0].copy()


def true_measurement(model, data, lane: int) -> np.ndarray:
    """The true measurement (N_CHANNELS,) of one lane now (what an ideal sensor gives)."""
    return _truth_of_lane(model, data, lane)


class Sensor:
    """The sensor of one episode outside the kernel (the ROS sensor node): the same noise,
    buffer and latency as the kernel's for the same control settings and seed, so the
    same true measurements give the same sensed ones, bit for bit."""

    def __init__(self, control, seed_state_: int):
        from .kernel.data import SensorData

        self.control = control
        slots = control.latency // control.period + 2
        self.state = SensorData(rng=np.array([seed_state_], dtype=np.uint64),
                                buf=np.zeros((slots, N_CHANNELS, 1)),
                                taken=np.full((slots, 1), -1, dtype=np.int64),
                                head=np.zeros(1, dtype=np.int64))

    def measure(self, truth: np.ndarray, step: int) -> np.ndarray | None:
        """The measurement the controller has at ``step`` after a true measurement taken
        then (None until the first has arrived)."""
        out = _measure_one(self.control, self.state, np.asarray(truth, dtype=np.float64),
                           int(step))
        return None if np.isnan(out[0]) else out
