"""visualization_msgs/MarkerArray of a capture, for Foxglove / RViz (frame ``chaser``, m)."""
from __future__ import annotations

import math

import numpy as np

from .conversions import set_time
from .state import StateArrays


class MarkerBuilder:
    """visualization_msgs/MarkerArray of a scenario, in frame ``frame_id``:

    net_rows, net_columns   LINE_STRIPs snaking through the grid by rows and by columns:
                            together every grid thread (edge threads twice), 2 x 289 points
    corner_threads          LINE_LIST, net corner -> corner mass
    closing_ring            LINE_LIST of the 12 drawstring pairs, green when locked
    corner_masses           SPHERE_LIST
    main_tether             LINE_STRIP, net centre -> winch
    target                  the target at its pose, so it turns as it tumbles: the Zenit-2
                            stage a CYLINDER (its long axis the body x), a mesh target
                            a TRIANGLE_LIST of its body-frame triangles
    chaser                  CUBE behind the launch point
    target_spin             ARROW from the target's centre along its angular velocity
                            (right-hand rule), 2 m longer than the target's bounding
                            radius; no length at rest

    Topology is taken once from the Scenario; positions on every call."""

    def __init__(self, scenario, frame_id: str = "chaser"):
        s = scenario
        self.frame_id = frame_id
        n = s.grid.n
        grid = np.arange(n * n).reshape(n, n)          # node (i, j) = n i + j
        rows = [grid[i] if i % 2 == 0 else grid[i, ::-1] for i in range(n)]
        cols = [grid[:, j] if j % 2 == 0 else grid[::-1, j] for j in range(n)]
        self.row_snake = np.concatenate(rows)
        self.col_snake = np.concatenate(cols)
        net = set(int(i) for i in s.net_nodes)
        corners = set(int(i) for i in s.corner_bodies)
        self.corner_threads = np.array([(a, b) for a, b in s.links.pairs.tolist()
                                        if (a in net and b in corners) or (b in net and a in corners)],
                                       dtype=np.int64).reshape(-1, 2)
        self.tether_chain = np.array([s.tether.centre, *s.tether.nodes, s.tether.winch])
        self.ring_pairs = s.drawstring.pairs
        self.corners = s.corner_bodies
        self.winch = s.tether.winch
        tc = s.config.target
        shape = s.target
        if shape.kind == "revolution":
            self.target_scale = (tc.diameter, tc.diameter, tc.length)
            self.target_triangles = None
            self.spin_arrow = tc.length / 2 + 2.0
        else:
            self.target_scale = (1.0, 1.0, 1.0)
            self.target_triangles = np.asarray(shape.vertices)[np.asarray(shape.faces)].reshape(-1, 3)
            self.spin_arrow = shape.bounding_radius + 2.0
        self.chaser_side = s.config.chaser_side

    @staticmethod
    def _points(xyz):
        from geometry_msgs.msg import Point

        return [Point(x=a, y=b, z=c) for a, b, c in xyz.tolist()]

    def build(self, state: StateArrays):
        """MarkerArray of a state snapshot (:func:`~.state.state_arrays`)."""
        from std_msgs.msg import ColorRGBA
        from visualization_msgs.msg import Marker, MarkerArray

        x = state.positions
        out = MarkerArray()

        def marker(ns, mid, mtype, rgba, scale):
            mk = Marker()
            set_time(mk.header.stamp, state.sim_time)
            mk.header.frame_id = self.frame_id
            mk.ns, mk.id, mk.type, mk.action = ns, mid, mtype, Marker.ADD
            mk.pose.orientation.w = 1.0
            mk.scale.x, mk.scale.y, mk.scale.z = scale
            mk.color = ColorRGBA(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3])
            out.markers.append(mk)
            return mk

        yellow = (0.9, 0.9, 0.2, 1.0)
        marker("net_rows", 0, Marker.LINE_STRIP, yellow, (0.03, 0.0, 0.0)).points = \
            self._points(x[self.row_snake])
        marker("net_columns", 1, Marker.LINE_STRIP, yellow, (0.03, 0.0, 0.0)).points = \
            self._points(x[self.col_snake])
        marker("corner_threads", 2, Marker.LINE_LIST, yellow, (0.03, 0.0, 0.0)).points = \
            self._points(x[self.corner_threads].reshape(-1, 3))
        mk = marker("closing_ring", 3, Marker.LINE_LIST, (1.0, 0.2, 0.2, 1.0), (0.08, 0.0, 0.0))
        mk.points = self._points(x[self.ring_pairs].reshape(-1, 3))
        green, red = ColorRGBA(r=0.1, g=0.9, b=0.1, a=1.0), ColorRGBA(r=1.0, g=0.2, b=0.2, a=1.0)
        mk.colors = [green if lk else red for lk in state.locked for _ in (0, 1)]
        marker("corner_masses", 4, Marker.SPHERE_LIST, (0.2, 0.4, 1.0, 1.0), (0.3, 0.3, 0.3)).points = \
            self._points(x[self.corners])
        marker("main_tether", 5, Marker.LINE_STRIP, (0.8, 0.8, 0.8, 1.0), (0.03, 0.0, 0.0)).points = \
            self._points(x[self.tether_chain])
        kind = Marker.CYLINDER if self.target_triangles is None else Marker.TRIANGLE_LIST
        mk = marker("target", 6, kind, (0.6, 0.6, 0.65, 0.8), self.target_scale)
        p, o = mk.pose.position, mk.pose.orientation
        p.x, p.y, p.z = (float(v) for v in state.target_position)
        if self.target_triangles is None:
            # the cylinder marker's axis is its local z; the stage's long axis is body x
            o.w, o.x, o.y, o.z = _quat_mul(state.target_quaternion,
                                           (math.sqrt(0.5), 0.0, math.sqrt(0.5), 0.0))
        else:
            o.w, o.x, o.y, o.z = (float(v) for v in state.target_quaternion)
            mk.points = self._points(self.target_triangles)
        mk = marker("chaser", 7, Marker.CUBE, (0.3, 0.3, 0.3, 1.0), (self.chaser_side,) * 3)
        # the winch sits at the launch point on the cube's +z face
        cx, cy, cz = (float(v) for v in x[self.winch])
        mk.pose.position.x, mk.pose.position.y, mk.pose.position.z = cx, cy, cz - self.chaser_side / 2
        mk = marker("target_spin", 8, Marker.ARROW, (1.0, 0.5, 0.0, 1.0), (0.15, 0.35, 0.5))
        centre = np.asarray(state.target_position, dtype=float)
        omega = np.asarray(state.target_omega, dtype=float)
        rate = float(np.sqrt(omega @ omega))
        tip = centre + omega * (self.spin_arrow / rate) if rate > 0 and math.isfinite(rate) \
            else centre
        mk.points = self._points(np.array([centre, tip]))
        return out


def _quat_mul(a, b) -> tuple[float, float, float, float]:
    aw, ax, ay, az = (float(v) for v in a)
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)
