"""The closed loop: Measurement.msg, ClosingDecision.msg, LaunchDecision.msg and the sensed
common_interfaces messages."""
from __future__ import annotations

import math
import numpy as np

from ...core.sensing import C_NET, C_OMEGA, C_QUAT, C_TGT, C_VEL, N_CHANNELS, SensingConfig
from .stamps import set_time


def measurement_msg(values, step: int, sim_time: float, episode_id: str,
                    closing_displacement: float, frame_id: str = "chaser",
                    launched: bool = True, age: float = 0.0):
    """Measurement of a core measurement vector (``core.sensing``, N_CHANNELS; None: none
    has reached the controller yet, ``valid`` false) at the control step ``step`` of the
    mission's clock (sim time s), before the launch or after it (``launched``), its values
    taken ``age`` s before."""
    from tethernet_msgs.msg import Measurement

    m = Measurement()
    set_time(m.header.stamp, sim_time)
    m.header.frame_id = frame_id
    m.episode_id = episode_id
    m.step = int(step)
    m.launched = bool(launched)
    m.age = float(age)
    m.closing_displacement = float(closing_displacement)
    m.valid = values is not None
    if values is None:
        m.target_orientation.w = 0.0
        return m
    v = [float(x) for x in values]
    m.net_point.x, m.net_point.y, m.net_point.z = v[C_NET:C_NET + 3]
    m.target_position.x, m.target_position.y, m.target_position.z = v[C_TGT:C_TGT + 3]
    q = m.target_orientation
    q.w, q.x, q.y, q.z = v[C_QUAT:C_QUAT + 4]
    w = m.target_angular_velocity
    w.x, w.y, w.z = v[C_OMEGA:C_OMEGA + 3]
    u = m.target_velocity
    u.x, u.y, u.z = v[C_VEL:C_VEL + 3]
    return m


def measurement_from_msg(m) -> np.ndarray | None:
    """The core's measurement vector (N_CHANNELS,) of a Measurement (None if not valid);
    the same bits as were sent."""
    if not m.valid:
        return None
    out = np.empty(N_CHANNELS)
    p, t, q = m.net_point, m.target_position, m.target_orientation
    w, u = m.target_angular_velocity, m.target_velocity
    out[C_NET:C_NET + 3] = (p.x, p.y, p.z)
    out[C_TGT:C_TGT + 3] = (t.x, t.y, t.z)
    out[C_QUAT:C_QUAT + 4] = (q.w, q.x, q.y, q.z)
    out[C_OMEGA:C_OMEGA + 3] = (w.x, w.y, w.z)
    out[C_VEL:C_VEL + 3] = (u.x, u.y, u.z)
    return out


def decision_msg(measurement, close: bool, controller: str):
    """ClosingDecision answering a Measurement (same stamp, episode and step)."""
    from tethernet_msgs.msg import ClosingDecision

    return _answer(ClosingDecision(), measurement, controller, close=bool(close))


def launch_decision_msg(measurement, launch: bool, controller: str):
    """LaunchDecision answering a Measurement taken before the launch (same stamp, episode
    and step)."""
    from tethernet_msgs.msg import LaunchDecision

    return _answer(LaunchDecision(), measurement, controller, launch=bool(launch))


def _answer(m, measurement, controller: str, **decision):
    """``m`` (a decision message) answering ``measurement``: its header, episode and step,
    the decision's field, who decided."""
    m.header = measurement.header
    m.episode_id = measurement.episode_id
    m.step = measurement.step
    for k, v in decision.items():
        setattr(m, k, v)
    m.controller = controller
    return m


def _diagonal(variances: list[float]) -> list[float]:
    n = len(variances)
    out = [0.0] * (n * n)
    for i, v in enumerate(variances):
        out[i * n + i] = float(v)
    return out


def sensed_msgs(values, sim_time: float, sensing: SensingConfig, frame_id: str = "chaser"):
    """(PoseWithCovarianceStamped of the target, TwistWithCovarianceStamped of the target,
    PointStamped of the net's reference point) of a sensed measurement vector.  The
    covariances are the sensor's noise (``sensing.sigma_*``): position sigma_position^2
    per axis (0 for a 'planned' target position, which is no measurement), attitude
    sigma_attitude^2 (rad^2) per axis of the small rotation, velocity sigma_velocity^2 and
    angular velocity sigma_rate^2 ((rad/s)^2) per axis; no correlations."""
    from geometry_msgs.msg import PointStamped, PoseWithCovarianceStamped, \
        TwistWithCovarianceStamped

    deg = math.pi / 180.0
    v = [float(x) for x in values]
    pose = PoseWithCovarianceStamped()
    twist = TwistWithCovarianceStamped()
    point = PointStamped()
    for m in (pose, twist, point):
        set_time(m.header.stamp, sim_time)
        m.header.frame_id = frame_id
    p, q = pose.pose.pose.position, pose.pose.pose.orientation
    p.x, p.y, p.z = v[C_TGT:C_TGT + 3]
    q.w, q.x, q.y, q.z = v[C_QUAT:C_QUAT + 4]
    sp = sensing.sigma_position ** 2 if sensing.target_position == "sensed" else 0.0
    sa = (sensing.sigma_attitude_deg * deg) ** 2
    pose.pose.covariance = _diagonal([sp, sp, sp, sa, sa, sa])
    lin, ang = twist.twist.twist.linear, twist.twist.twist.angular
    lin.x, lin.y, lin.z = v[C_VEL:C_VEL + 3]
    ang.x, ang.y, ang.z = v[C_OMEGA:C_OMEGA + 3]
    sv, sr = sensing.sigma_velocity ** 2, (sensing.sigma_rate_deg_s * deg) ** 2
    twist.twist.covariance = _diagonal([sv, sv, sv, sr, sr, sr])
    point.point.x, point.point.y, point.point.z = v[C_NET:C_NET + 3]
    return pose, twist, point
