"""The one scenario builder: design + launch/closing actions + world state -> the
structure-of-arrays initial state the kernels integrate.  The body layout is in
``layout``, the model's parts (masses, threads, contact spheres) in ``lumped``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from . import detmath
from . import kernel as kn
from .kernel.data import lane_of
from .kernel.launch import immediate_launch
from .kernel.model import TETHER_ORDERS, reference_point, steps_every
from .kernel.sensing import TARGET_POSITIONS, seed_state, sensor_slots
from .kernel.state import bind_lane
from .launch import LaunchConfig, LaunchError, launch_model
from .policies import PolicyConfig
from .sensing import SensingConfig
from .tumble import TumbleConfig, axis_quaternion, quat_multiply, spin_of
from .config import SimConfig
from .design import Design
from .layout import BodyLayout, drawstring_ring, grid_thread_pairs
from .lumped import (Threads, contact_spheres, kernel_params, lumped_masses,
                     main_tether_radius, other_threads, stowed_state, thread_damping)
from .noise import NoiseSample, check_orientation_axis, corner_velocities
from .tug import pull_ladder, required_pull, tug_params
from .shapes import Shape, target_shape


@dataclass(frozen=True)
class Actions:
    """What the actuator commands, noise included.

    corner_velocities: (4, 3) launch velocities of the corner masses (m/s);
    closing_displacement: threshold on z(net CoM) - z(target CoM) that starts closing (m).
    """

    corner_velocities: np.ndarray
    closing_displacement: float


@dataclass(frozen=True)
class World:
    """The target's actual placement: distance of its centre from the launch point along z
    (m) and its rotation about ``rotation_axis`` ('z' or 'y') from the nominal attitude
    (long axis along +x) (rad); its tumble (``core.tumble``): spin_rate (rad/s) about the
    body-frame unit axis spin_axis, the attitude first turned by spin_phase (rad) about it."""

    distance: float
    rotation: float = 0.0
    rotation_axis: str = "z"
    spin_rate: float = 0.0
    spin_axis: tuple = (0.0, 1.0, 0.0)
    spin_phase: float = 0.0
    target_mass_offset: float = 0.0
    target_inertia_offsets: tuple = (0.0, 0.0, 0.0)
    target_com_offset: tuple = (0.0, 0.0, 0.0)


def actions_for(design: Design, sample: NoiseSample | None) -> Actions:
    """Noisy (or nominal) actions of a design: the actuator's share of the noise."""
    cv = corner_velocities(design.V_e, sample)
    off = 0.0 if sample is None else sample.closing_offset
    return Actions(corner_velocities=cv, closing_displacement=design.d_c + off)


def world_for(design: Design, sample: NoiseSample | None,
              tumble: TumbleConfig | None = None) -> World:
    """Actual target placement and tumble: the world's share of the noise."""
    spin = {}
    if tumble is not None and not tumble.at_rest:
        axis, rate, phase = spin_of(tumble, sample)
        spin = dict(spin_rate=rate, spin_axis=tuple(float(c) for c in axis), spin_phase=phase)
    if sample is None:
        return World(distance=design.d_L, **spin)
    return World(distance=design.d_L + sample.distance_offset, rotation=sample.orientation_angle,
                 rotation_axis=sample.orientation_axis,
                 target_mass_offset=sample.target_mass_offset,
                 target_inertia_offsets=tuple(sample.target_inertia_offsets),
                 target_com_offset=tuple(sample.target_com_offset), **spin)


def target_mass_properties(shape, world: World) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass (kg), principal moments (3,) (kg m^2), centre-of-mass offset (3,) (m, in the
    shape's body frame)) of the target of one episode: the shape's, with the world's draws
    of their uncertainty (docs/noise.md §1): the mass times (1 + its relative offset), at
    least 1 % of it; each moment times the mass's factor and (1 + its own offset), at
    least 1 % of it, the largest then held to the sum of the other two (a physical body);
    the centre of mass moved by the offset (the moments about it taken as drawn: the
    parallel-axis change, m |offset|^2, is a part of their own uncertainty)."""
    if world.target_mass_offset == 0.0 and not any(world.target_inertia_offsets) \
            and not any(world.target_com_offset):
        return shape.mass, np.array(shape.inertia, dtype=np.float64), np.zeros(3)
    f = max(1.0 + world.target_mass_offset, 0.01)
    moments = [float(i) * f * max(1.0 + d, 0.01)
               for i, d in zip(shape.inertia, world.target_inertia_offsets)]
    k = max(range(3), key=lambda j: moments[j])
    rest = sum(moments[j] for j in range(3) if j != k)
    moments[k] = min(moments[k], rest)
    return shape.mass * f, np.array(moments), np.array(world.target_com_offset, dtype=np.float64)


def nominal_pull(design: Design, config: SimConfig) -> float:
    """The tug test's required pull (N) on the nominal target of ``config`` (its
    catalogue or file mass; ``tug.required_pull``), checked against the main tether's
    breaking load before any episode runs: TugError naming the field that set it.  0 when
    the test is off."""
    if not config.tug.enabled:
        return 0.0
    return required_pull(config.tug, target_shape(config.target).mass,
                         main_tether_radius(design, config))


def launch_attitude(design: Design, sample: NoiseSample | None, config: SimConfig):
    """(attitude quaternion, world angular momentum (kg m^2/s), principal moments
    (kg m^2)) of the target at launch in one sample, as ``build_scenario`` sets them."""
    world = world_for(design, sample, config.tumble)
    _, inertia, _ = target_mass_properties(target_shape(config.target), world)
    q, _w, ang_mom = initial_attitude(world, inertia, config.target.attitude_deg)
    return q, ang_mom, inertia


def initial_attitude(world: World, inertia: np.ndarray, attitude_deg=()):
    """(quaternion, world angular velocity (rad/s), world angular momentum (kg m^2/s)) of
    the target at the start: the orientation noise's rotation of its configured attitude
    (``TargetConfig.attitude_deg``), then the tumble's phase about its axis, spinning at
    its rate (IEEE operations only)."""
    q = rotation_quaternion(world.rotation, world.rotation_axis)
    if attitude_deg:
        q = quat_multiply(q, attitude_quaternion(attitude_deg))
    if world.spin_rate == 0.0:
        return q, np.zeros(3), np.zeros(3)
    axis = np.asarray(world.spin_axis, dtype=float)
    q = quat_multiply(q, axis_quaternion(axis, world.spin_phase))
    R = kn.quat_to_matrix(q)
    w_body = world.spin_rate * axis
    l_body = inertia * w_body
    omega = np.array([R[c, 0] * w_body[0] + R[c, 1] * w_body[1] + R[c, 2] * w_body[2]
                      for c in range(3)])
    ang_mom = np.array([R[c, 0] * l_body[0] + R[c, 1] * l_body[1] + R[c, 2] * l_body[2]
                        for c in range(3)])
    return q, omega, ang_mom


def attitude_quaternion(turns_deg) -> np.ndarray:
    """Unit quaternion of turns (deg) about the world x, then y, then z axis."""
    deg = math.pi / 180.0
    q = rotation_quaternion(turns_deg[0] * deg, "x")
    for angle, axis in zip(turns_deg[1:], "yz"):
        q = quat_multiply(rotation_quaternion(angle * deg, axis), q)
    return q


def rotation_quaternion(angle: float, axis: str) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation by ``angle`` (rad) about x/y/z."""
    q = np.zeros(4)
    q[0] = detmath.cos(angle / 2)
    q[{"x": 1, "y": 2, "z": 3}[axis]] = detmath.sin(angle / 2)
    return q


@dataclass
class Scenario:
    """One episode as named parts (``kernel.state``), with the design, configuration and
    target it was built from.  ``warm`` holds the implicit method's warm start.

    dt: integration step (s); stable_step: the explicit method's stable step (s);
    net_nodes: the net's grid nodes; corner_bodies: the four corner masses (body indices);
    close_threshold: the z_rel (m) that starts closing; broadphase: the contacts' broad
    phase (``kernel.BROADPHASE_MODES``; set before :meth:`kernel`; it changes no result).

    :meth:`kernel` builds the kernel's Model and one-lane Data from the parts, and rebinds
    every array a step changes to a view of that lane: from then on the parts show the
    episode as the kernel advances it.
    """

    design: Design
    config: SimConfig
    target: Shape
    bodies: kn.Bodies
    grid: kn.GridModel
    links: kn.Links
    drawstring: kn.Drawstring
    tether: kn.TetherModel
    target_body: kn.TargetBody
    params: kn.Params
    events: np.ndarray
    warm: kn.WarmStart
    dt: float
    stable_step: float
    net_nodes: np.ndarray
    corner_bodies: np.ndarray
    close_threshold: float = 0.0
    iterations: int = 4
    control: kn.ControlModel | None = None
    # (immediate by default: a Model whose launch were None would be another numba
    # signature, a second compile of the whole kernel for the tests' particle systems)
    launch: kn.LaunchModel = field(default_factory=immediate_launch)
    sensor_seed: int = 0
    broadphase: str = "on"
    #: the tug test's required pull (N) and the ladder's pulls above it (``core.tug``;
    #: 0 and () when the test is off)
    tug_pull: float = 0.0
    tug_ladder: tuple = ()
    _kernel: tuple | None = field(default=None, repr=False, compare=False)
    lane: int = field(default=0, repr=False, compare=False)

    @property
    def n_bodies(self) -> int:
        return self.bodies.x.shape[0]

    def set_params(self, **changes) -> None:
        """Replace model parameters (kernel Params fields) before or between steps."""
        self.params = self.params._replace(**changes)
        if self._kernel is not None:
            self._kernel = (self._build_model(), self._kernel[1])

    def _build_model(self) -> kn.Model:
        from .kernel.model import build_model
        return build_model(self.bodies, self.grid, self.links, self.drawstring, self.tether,
                           self.target_body, self.control, self.launch, self.params,
                           self.iterations,
                           kn.BROADPHASE_MODES.index(self.broadphase))

    def kernel(self) -> tuple[kn.Model, kn.Data]:
        """The kernel's (Model, Data) of this episode: on first call a Data of one lane is
        built and the parts become views of it, and an in-kernel launch policy waits until
        it fires (``kernel.launch``): the episode then starts at its launch; after
        :meth:`attach`, the batch's."""
        if self._kernel is None:
            from .kernel.data import one_lane
            ct = self.control
            data = one_lane(self.bodies, self.links, self.drawstring, self.target_body,
                            self.close_threshold, self.events, self.warm,
                            sensor_slots(ct), self.sensor_seed)
            model = self._build_model()
            self._kernel = (model, data)
            self._bind(data, 0)
            if self.events[kn.E_LAUNCHED] == 0 and model.launch.policy != kn.LAUNCH_EXTERNAL:
                kn.wait_for_launch(model, data, kn.new_scratch(model, 1))
        return self._kernel

    def attach(self, model: kn.Model, data: kn.Data, lane: int) -> None:
        """Make this episode lane ``lane`` of a batch's ``data`` (whose lane already holds
        it, e.g. by ``kernel.copy_lane``): the parts become views of that lane."""
        self._kernel = (model, data)
        self.lane = lane
        self._bind(data, lane)

    def _bind(self, data: kn.Data, lane: int) -> None:
        """Rebind the parts' changing arrays to views of ``lane`` of ``data``."""
        self.lane = lane
        self.bodies = bind_lane(self.bodies, data.bodies, lane)
        self.links = bind_lane(self.links, data.links, lane)
        self.drawstring = bind_lane(self.drawstring, data.ring, lane)
        self.target_body = bind_lane(self.target_body, data.target, lane)
        self.events = data.events[:, lane]
        self.warm = lane_of(data.warm, lane)

    def threads(self):
        """Every thread, grid and other: (pairs (T, 2), rest (m), k (N/m), c (N s/m),
        active flags), for analysis outside the kernel."""
        g, ln = self.grid, self.links
        gp = grid_thread_pairs(g.n)
        ng = len(gp)
        return (np.concatenate([gp, ln.pairs]).astype(np.int64),
                np.concatenate([np.full(ng, g.rest), ln.rest]),
                np.concatenate([g.kh.ravel(), g.kv.ravel(), ln.k]),
                np.concatenate([g.ch.ravel(), g.cv.ravel(), ln.c]),
                np.concatenate([np.ones(ng, dtype=np.uint8), ln.active]))


def _check_inputs(actions: Actions, world: World) -> np.ndarray:
    """The launch velocities as a (4, 3) array; a clear error naming a bad field."""
    cv = np.asarray(actions.corner_velocities, dtype=float)
    if cv.shape != (4, 3) or not np.all(np.isfinite(cv)):
        raise ValueError("actions field 'corner_velocities': must be 4 x 3 finite values (m/s)")
    if not math.isfinite(actions.closing_displacement):
        raise ValueError("actions field 'closing_displacement': must be finite (m)")
    if not (math.isfinite(world.distance) and world.distance > 0):
        raise ValueError(f"world field 'distance': got {world.distance}; must be > 0 m")
    if not math.isfinite(world.rotation):
        raise ValueError("world field 'rotation': must be finite (rad)")
    check_orientation_axis(world.rotation_axis, "world field 'rotation_axis'")
    return cv


def build_scenario(design: Design, actions: Actions, world: World,
                   config: SimConfig | None = None) -> Scenario:
    """Initial state of an episode (docs/model.md §1-5): the stowed net at the launch point,
    corner masses leaving with ``actions.corner_velocities``, the target at rest at
    (0, 0, world.distance) less the chaser's aim offset (``LaunchConfig.aim_offset``)
    rotated by world.rotation, closing armed at
    ``actions.closing_displacement``.  The model's parts come from ``lumped``."""
    cfg = config or SimConfig()
    cv = _check_inputs(actions, world)
    lay = BodyLayout.of(cfg)
    n, nb = lay.n, lay.n_bodies
    th = Threads.of(design, cfg)
    ring = drawstring_ring(cfg)

    x, v = stowed_state(lay, th, cv, cfg)
    mass = lumped_masses(design, cfg, lay, th, ring)
    other = other_threads(cfg, lay, th)
    # grid threads are implicit in the kernel (kernel.GridModel), all of rest length th.mesh
    k_grid = th.EA / th.mesh
    grid_kh = np.full((n, n - 1), k_grid)
    grid_kv = np.full((n - 1, n), k_grid)
    damping, grid_ch, grid_cv, omega_1 = thread_damping(cfg, lay, mass, other.k, other.pairs,
                                                        k_grid, grid_kh, grid_kv)
    radius, contact, k_contact, c_contact = contact_spheres(cfg, lay, th, mass)
    w = 1.0 / mass
    w[lay.tether_bodies] = 0.0  # kinematic while the winch pays out
    ring_pairs = np.array([(ring[q], ring[(q + 1) % len(ring)]) for q in range(len(ring))],
                          dtype=np.int64)

    target = target_shape(cfg.target)
    tgt_mass, tgt_inertia, tgt_com = target_mass_properties(target, world)
    quat, omega, ang_mom = initial_attitude(world, tgt_inertia, cfg.target.attitude_deg)
    net_nodes = np.arange(lay.n_net, dtype=np.int64)
    sc = Scenario(
        design=design, config=cfg, target=target,
        bodies=kn.Bodies(x=x, v=v, w=w, mass=mass, radius=radius, contact_mask=contact,
                         k_contact=k_contact, c_contact=c_contact),
        grid=kn.GridModel(n=n, rest=th.mesh, kh=grid_kh, ch=grid_ch, kv=grid_kv, cv=grid_cv),
        links=kn.Links(pairs=other.pairs, rest=other.rest, k=other.k, c=damping,
                       active=other.active, slots=other.slots, signs=other.signs),
        drawstring=kn.Drawstring(pairs=ring_pairs, locked=np.zeros(len(ring_pairs), dtype=np.uint8),
                                 maxdist=np.zeros(len(ring_pairs)),
                                 lock_step=np.full(len(ring_pairs), -1, dtype=np.int64)),
        tether=kn.TetherModel(nodes=np.arange(lay.tether0, lay.chaser, dtype=np.int64),
                              links=other.tether_links, centre=lay.centre, winch=lay.chaser,
                              order=TETHER_ORDERS.index(cfg.tether_order)),
        target_body=kn.TargetBody(
            pos=np.array([0.0 - cfg.launch.aim_offset[0], 0.0 - cfg.launch.aim_offset[1],
                          world.distance]), quat=quat, vel=np.zeros(3), omega=omega,
            ang_mom=ang_mom, inertia=tgt_inertia, inv_mass=1.0 / tgt_mass, com_offset=tgt_com,
            bound=target.bounding_radius + detmath.norm3(tgt_com), geometry=target.geometry()),
        params=kernel_params(design, cfg, th, omega_1),
        close_threshold=float(actions.closing_displacement), iterations=cfg.implicit_iterations,
        events=kn.new_events(),
        warm=kn.new_warm_start(n, len(other.pairs), nb, len(ring_pairs)), dt=0.0,
        stable_step=0.0, net_nodes=net_nodes, corner_bodies=lay.corner_bodies,
    )
    # the integration step: a fraction of the stable step of every thread (grid and other)
    pairs, _, k_all, c_all, active_all = sc.threads()
    _, sc.stable_step = kn.stable_step(pairs, k_all, active_all, w, nb, c=c_all,
                                       k_contact=k_contact, c_contact=c_contact)
    sc.dt = cfg.step_for(sc.stable_step)
    sc.set_params(dt=sc.dt, **tug_params(cfg.tug))
    if cfg.tug.enabled:
        sc.tug_pull = required_pull(cfg.tug, tgt_mass, th.tether_radius)
        sc.tug_ladder = pull_ladder(cfg.tug, sc.tug_pull, th.tether_radius)
    sc.control = control_model(cfg.sensing, cfg.policy, sc.dt, design.d_L, lay, mass)
    sc.launch = launch_model(cfg.launch, sc.dt,
                             planned_window(design, cfg) if cfg.launch.built_in else None,
                             target.inertia)
    if not cfg.launch.immediate:
        sc.events[kn.E_LAUNCHED] = 0
    return sc


def control_model(sensing: SensingConfig, policy: PolicyConfig, dt: float, planned_z: float,
                  lay: BodyLayout, mass: np.ndarray) -> kn.ControlModel:
    """The kernel's sensing and policy settings (``core.sensing``, ``core.policies``): the
    net's reference point as nodes and weights (masses for a centre of mass, 1 for the
    corner masses' centroid and the centre node), the control period and latency in steps,
    the noise in radians."""
    net = np.arange(lay.n_net, dtype=np.int64)
    corners = np.asarray(lay.corner_bodies, dtype=np.int64)
    if sensing.net_point == "com":
        nodes, weights = net, mass[net]
    elif sensing.net_point == "centre":
        nodes, weights = np.array([lay.centre], dtype=np.int64), np.ones(1)
    elif sensing.net_point == "corners":
        nodes, weights = corners, np.ones(len(corners))
    else:
        nodes = np.concatenate([net, corners])
        weights = mass[nodes]
    ref_nodes, ref_weights, ref_total = reference_point(nodes, weights)
    deg = math.pi / 180.0
    return kn.ControlModel(
        policy=policy.index, period=sensing.period_steps(dt), latency=sensing.latency_steps(dt),
        ref_nodes=ref_nodes, ref_weights=ref_weights, ref_total=ref_total,
        target_position=TARGET_POSITIONS.index(sensing.target_position),
        planned_z=float(planned_z), sigma_position=float(sensing.sigma_position),
        sigma_attitude=sensing.sigma_attitude_deg * deg, sigma_rate=sensing.sigma_rate_deg_s * deg,
        sigma_velocity=float(sensing.sigma_velocity), closing_time=float(policy.closing_time),
        apex=bool(policy.apex))


def scenario_for(design: Design, sample: NoiseSample | None = None,
                 config: SimConfig | None = None) -> Scenario:
    """Scenario of one Monte Carlo sample (or the nominal one if ``sample`` is None)."""
    cfg = config or SimConfig()
    sc = build_scenario(design, actions_for(design, sample),
                        world_for(design, sample, cfg.tumble), cfg)
    sc.sensor_seed = seed_state(None if sample is None else sample.seed)
    return sc


def ideal_control(n_ref: int) -> kn.ControlModel:
    """Ideal sensing at every step and the threshold policy, with the unweighted mean of
    bodies 0..n_ref-1 as the net's reference point (hand-made test systems)."""
    nodes, weights, total = reference_point(np.arange(n_ref), np.ones(n_ref))
    return kn.ControlModel(policy=0, period=1, latency=0, ref_nodes=nodes, ref_weights=weights,
                           ref_total=total, target_position=0, planned_z=0.0,
                           sigma_position=0.0, sigma_attitude=0.0, sigma_rate=0.0,
                           sigma_velocity=0.0, closing_time=0.0, apex=False)


def advance_kernel(cfg: SimConfig, model, data, scratch, n_steps: int) -> None:
    """Advance every lane of ``data`` by ``n_steps`` with the configured method."""
    if cfg.integrator == "implicit":
        kn.advance_implicit(model, data, scratch, n_steps)
    else:
        kn.advance_explicit(model, data, scratch, n_steps)


def planned_window(design: Design, config: SimConfig) -> tuple[float, float]:
    """(start, end) (s after the launch) of the design's planned capture, the window a
    launch policy predicts over: from when the net's centre of mass reaches the target's
    centre to the end of closing (the closing policy's ``closing_time`` after it starts),
    in the nominal episode: no noise, the target at rest, ideal sensing, the source's
    threshold trigger, fired at once (its flight only, up to closing).  This is what the
    chaser plans from its own design; the net slows as it spreads, so a constant speed
    from the launch momentum comes 6-19 % early on the reference designs (docs/model.md
    §16).  Once per design and configuration in a process."""
    plan = config.replace(launch=LaunchConfig(), tumble=TumbleConfig(),
                          sensing=SensingConfig(), state_rate=0.0,
                          policy=PolicyConfig(closing_time=config.policy.closing_time))
    key = (repr(design), repr(plan))
    if key not in _WINDOWS:
        if len(_WINDOWS) >= 256:
            _WINDOWS.clear()
        _WINDOWS[key] = _planned_window(design, plan)
    return _WINDOWS[key]


_WINDOWS: dict = {}


def _planned_window(design: Design, plan: SimConfig) -> tuple[float, float]:
    sc = scenario_for(design, None, plan)
    model, data = sc.kernel()
    scratch = kn.new_scratch(model, 1)
    chunk = steps_every(plan.metric_rate, sc.dt)
    nodes = sc.net_nodes
    m = [float(v) for v in sc.bodies.mass[nodes]]
    total = math.fsum(m)
    arrival = math.nan
    end = int(round(plan.horizon / sc.dt))
    while not sc.events[kn.E_CLOSING_ACTIVE] and sc.events[kn.E_STEP] < end:
        advance_kernel(plan, model, data, scratch, chunk)
        z = math.fsum(float(x) * w for x, w in zip(sc.bodies.x[nodes, 2], m)) / total
        if math.isnan(arrival) and z >= sc.target_body.pos[2]:
            arrival = int(sc.events[kn.E_STEP]) * sc.dt
        if not np.all(np.isfinite(sc.bodies.x)):
            break
    if not sc.events[kn.E_CLOSING_ACTIVE]:
        raise LaunchError("launch: the design's planned capture never closes within the "
                          f"{plan.horizon:g} s horizon; a launch policy needs a planned "
                          "closing time")
    close = int(sc.events[kn.E_CLOSING_STEP]) * sc.dt
    start = close if math.isnan(arrival) else min(arrival, close)
    return start, close + plan.policy.closing_time
