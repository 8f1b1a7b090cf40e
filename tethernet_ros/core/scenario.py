"""The one scenario builder: design + launch/closing actions + world state -> the
structure-of-arrays initial state the kernels integrate.

Body layout (indices into every per-body array):
  [0, 289)            net nodes, node (i, j) = 17 i + j, i along y, j along x
  [289, 293)          corner masses, in the corner order of ``noise.CORNER_SIGNS``
  [293, 293 + S - 1)  main-tether lumped masses, from the net centre toward the winch
  last                the chaser (winch at the launch point)
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .config import SimConfig
from .design import Design
from . import materials
from .noise import CORNER_SIGNS, NoiseSample, corner_velocities
from .target import Target
from . import kernel as kn
from .kernel import N_SLOTS


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
    (long axis along +x) (rad)."""

    distance: float
    rotation: float = 0.0
    rotation_axis: str = "z"


def actions_for(design: Design, sample: NoiseSample | None) -> Actions:
    """Noisy (or nominal) actions of a design: the actuator's share of the noise."""
    cv = corner_velocities(design.V_e, sample)
    off = 0.0 if sample is None else sample.closing_offset
    return Actions(corner_velocities=cv, closing_displacement=design.d_c + off)


def world_for(design: Design, sample: NoiseSample | None) -> World:
    """Actual target placement: the world's share of the noise."""
    if sample is None:
        return World(distance=design.d_L)
    return World(distance=design.d_L + sample.distance_offset, rotation=sample.orientation_angle,
                 rotation_axis=sample.orientation_axis)


def grid_index(i: int, j: int, n: int = 17) -> int:
    return i * n + j


def grid_thread_pairs(n: int) -> np.ndarray:
    """(T, 2) node pairs of the grid threads: the x-threads row by row, then the y-threads
    (the order of the kernel's grid_kh.ravel(), grid_kv.ravel())."""
    if n == 0:
        return np.zeros((0, 2), dtype=np.int64)
    gi = np.arange(n * n).reshape(n, n)
    xs = np.stack([gi[:, :-1].ravel(), gi[:, 1:].ravel()], axis=1)
    ys = np.stack([gi[:-1, :].ravel(), gi[1:, :].ravel()], axis=1)
    return np.concatenate([xs, ys]).astype(np.int64)


def closing_ring(config: SimConfig) -> list[int]:
    """Perimeter nodes of the drawstring in ring order (12 for the default indices)."""
    n = config.grid_nodes
    idx = list(config.closing_indices)
    ring = [(0, j) for j in idx]                       # bottom edge, +x
    ring += [(i, n - 1) for i in idx[1:]]              # right edge, +y
    ring += [(n - 1, j) for j in reversed(idx[:-1])]   # top edge, -x
    ring += [(i, 0) for i in reversed(idx[1:-1])]      # left edge, -y
    return [grid_index(i, j, n) for i, j in ring]


def corner_nodes(config: SimConfig) -> list[int]:
    """Net corner node of each corner mass, same order as CORNER_SIGNS."""
    n = config.grid_nodes - 1
    out = []
    for sx, sy in CORNER_SIGNS:
        out.append(grid_index(n if sy > 0 else 0, n if sx > 0 else 0, config.grid_nodes))
    return out


def rotation_quaternion(angle: float, axis: str) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation by ``angle`` (rad) about x/y/z."""
    q = np.zeros(4)
    q[0] = math.cos(angle / 2)
    q[{"x": 1, "y": 2, "z": 3}[axis]] = math.sin(angle / 2)
    return q


@dataclass
class Scenario:
    """One episode's state in the kernel's named structures (mutated in place by the
    kernels), with the design, configuration and target it was built from.  ``solver``
    holds the implicit method's warm start.

    dt: integration step (s); stable_step: the explicit method's stable step (s);
    net_nodes: the net's grid nodes; corner_bodies: the four corner masses (body indices).
    """

    design: Design
    config: SimConfig
    target: Target
    bodies: kn.Bodies
    grid: kn.Grid
    links: kn.Links
    drawstring: kn.Drawstring
    tether: kn.Tether
    target_body: kn.TargetBody
    params: kn.Params
    events: np.ndarray
    solver: kn.Solver
    dt: float
    stable_step: float
    net_nodes: np.ndarray
    corner_bodies: np.ndarray

    @property
    def n_bodies(self) -> int:
        return self.bodies.x.shape[0]

    def set_params(self, **changes) -> None:
        """Replace model parameters (kernel Params fields) before or between steps."""
        self.params = self.params._replace(**changes)

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


def build_scenario(design: Design, actions: Actions, world: World,
                   config: SimConfig | None = None) -> Scenario:
    """Initial state of an episode (SPEC sections 1-3): the stowed net at the launch point,
    corner masses leaving with ``actions.corner_velocities``, the target at rest at
    (0, 0, world.distance) rotated by world.rotation, closing armed at
    ``actions.closing_displacement``."""
    cfg = config or SimConfig()
    cv = np.asarray(actions.corner_velocities, dtype=float)
    if cv.shape != (4, 3) or not np.all(np.isfinite(cv)):
        raise ValueError("actions field 'corner_velocities': must be 4 x 3 finite values (m/s)")
    if not math.isfinite(actions.closing_displacement):
        raise ValueError("actions field 'closing_displacement': must be finite (m)")
    if not (math.isfinite(world.distance) and world.distance > 0):
        raise ValueError(f"world field 'distance': got {world.distance}; must be > 0 m")
    if not math.isfinite(world.rotation):
        raise ValueError("world field 'rotation': must be finite (rad)")
    if world.rotation_axis not in ("z", "y"):
        raise ValueError("world field 'rotation_axis': must be 'z' or 'y'")

    n = cfg.grid_nodes
    meshes = n - 1
    l0 = design.L_n / meshes                      # mesh side (m)
    area = math.pi * design.r_n**2                # thread cross-section (m^2)
    lin_density = cfg.density * area              # kg/m
    EA = cfg.young_modulus * area                 # N
    n_net = n * n
    n_tether = cfg.tether_segments - 1
    i_corner0 = n_net
    i_tether0 = n_net + 4
    i_chaser = i_tether0 + n_tether
    nb = i_chaser + 1

    x = np.zeros((nb, 3))
    v = np.zeros((nb, 3))
    mass = np.zeros(nb)
    radius = np.full(nb, cfg.node_contact_radius)
    contact = np.ones(nb, dtype=np.uint8)

    # stowed net: a flat square of side stowed_fraction * L_n at the launch point
    s = cfg.stowed_fraction * design.L_n / meshes
    for i in range(n):
        for j in range(n):
            x[grid_index(i, j, n)] = [(j - meshes / 2) * s, (i - meshes / 2) * s, 0.0]

    # grid threads are implicit in the kernel (kernel.Grid); their lumped mass: half of
    # each x- and y-thread to each end node
    grid_pairs = grid_thread_pairs(n)
    for a, b in grid_pairs:
        mass[a] += 0.5 * lin_density * l0
        mass[b] += 0.5 * lin_density * l0
    # the drawstring ring: through the net's corner nodes or through the corner masses
    cnodes = corner_nodes(cfg)
    corner_bodies = np.arange(i_corner0, i_corner0 + 4)
    ring = closing_ring(cfg)
    if cfg.drawstring_corners == "corner_mass":
        by_node = dict(zip(cnodes, corner_bodies.tolist()))
        ring = [by_node.get(r, r) for r in ring]
    # drawstring mass (the allowance of m_a: 4 L_n of thread) spread over the ring bodies
    # (net nodes now, corner masses once they exist below)
    ring_mass = 4.0 * design.L_n * lin_density / len(ring)
    for r in ring:
        if r < n_net:
            mass[r] += ring_mass

    # other threads (corner threads, tether), each acting through a body's two slots
    links = []
    slots = np.full((nb, N_SLOTS), -1, dtype=np.int64)
    signs = np.zeros((nb, N_SLOTS))

    def add_link(a, b, slot_a, slot_b):
        links.append((a, b))
        m = len(links) - 1
        slots[a, slot_a], signs[a, slot_a] = m, 1.0    # force on the first end: +F n
        slots[b, slot_b], signs[b, slot_b] = m, -1.0
        return m

    # corner masses and corner threads
    lc = cfg.corner_thread_meshes * l0
    rest = []
    for k, (node, body) in enumerate(zip(cnodes, corner_bodies)):
        sx, sy = CORNER_SIGNS[k]
        x[body] = x[node] + np.array([sx, sy, 0.0]) * s
        v[body] = cv[k]
        mass[body] = design.m_c + 0.5 * lin_density * lc
        mass[node] += 0.5 * lin_density * lc
        radius[body] = cfg.corner_mass_radius
        add_link(node, body, 0, 0)
        rest.append(lc)
    n_net_links = len(links)
    for r in ring:
        if r >= n_net:
            mass[r] += ring_mass

    # main tether: net centre -> lumped masses -> winch on the chaser
    centre = grid_index(n // 2, n // 2, n)
    chain = [centre] + list(range(i_tether0, i_tether0 + n_tether)) + [i_chaser]
    tether_links = []
    for q, (a, b) in enumerate(zip(chain[:-1], chain[1:])):
        # along the chain: slot 0 toward the net, slot 1 toward the winch
        tether_links.append(add_link(a, b, 1 if q > 0 else 0, 0))
        rest.append(0.0)  # set when the winch locks
    # the main tether's thread (its own radius, or the net's)
    r_tether = cfg.tether_radius if cfg.tether_radius > 0 else design.r_n
    tether_lin_density = cfg.density * math.pi * r_tether**2
    tether_EA = cfg.young_modulus * math.pi * r_tether**2
    # placeholder masses (set when the winch locks; kinematic until then)
    mass[i_tether0:i_chaser] = tether_lin_density * 1.0
    contact[i_tether0:i_chaser] = 0
    mass[i_chaser] = cfg.chaser_mass
    contact[i_chaser] = 0
    radius[i_chaser] = cfg.chaser_side / 2

    links = np.array(links, dtype=np.int64)
    rest = np.array(rest, dtype=float)
    k = np.zeros(len(links))
    k[:n_net_links] = EA / rest[:n_net_links]
    active = np.zeros(len(links), dtype=np.uint8)
    active[:n_net_links] = 1
    k_grid = EA / l0
    gi = np.arange(n * n).reshape(n, n)
    grid_kh = np.full((n, n - 1), k_grid)
    grid_kv = np.full((n - 1, n), k_grid)
    zeta = cfg.damping_ratio
    if cfg.thread_damping == "element":
        omega_1 = 0.0
        damping = materials.element_damping(k, mass[links[:, 0]], mass[links[:, 1]], zeta)
        grid_ch = materials.element_damping(grid_kh, mass[gi[:, :-1]], mass[gi[:, 1:]], zeta)
        grid_cv = materials.element_damping(grid_kv, mass[gi[:-1, :]], mass[gi[1:, :]], zeta)
    else:
        omega_1 = materials.first_axial_frequency(mass[:n_net].reshape(n, n), k_grid)
        damping = materials.stiffness_damping(k, zeta, omega_1)
        grid_ch = materials.stiffness_damping(grid_kh, zeta, omega_1)
        grid_cv = materials.stiffness_damping(grid_kv, zeta, omega_1)

    # contact spheres and their stiffness and damping
    tether_bodies = slice(i_tether0, i_chaser)
    if cfg.contact_radius == "density":
        radius[:n_net] = materials.sphere_radius(mass[:n_net], cfg.density)
        radius[corner_bodies] = materials.sphere_radius(mass[corner_bodies], cfg.corner_mass_density)
        radius[tether_bodies] = r_tether
    e_net = materials.effective_modulus(cfg.young_modulus, cfg.poisson_ratio,
                                        cfg.target_young_modulus, cfg.target_poisson_ratio)
    e_corner = materials.effective_modulus(cfg.target_young_modulus, cfg.target_poisson_ratio,
                                           cfg.target_young_modulus, cfg.target_poisson_ratio)
    if cfg.contact_model == "frequency":
        k_contact = mass * cfg.contact_frequency**2
        c_contact = 2.0 * cfg.contact_damping_ratio * mass * cfg.contact_frequency
    else:
        k_contact = materials.hertz_linear_stiffness(radius, e_net, cfg.hertz_penetration,
                                                     cfg.hertz_divisor)
        k_contact[corner_bodies] = materials.hertz_linear_stiffness(
            radius[corner_bodies], e_corner, cfg.hertz_penetration, cfg.hertz_divisor)
        c_contact = 2.0 * cfg.contact_damping_ratio * np.sqrt(k_contact * mass)
    k_contact[~contact.astype(bool)] = 0.0
    c_contact[~contact.astype(bool)] = 0.0
    if cfg.contact_model == "hertz":   # the tether's masses collide once the winch locks
        k_contact[tether_bodies] = materials.hertz_linear_stiffness(
            radius[tether_bodies], e_net, cfg.hertz_penetration, cfg.hertz_divisor)

    w = 1.0 / mass
    w[i_tether0:i_chaser] = 0.0  # kinematic while the winch pays out

    ring_pairs = np.array([(ring[q], ring[(q + 1) % len(ring)]) for q in range(len(ring))], dtype=np.int64)

    target = Target(cfg.target)
    verts, offsets = target.packed_polygons()
    params = kn.Params(
        dt=0.0, close_force=cfg.closing_force_factor * design.m_c * design.L_n,
        close_threshold=float(actions.closing_displacement), lock_dist=cfg.lock_distance,
        mu=cfg.friction, mu_static=cfg.friction * cfg.static_friction_scale,
        contact_model=kn.CONTACT_MODELS.index(cfg.contact_model),
        omega_contact=cfg.contact_frequency,
        zeta_contact=cfg.contact_damping_ratio, tgt_inv_mass=1.0 / cfg.target.mass,
        tgt_bound=target.bounding_radius, tether_lin_density=tether_lin_density,
        tether_EA=tether_EA, zeta_thread=cfg.damping_ratio,
        thread_damping=kn.THREAD_DAMPING_MODELS.index(cfg.thread_damping), omega_1=omega_1,
        lock_model=kn.LOCK_MODELS.index(cfg.lock_model),
        restitution=(materials.kelvin_voigt_restitution(cfg.contact_damping_ratio)
                     if cfg.implicit_impacts == "rebound" else 0.0))
    net_nodes = np.arange(n_net, dtype=np.int64)
    sc = Scenario(
        design=design, config=cfg, target=target,
        bodies=kn.Bodies(x=x, v=v, w=w, mass=mass, radius=radius, contact_mask=contact,
                         k_contact=k_contact, c_contact=c_contact),
        grid=kn.Grid(n=n, rest=l0, kh=grid_kh, ch=grid_ch, kv=grid_kv, cv=grid_cv),
        links=kn.Links(pairs=links, rest=rest, k=k, c=damping, active=active, node_links=slots,
                       node_sign=signs),
        drawstring=kn.Drawstring(pairs=ring_pairs, locked=np.zeros(len(ring_pairs), dtype=np.uint8),
                                 maxdist=np.zeros(len(ring_pairs)),
                                 lock_step=np.full(len(ring_pairs), -1, dtype=np.int64),
                                 trigger_nodes=net_nodes),
        tether=kn.Tether(nodes=np.arange(i_tether0, i_chaser, dtype=np.int64),
                         links=np.array(tether_links, dtype=np.int64), centre=centre,
                         winch=i_chaser),
        target_body=kn.TargetBody(
            pos=np.array([0.0, 0.0, world.distance]),
            quat=rotation_quaternion(world.rotation, world.rotation_axis),
            vel=np.zeros(3), omega=np.zeros(3), inertia=target.inertia.copy(),
            cyl=target.cylinder(), verts=verts, offsets=offsets),
        params=params, events=kn.new_events(),
        solver=kn.new_solver(n, len(links), nb, len(ring_pairs)), dt=0.0, stable_step=0.0,
        net_nodes=net_nodes, corner_bodies=corner_bodies,
    )
    # the integration step: a fraction of the stable step of every thread (grid and other)
    pairs, _, k_all, c_all, active_all = sc.threads()
    _, sc.stable_step = kn.stable_step(pairs, k_all, active_all, w, nb, c=c_all,
                                       k_contact=k_contact, c_contact=c_contact)
    sc.dt = cfg.step_for(sc.stable_step)
    sc.set_params(dt=sc.dt)
    return sc


def scenario_for(design: Design, sample: NoiseSample | None = None,
                 config: SimConfig | None = None) -> Scenario:
    """Scenario of one Monte Carlo sample (or the nominal one if ``sample`` is None)."""
    return build_scenario(design, actions_for(design, sample), world_for(design, sample), config)
