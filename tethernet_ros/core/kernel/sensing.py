"""The sensor inside the kernel (docs/model.md §14; its settings and the sensor outside the
kernel are ``core.sensing``): the true measurement of a lane, its noise, and the buffer
that delays it by the latency.

A measurement is a vector of ``N_CHANNELS`` numbers: the net's reference point (m), the
target's position (m; or the planned one), its attitude quaternion (w, x, y, z), world
angular velocity (rad/s) and velocity (m/s).  The noise is Gaussian, drawn from a per-lane
counter-based generator (splitmix64, Steele, Lea and Flood, OOPSLA 2014) turned into normal
variates by the polar method (Marsaglia and Bray, SIAM Review 6, 1964) with a logarithm in
IEEE operations only (:func:`det_log`): the same bits on every machine.  Units: SI.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

#: where the chaser takes the target to be (ControlModel.target_position is the index)
TARGET_POSITIONS = ("sensed", "planned")
TARGET_SENSED, TARGET_PLANNED = range(2)

#: channels of a measurement
C_NET, C_TGT, C_QUAT, C_OMEGA, C_VEL = 0, 3, 6, 10, 13
N_CHANNELS = 16

#: The sensor's per-lane data (``data.Data.sensor``): rng (K,) uint64 its generator's
#: state; buf (B, C, K) the last B measurements, taken (B, K) the step each was taken at
#: (-1: none), head (K,) the slot of the next one.
SensorData = namedtuple("SensorData", "rng buf taken head")


def sensor_slots(control) -> int:
    """Measurements the buffer holds for the control settings ``control`` (ControlModel):
    enough for the latency plus the newest."""
    return control.latency // control.period + 2


def new_sensor_data(slots: int, seed_state_: int) -> SensorData:
    """A one-lane sensor: ``slots`` empty measurements, the generator at ``seed_state_``."""
    return SensorData(rng=np.array([seed_state_], dtype=np.uint64),
                      buf=np.zeros((slots, N_CHANNELS, 1)),
                      taken=np.full((slots, 1), -1, dtype=np.int64),
                      head=np.zeros(1, dtype=np.int64))


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
def truth_of_lane(model, data, l):
    out = np.zeros(N_CHANNELS)
    truth_into(model, data, l, out)
    return out


@njit(cache=True, error_model='numpy')
def measure_one(ct, sd, truth, step):
    """The sensed measurement (N_CHANNELS,) a one-lane sensor gives at ``step`` after the
    true one taken then, then the step it was taken at; NaNs and -1 before the first has
    arrived."""
    out = truth.copy()
    slot = buffer_measurement(ct, sd, 0, out, step)
    got = np.full(N_CHANNELS + 1, np.nan)
    got[N_CHANNELS] = -1.0
    if slot >= 0:
        got[:N_CHANNELS] = sd.buf[slot, :, 0]
        got[N_CHANNELS] = float(sd.taken[slot, 0])
    return got
