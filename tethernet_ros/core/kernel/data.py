"""The kernel's per-lane data: everything a step changes, for K episodes of one model side
by side (MuJoCo's mjData, with a lane axis); each part's constant half is in :mod:`model`.
Every array has the lane as its last axis, so that a loop over lanes is a contiguous,
independent inner loop (SIMD across episodes).

Lane l of every array is one episode; lanes never read each other, so an episode gives
the same bits in any lane of any batch, and a batch of one is a single episode.
Units: SI (m, s, kg, N s).
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from .policy import new_policy_data
from .sensing import new_sensor_data

#: BodyData.contact_mask values: no contact with the target; contact; contact once the body
#: is outside the target (a tether mass that joins the dynamics when the winch locks may lie
#: inside the stage, on the straight line the paid-out tether was drawn on: it must leave
#: the stage before it can touch it, else its penetration would expel it explosively).
CONTACT_OFF, CONTACT_ON, CONTACT_ONCE_OUTSIDE = 0, 1, 2

#: Integer episode state, one int64 array; these name its slots.  E_STEP counts the
#: flight's steps from the launch; E_LAUNCH_STEP the steps the chaser waited before it
#: (``launch``), E_LAUNCHED whether the net has left, E_FAVOURABLE_SINCE the mission step
#: since which every launch decision found the attitude favourable (-1: not now),
#: E_TUG_STEP the flight step at which the tug test started (-1: not started; ``tug``),
#: E_TUG_TAUT the first step of it in which the tether carried half the thrust (-1: not
#: yet).
(E_STEP, E_CLOSING_ARMED, E_CLOSING_ACTIVE, E_CLOSING_STEP, E_TETHER_LOCKED, E_LAUNCH_STEP,
 E_LAUNCHED, E_FAVOURABLE_SINCE, E_TUG_STEP, E_TUG_TAUT) = range(10)
N_EV = 10

#: x, v (N, 3, K): positions (m) and velocities (m/s); w (N, K): inverse mass (1/kg, 0 for a
#: kinematic body); mass (N, K) (kg); contact_mask (N, K) uint8 (CONTACT_*);
#: c_contact (N, K): contact damping (N s/m).  Mass, w, contact of the tether's lumped
#: masses change when the winch locks.
BodyData = namedtuple("BodyData", "x v w mass contact_mask c_contact")

#: Other threads (M, K): rest length (m), stiffness (N/m), damping (N s/m), active (uint8);
#: the tether's segments get theirs when the winch locks.
LinkData = namedtuple("LinkData", "rest k c active")

#: Drawstring pairs (P, K): locked (uint8), the ratchet's maximum distance (m), the step
#: of locking (-1 before).
RingData = namedtuple("RingData", "locked maxdist lock_step")

#: The target: pos, vel, omega (world angular velocity, rad/s), ang_mom (world angular
#: momentum about the CoM, kg m^2/s) (3, K); quat (4, K) body -> world (w, x, y, z); its
#: mass properties, drawn per lane: inertia (3, K) principal moments (kg m^2), inv_mass (K,)
#: (1/kg), com_offset (3, K) the centre of mass in the shape's frame (m: a body-frame point
#: b is the shape's point b + com_offset), bound (K,) the radius (m) of a sphere about the
#: centre of mass enclosing the body.
TargetData = namedtuple("TargetData", "pos quat vel omega ang_mom inertia inv_mass com_offset "
                                      "bound")

#: The implicit method's impulses of the last step (N s), its warm start: grid_ph
#: (n, n - 1, K), grid_pv (n - 1, n, K), link_p (M, K) (negative: tension), contact_pn
#: (N, K) (>= 0), contact_pt (N, 3, K) friction, lock_p (P, K).
WarmStart = namedtuple("WarmStart", "grid_ph grid_pv link_p contact_pn contact_pt lock_p")

#: The contacts' broad phase (``broadphase``): point (N, 3, K) the body-frame point (m) of
#: each body's last exact test, dist (N, K) its signed distance to the target there (m; 0:
#: none yet); tests (K,) exact tests made, skips (K,) tests skipped (mode check: that
#: would be skipped), misses (K,) (mode check) of those, the ones not clear after all;
#: int64 counts.
BroadData = namedtuple("BroadData", "point dist tests skips misses")

#: Per lane: events (N_EV, K) int64 (E_*); close_threshold (K,): the closing
#: displacement d_c of the episode (m); contact_count (K,): body-steps in contact;
#: max_penetration (K,) (m); sensor: the sensor's buffer and generator
#: (``sensing.SensorData``); policy: the closing policy's memory (``policy.PolicyData``);
#: broad: the contacts' broad phase; tug_peak (K,): the largest tension (N) of a main-tether
#: segment in any step since the tug test started, tug_impulse (3, K): the thrust's impulse
#: on the chaser since then (N s), tug_force (K,): the thrust (N) of the test's current
#: level, set by the host (``core.tug``: the required pull, then a ladder above it; per
#: lane, since it follows each episode's target mass) (``tug``).
Data = namedtuple("Data", "bodies links ring target warm events close_threshold sensor policy "
                          "contact_count max_penetration broad tug_peak tug_impulse tug_force")


def new_events(closing_armed: bool = True, tether_locked: bool = False,
               launched: bool = True) -> np.ndarray:
    """A fresh events array: step 0, closing armed (or not), closing step -1, launched (or
    waiting to launch, at its step 0)."""
    ev = np.zeros(N_EV, dtype=np.int64)
    ev[E_LAUNCHED] = 1 if launched else 0
    ev[E_FAVOURABLE_SINCE] = -1
    ev[E_TUG_STEP] = -1
    ev[E_TUG_TAUT] = -1
    ev[E_CLOSING_ARMED] = 1 if closing_armed else 0
    ev[E_CLOSING_STEP] = -1
    ev[E_TETHER_LOCKED] = 1 if tether_locked else 0
    return ev


def new_warm_start(n_grid: int, n_links: int, n_bodies: int, n_pairs: int) -> WarmStart:
    """A zero warm start of one episode (no lane axis): n_grid x n_grid nodes, n_links
    other threads, n_bodies bodies, n_pairs drawstring pairs."""
    return WarmStart(grid_ph=np.zeros((n_grid, max(n_grid - 1, 0))),
                     grid_pv=np.zeros((max(n_grid - 1, 0), n_grid)), link_p=np.zeros(n_links),
                     contact_pn=np.zeros(n_bodies), contact_pt=np.zeros((n_bodies, 3)),
                     lock_p=np.zeros(n_pairs))


def _lanes(a, dtype=np.float64) -> np.ndarray:
    """A one-lane array of ``a`` (lane axis appended)."""
    return np.ascontiguousarray(np.asarray(a, dtype=dtype)[..., None])


def one_lane(bodies, links, drawstring, target_body, close_threshold: float, events,
             warm, sensor_slots: int, sensor_seed: int) -> Data:
    """Data with one lane from an episode's parts (fresh arrays; diagnostics at zero);
    a sensor buffer of ``sensor_slots`` measurements and its generator's seed."""
    n_bodies = np.shape(bodies.x)[0]
    return Data(
        bodies=BodyData(x=_lanes(bodies.x), v=_lanes(bodies.v), w=_lanes(bodies.w),
                        mass=_lanes(bodies.mass), contact_mask=_lanes(bodies.contact_mask, np.uint8),
                        c_contact=_lanes(bodies.c_contact)),
        links=LinkData(rest=_lanes(links.rest), k=_lanes(links.k), c=_lanes(links.c),
                       active=_lanes(links.active, np.uint8)),
        ring=RingData(locked=_lanes(drawstring.locked, np.uint8),
                      maxdist=_lanes(drawstring.maxdist),
                      lock_step=_lanes(drawstring.lock_step, np.int64)),
        target=TargetData(pos=_lanes(target_body.pos), quat=_lanes(target_body.quat),
                          vel=_lanes(target_body.vel), omega=_lanes(target_body.omega),
                          ang_mom=_lanes(target_body.ang_mom),
                          inertia=_lanes(target_body.inertia),
                          inv_mass=_lanes(target_body.inv_mass),
                          com_offset=_lanes(target_body.com_offset),
                          bound=_lanes(target_body.bound)),
        warm=WarmStart(*(_lanes(a) for a in warm)),
        events=_lanes(events, np.int64),
        close_threshold=np.array([float(close_threshold)]),
        sensor=new_sensor_data(sensor_slots, sensor_seed),
        policy=new_policy_data(),
        contact_count=np.zeros(1, dtype=np.int64), max_penetration=np.zeros(1),
        broad=BroadData(point=np.zeros((n_bodies, 3, 1)), dist=np.zeros((n_bodies, 1)),
                        tests=np.zeros(1, dtype=np.int64), skips=np.zeros(1, dtype=np.int64),
                        misses=np.zeros(1, dtype=np.int64)),
        tug_peak=np.zeros(1), tug_impulse=np.zeros((3, 1)), tug_force=np.zeros(1))


def _map(data: Data, fn) -> Data:
    """``fn(array)`` applied to every per-lane array of ``data`` (same structure)."""
    def rec(t):
        if isinstance(t, np.ndarray):
            return fn(t)
        return type(t)(*(rec(f) for f in t))
    return rec(data)


def empty_like(data: Data, lanes: int) -> Data:
    """Data of the same shapes with ``lanes`` lanes, zero-filled."""
    return _map(data, lambda a: np.zeros(a.shape[:-1] + (lanes,), dtype=a.dtype))


def copy_lane(dst: Data, dst_lane: int, src: Data, src_lane: int) -> None:
    """Copy lane ``src_lane`` of ``src`` into lane ``dst_lane`` of ``dst`` (same model)."""
    def rec(d, s):
        if isinstance(d, np.ndarray):
            d[..., dst_lane] = s[..., src_lane]
            return
        for a, b in zip(d, s):
            rec(a, b)
    rec(dst, src)


def take(data: Data, lanes) -> Data:
    """A new Data of the given lanes, in that order (fresh contiguous arrays)."""
    idx = np.asarray(lanes, dtype=np.int64)
    return _map(data, lambda a: np.ascontiguousarray(a[..., idx]))


def lane_of(part, lane: int):
    """The same part (any namedtuple of per-lane arrays) with every array a view of lane
    ``lane`` (lane axis dropped)."""
    return type(part)(*(a[..., lane] for a in part))


def lane_count(data: Data) -> int:
    return int(data.close_threshold.shape[0])
