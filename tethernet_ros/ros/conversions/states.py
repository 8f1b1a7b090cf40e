"""NetState.msg, the target's PoseStamped and the clock from and to the kernel's state."""
from __future__ import annotations

import array
import numpy as np

from ..state import StateArrays
from .stamps import set_time


def _vec(v) -> np.ndarray:
    return np.array([v.x, v.y, v.z], dtype=float)


def net_state_msg(state: StateArrays, frame_id: str = "chaser"):
    """NetState of a state snapshot (header stamp: sim time)."""
    from tethernet_msgs.msg import NetState

    m = NetState()
    set_time(m.header.stamp, state.sim_time)
    m.header.frame_id = frame_id
    m.sim_time = state.sim_time
    m.step = state.step
    m.launch_step = int(state.launch_step)
    m.positions = array.array("d", np.ascontiguousarray(state.positions).tobytes())
    m.velocities = array.array("d", np.ascontiguousarray(state.velocities).tobytes())
    m.num_net_nodes = state.num_net_nodes
    m.num_corner_masses = state.num_corner_masses
    m.num_tether_nodes = len(state.positions) - state.num_net_nodes - state.num_corner_masses
    p, q = m.target_pose.position, m.target_pose.orientation
    p.x, p.y, p.z = (float(v) for v in state.target_position)
    q.w, q.x, q.y, q.z = (float(v) for v in state.target_quaternion)
    lin, ang = m.target_twist.linear, m.target_twist.angular
    lin.x, lin.y, lin.z = (float(v) for v in state.target_velocity)
    ang.x, ang.y, ang.z = (float(v) for v in state.target_omega)
    m.closing_active = bool(state.closing_active)
    m.closing_start_time = float(state.closing_start_time)
    m.locked = [bool(v) for v in state.locked]
    return m


def net_state_from_msg(m) -> StateArrays:
    pos = np.asarray(m.positions, dtype=float)
    vel = np.asarray(m.velocities, dtype=float)
    q = m.target_pose.orientation
    return StateArrays(
        step=int(m.step), sim_time=float(m.sim_time),
        positions=pos.reshape(-1, 3), velocities=vel.reshape(-1, 3),
        target_position=_vec(m.target_pose.position),
        target_quaternion=np.array([q.w, q.x, q.y, q.z], dtype=float),
        target_velocity=_vec(m.target_twist.linear), target_omega=_vec(m.target_twist.angular),
        closing_active=bool(m.closing_active), closing_start_time=float(m.closing_start_time),
        locked=np.array([bool(v) for v in m.locked], dtype=bool),
        num_net_nodes=int(m.num_net_nodes), num_corner_masses=int(m.num_corner_masses),
        launch_step=int(getattr(m, "launch_step", 0)))


def target_pose_msg(state: StateArrays, frame_id: str = "chaser"):
    """PoseStamped of the target's centre of mass (m) and attitude (header stamp: sim time)."""
    from geometry_msgs.msg import PoseStamped

    m = PoseStamped()
    set_time(m.header.stamp, state.sim_time)
    m.header.frame_id = frame_id
    m.pose.position.x, m.pose.position.y, m.pose.position.z = \
        (float(v) for v in state.target_position)
    o = m.pose.orientation
    o.w, o.x, o.y, o.z = (float(v) for v in state.target_quaternion)
    return m


def clock_msg(t: float):
    """rosgraph_msgs/Clock at sim time ``t`` (s)."""
    from rosgraph_msgs.msg import Clock

    m = Clock()
    set_time(m.clock, t)
    return m
