"""Snapshots of one capture at four moments, drawn in 3D with the target.

The moments are picked from the node positions recorded at the state rate
(``SimConfig.state_rate``; trace.state_time / positions / target_pose):

net fully released
    the first recorded instant at which every net node is at least one mesh side
    (L_n / 16) from the winch: the whole net, its centre (held back by the main tether)
    included, has left the stowed pack.
maximum mouth opening
    the instant, up to closing activation (the whole episode if closing never triggers),
    of the largest mouth area: the area of the drawstring's 12-node ring projected on the
    plane normal to the line of sight (x-y).
first wrapping
    the first instant at which the net touches the target (a net node within its contact
    radius + 5 cm of the surface) while the convex hull of the net nodes encloses the
    target's centre of mass -- the net is in contact and closing around the body.
    Fallbacks, marked "(not reached)": the first contact, else the closest approach.
capture settled
    the last recorded instant (within 1 / state_rate of the settled reading, closing
    activation + settle time).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

MOMENT_NAMES = ("net fully released", "maximum mouth opening", "first wrapping", "capture settled")


@dataclass(frozen=True)
class Moment:
    """One snapshot: its name, index into the trace's state series, time (s), whether the
    defining event happened (False: a fallback instant) and a note."""

    name: str
    index: int
    time: float
    reached: bool = True
    note: str = ""


def quat_matrix(q) -> np.ndarray:
    """Rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = (float(v) for v in q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def ring_nodes(scenario) -> np.ndarray:
    """The drawstring's nodes in ring order (from the scenario's adjacent pairs)."""
    return np.asarray(scenario.drawstring.pairs)[:, 0]


def mouth_area(x: np.ndarray, ring: np.ndarray) -> float:
    """Area (m^2) of the ring polygon projected on the x-y plane (shoelace)."""
    p = x[ring, :2]
    return 0.5 * abs(float(np.dot(p[:, 0], np.roll(p[:, 1], -1)) - np.dot(p[:, 1], np.roll(p[:, 0], -1))))


def hull_contains(points: np.ndarray, q: np.ndarray) -> bool:
    from scipy.spatial import ConvexHull, QhullError

    try:
        h = ConvexHull(points)
    except QhullError:
        return False
    return bool(np.all(h.equations[:, :3] @ q + h.equations[:, 3] <= 1e-9))


def min_target_distance(net: np.ndarray, pose, target) -> float:
    """Smallest signed distance (m) of net nodes to the target's surface."""
    pos, R = np.asarray(pose[:3], dtype=float), quat_matrix(pose[3:])
    body = (net - pos) @ R
    r = np.linalg.norm(body, axis=1)
    near = np.flatnonzero(r < target.bounding_radius + 0.5)
    if near.size == 0:
        return float(r.min() - target.bounding_radius)
    return min(target.signed_distance(body[i])[0] for i in near)


def snapshot_moments(result, scenario) -> list[Moment]:
    """The four moments (see the module doc) of an episode run with state_rate > 0."""
    tr = result.trace
    if tr is None or not tr.positions:
        raise ValueError("the episode has no recorded positions (run it with SimConfig(state_rate=...) "
                         "and record_trace=True)")
    cfg = scenario.config
    times = list(tr.state_time)
    X = [np.asarray(x) for x in tr.positions]
    net_idx = np.asarray(scenario.net_nodes)
    ring = ring_nodes(scenario)
    mesh = scenario.design.L_n / (cfg.grid_nodes - 1)
    n = len(X)

    # 1. released
    rel = None
    for i, x in enumerate(X):
        if np.min(np.linalg.norm(x[net_idx] - x[scenario.tether.winch], axis=1)) >= mesh:
            rel = i
            break
    # 2. maximum mouth opening, up to closing activation
    closing = result.closing_time
    last = n - 1
    if closing == closing:  # not NaN
        last = max(0, max(i for i, t in enumerate(times) if t <= closing + 1e-9))
    areas = [mouth_area(x, ring) for x in X[:last + 1]]
    imax = int(np.argmax(areas))
    released = Moment(MOMENT_NAMES[0], rel, times[rel]) if rel is not None else \
        Moment(MOMENT_NAMES[0], imax, times[imax], False, "net never fully out; max opening shown")
    opening = Moment(MOMENT_NAMES[1], imax, times[imax], True, f"mouth area {areas[imax]:.0f} m^2")
    # 3. first wrapping
    target = scenario.target
    touch = cfg.node_contact_radius + 0.05
    first_contact, closest, closest_d, wrap = None, 0, np.inf, None
    for i, x in enumerate(X):
        net = x[net_idx]
        d = min_target_distance(net, tr.target_pose[i], target)
        if d < closest_d:
            closest, closest_d = i, d
        if d <= touch:
            if first_contact is None:
                first_contact = i
            if hull_contains(net, np.asarray(tr.target_pose[i][:3], dtype=float)):
                wrap = i
                break
    if wrap is not None:
        wrapping = Moment(MOMENT_NAMES[2], wrap, times[wrap])
    elif first_contact is not None:
        wrapping = Moment(MOMENT_NAMES[2], first_contact, times[first_contact], False,
                          "net never encloses the target; first contact shown")
    else:
        wrapping = Moment(MOMENT_NAMES[2], closest, times[closest], False,
                          f"no contact; closest approach {closest_d:.2f} m shown")
    settled = Moment(MOMENT_NAMES[3], n - 1, times[-1])
    return [released, opening, wrapping, settled]


def clip_segment(a, b, lo, hi):
    """The part of segment a-b inside the box [lo, hi] (Liang-Barsky), or None."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    d = b - a
    t0, t1 = 0.0, 1.0
    for k in range(3):
        for p, q in ((-d[k], a[k] - lo[k]), (d[k], hi[k] - a[k])):
            if p == 0:
                if q < 0:
                    return None
            else:
                t = q / p
                if p < 0:
                    t0 = max(t0, t)
                else:
                    t1 = min(t1, t)
    if t0 > t1:
        return None
    return np.array([a + t0 * d, a + t1 * d])


def _target_mesh_world(target, pose):
    mesh = target.trimesh()
    R, p = quat_matrix(pose[3:]), np.asarray(pose[:3], dtype=float)
    return mesh.vertices @ R.T + p, mesh.faces


def _draw(ax, scenario, x, pose, moment, limits):
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    def P(a):  # plot coordinates: line of sight (z) horizontal, y up
        a = np.asarray(a)
        return a[..., [2, 0, 1]]

    verts, faces = _target_mesh_world(scenario.target, pose)
    tri = P(verts)[faces]
    ax.add_collection3d(Poly3DCollection(tri, facecolor=(0.6, 0.6, 0.65, 0.25), edgecolor="none"))
    links = np.asarray(scenario.threads()[0])
    net_set = set(np.asarray(scenario.net_nodes).tolist()) | set(np.asarray(scenario.corner_bodies).tolist())
    net_links = np.array([l for l in links if l[0] in net_set and l[1] in net_set])
    segs = P(x)[net_links]
    ax.add_collection3d(Line3DCollection(segs, colors="tab:blue", linewidths=0.5))
    lo, hi = limits
    tether = [scenario.tether.centre, *np.asarray(scenario.tether.nodes).tolist(), scenario.tether.winch]
    t = P(x[tether])
    tsegs = [c for c in (clip_segment(a, b, lo, hi) for a, b in zip(t[:-1], t[1:])) if c is not None]
    if tsegs:
        ax.add_collection3d(Line3DCollection(tsegs, colors="0.3", linewidths=0.8))
    ring = P(x[ring_nodes(scenario)])
    ax.scatter(ring[:, 0], ring[:, 1], ring[:, 2], s=6, color="tab:orange")
    c = P(x[np.asarray(scenario.corner_bodies)])
    ax.scatter(c[:, 0], c[:, 1], c[:, 2], s=14, color="tab:red")
    w = P(x[scenario.tether.winch])
    if np.all(w >= lo) and np.all(w <= hi):
        ax.scatter([w[0]], [w[1]], [w[2]], s=30, marker="s", color="k")
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(hi - lo)
    ax.set_xlabel("z (m, line of sight)", fontsize=7)
    ax.set_ylabel("x (m)", fontsize=7)
    ax.set_zlabel("y (m)", fontsize=7)
    ax.tick_params(labelsize=6)
    ax.view_init(elev=18, azim=-62)
    title = f"{moment.name}, t = {moment.time:.1f} s"
    if not moment.reached:
        title += " (not reached)"
    ax.set_title(title + (f"\n{moment.note}" if moment.note else ""), fontsize=8)


def plot_snapshots(result, scenario, path: str | Path, title: str = "") -> tuple[Path, list[Moment]]:
    """PNG of the four moments (2 x 2 panels, 3D, in time order) of an episode recorded with
    state_rate > 0; ``scenario`` gives the net topology and the target (build it with
    ``core.scenario.scenario_for`` for the same design, sample and config).  Returns the
    path and the moments."""
    moments = snapshot_moments(result, scenario)
    tr = result.trace
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig = plt.figure(figsize=(11, 9))
    for k, m in enumerate(sorted(moments, key=lambda m: m.time)):
        x = np.asarray(tr.positions[m.index])
        pose = tr.target_pose[m.index]
        pts = x[np.r_[np.asarray(scenario.net_nodes), np.asarray(scenario.corner_bodies)]][:, [2, 0, 1]]
        tc = np.asarray(pose[:3])[[2, 0, 1]]
        rb = scenario.target.bounding_radius
        lo = np.minimum(pts.min(axis=0), tc - rb) - 0.5
        hi = np.maximum(pts.max(axis=0), tc + rb) + 0.5
        ax = fig.add_subplot(2, 2, k + 1, projection="3d")
        _draw(ax, scenario, x, pose, m, (lo, hi))
    verdict = "success" if result.success else f"failure: {result.failure_reason}"
    fig.suptitle(f"{title}  ({verdict})" if title else verdict, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path, moments
