"""The net's lumped-parameter model (docs/model.md §1-5): thread properties, the stowed
initial state, lumped masses, the threads other than the grid's (corner threads, main
tether), the threads' damping and the bodies' contact spheres.  Each function computes
one of these from the design and the configuration; ``scenario.build_scenario`` composes
them into the kernel's state.  Units: SI (m, s, kg, N).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import kernel as kn
from . import materials
from .config import SimConfig
from .design import Design
from .kernel import N_SLOTS
from .layout import BodyLayout, corner_nodes, grid_index, grid_thread_pairs
from .noise import CORNER_SIGNS


@dataclass(frozen=True)
class Threads:
    """The threads' geometry and material of a design.

    mesh: mesh side l0 = L_n / (n - 1) (m); lin_density (kg/m) and EA (N) of the net's
    thread (radius r_n); stowed_mesh: mesh side of the stowed net (m); corner_length:
    corner-thread length (m); tether_radius (m), tether_lin_density (kg/m) and tether_EA
    (N) of the main tether's thread.
    """

    mesh: float
    lin_density: float
    EA: float
    stowed_mesh: float
    corner_length: float
    tether_radius: float
    tether_lin_density: float
    tether_EA: float

    @classmethod
    def of(cls, design: Design, cfg: SimConfig) -> Threads:
        meshes = cfg.grid_nodes - 1
        area = math.pi * (design.r_n * design.r_n)
        l0 = design.L_n / meshes
        r_tether = main_tether_radius(design, cfg)
        return cls(mesh=l0, lin_density=cfg.density * area, EA=cfg.young_modulus * area,
                   stowed_mesh=cfg.stowed_fraction * design.L_n / meshes,
                   corner_length=cfg.corner_thread_meshes * l0, tether_radius=r_tether,
                   tether_lin_density=cfg.density * math.pi * (r_tether * r_tether),
                   tether_EA=cfg.young_modulus * math.pi * (r_tether * r_tether))


def main_tether_radius(design: Design, cfg: SimConfig) -> float:
    """The main tether's thread radius (m): ``cfg.tether_radius``, or the net's r_n when it
    is 0 (the text's choice)."""
    return cfg.tether_radius if cfg.tether_radius > 0 else design.r_n


def stowed_state(lay: BodyLayout, th: Threads, corner_velocities: np.ndarray, cfg: SimConfig):
    """Positions and velocities (nb, 3) at launch: the net a flat square of mesh side
    ``th.stowed_mesh`` at the launch point, each corner mass one stowed mesh diagonally
    outside its corner node and leaving with its launch velocity; everything else at rest
    at the origin (the tether's masses and the chaser)."""
    n = lay.n
    meshes = n - 1
    s = th.stowed_mesh
    x = np.zeros((lay.n_bodies, 3))
    v = np.zeros((lay.n_bodies, 3))
    for i in range(n):
        for j in range(n):
            x[grid_index(i, j, n)] = [(j - meshes / 2) * s, (i - meshes / 2) * s, 0.0]
    for k, (node, body) in enumerate(zip(corner_nodes(cfg), lay.corner_bodies)):
        sx, sy = CORNER_SIGNS[k]
        x[body] = x[node] + np.array([sx, sy, 0.0]) * s
        v[body] = corner_velocities[k]
    return x, v


def lumped_masses(design: Design, cfg: SimConfig, lay: BodyLayout, th: Threads,
                  ring: list[int]) -> np.ndarray:
    """Mass of every body (kg): each grid thread's half to each end node; the drawstring
    (4 L_n of thread, the allowance of m_a) spread over its ring bodies; each corner mass
    m_c plus half its corner thread, the other half on its corner node; the main tether's
    placeholder masses (1 m of its thread each: set when the winch locks) and the chaser."""
    mass = np.zeros(lay.n_bodies)
    half_mesh = 0.5 * th.lin_density * th.mesh
    for a, b in grid_thread_pairs(lay.n):
        mass[a] += half_mesh
        mass[b] += half_mesh
    ring_mass = 4.0 * design.L_n * th.lin_density / len(ring)
    for r in ring:
        if r < lay.n_net:
            mass[r] += ring_mass
    half_corner = 0.5 * th.lin_density * th.corner_length
    for node, body in zip(corner_nodes(cfg), lay.corner_bodies):
        mass[body] = design.m_c + half_corner
        mass[node] += half_corner
    for r in ring:
        if r >= lay.n_net:
            mass[r] += ring_mass
    mass[lay.tether_bodies] = th.tether_lin_density * 1.0
    mass[lay.chaser] = cfg.chaser_mass
    return mass


@dataclass
class OtherThreads:
    """The threads outside the grid, before their damping: pairs (M, 2), rest lengths (m),
    stiffness (N/m), active flags, each body's link slots and signs (``kernel.Links``), the
    number of net links (corner threads, first) and the tether's links in chain order."""

    pairs: np.ndarray
    rest: np.ndarray
    k: np.ndarray
    active: np.ndarray
    slots: np.ndarray
    signs: np.ndarray
    n_net_links: int
    tether_links: np.ndarray


def other_threads(cfg: SimConfig, lay: BodyLayout, th: Threads) -> OtherThreads:
    """Corner threads (corner node -> corner mass, rest ``th.corner_length``, active) and
    the main tether's segments (net centre -> lumped masses -> winch, inactive until the
    winch locks), each acting through a slot of each of its two bodies."""
    pairs = []
    rest = []
    slots = np.full((lay.n_bodies, N_SLOTS), -1, dtype=np.int64)
    signs = np.zeros((lay.n_bodies, N_SLOTS))

    def add(a, b, slot_a, slot_b, length):
        pairs.append((a, b))
        rest.append(length)
        m = len(pairs) - 1
        slots[a, slot_a], signs[a, slot_a] = m, 1.0    # force on the first end: +F n
        slots[b, slot_b], signs[b, slot_b] = m, -1.0
        return m

    for node, body in zip(corner_nodes(cfg), lay.corner_bodies):
        add(node, body, 0, 0, th.corner_length)
    n_net_links = len(pairs)
    chain = [lay.centre] + list(range(lay.tether0, lay.chaser)) + [lay.chaser]
    # along the chain: slot 0 toward the net, slot 1 toward the winch; rest set on locking
    tether_links = [add(a, b, 1 if q > 0 else 0, 0, 0.0)
                    for q, (a, b) in enumerate(zip(chain[:-1], chain[1:]))]
    pairs = np.array(pairs, dtype=np.int64)
    rest = np.array(rest, dtype=float)
    k = np.zeros(len(pairs))
    k[:n_net_links] = th.EA / rest[:n_net_links]
    active = np.zeros(len(pairs), dtype=np.uint8)
    active[:n_net_links] = 1
    return OtherThreads(pairs=pairs, rest=rest, k=k, active=active, slots=slots, signs=signs,
                        n_net_links=n_net_links,
                        tether_links=np.array(tether_links, dtype=np.int64))


def thread_damping(cfg: SimConfig, lay: BodyLayout, mass: np.ndarray, k_links: np.ndarray,
                   pairs: np.ndarray, k_grid: float, grid_kh: np.ndarray, grid_kv: np.ndarray):
    """Damping (N s/m) of the other threads (stiffness ``k_links``, bodies ``pairs``) and
    of the grid's x- and y-threads (stiffness ``grid_kh``, ``grid_kv``; k_grid each), and
    the net's first axial frequency omega_1 (rad/s; 0 for "element" damping): per element
    from its critical damping ("element") or proportional to stiffness at omega_1
    ("stiffness")."""
    n = lay.n
    zeta = cfg.damping_ratio
    if cfg.thread_damping == "element":
        gi = np.arange(n * n).reshape(n, n)
        damping = materials.element_damping(k_links, mass[pairs[:, 0]], mass[pairs[:, 1]], zeta)
        grid_ch = materials.element_damping(grid_kh, mass[gi[:, :-1]], mass[gi[:, 1:]], zeta)
        grid_cv = materials.element_damping(grid_kv, mass[gi[:-1, :]], mass[gi[1:, :]], zeta)
        return damping, grid_ch, grid_cv, 0.0
    omega_1 = materials.first_axial_frequency(mass[:lay.n_net].reshape(n, n), k_grid)
    return (materials.stiffness_damping(k_links, zeta, omega_1),
            materials.stiffness_damping(grid_kh, zeta, omega_1),
            materials.stiffness_damping(grid_kv, zeta, omega_1), omega_1)


def contact_spheres(cfg: SimConfig, lay: BodyLayout, th: Threads, mass: np.ndarray):
    """Contact sphere of every body with the target: radius (m), mask (uint8: 1 where it
    collides), stiffness (N/m) and damping (N s/m).  Radii fixed by the configuration
    ("fixed") or spheres of the body's mass at thread / corner-mass density ("density");
    the tether's masses and the chaser collide only where noted; stiffness from the
    contact frequency ("frequency") or Hertz's law linearised at a penetration ("hertz")."""
    nb = lay.n_bodies
    corners = lay.corner_bodies
    tether = lay.tether_bodies
    radius = np.full(nb, cfg.node_contact_radius)
    radius[corners] = cfg.corner_mass_radius
    radius[lay.chaser] = cfg.chaser_side / 2
    contact = np.ones(nb, dtype=np.uint8)
    contact[tether] = 0
    contact[lay.chaser] = 0
    if cfg.contact_radius == "density":
        radius[:lay.n_net] = materials.sphere_radius(mass[:lay.n_net], cfg.density)
        radius[corners] = materials.sphere_radius(mass[corners], cfg.corner_mass_density)
        radius[tether] = th.tether_radius
    e_net = materials.effective_modulus(cfg.young_modulus, cfg.poisson_ratio,
                                        cfg.target_young_modulus, cfg.target_poisson_ratio)
    e_corner = materials.effective_modulus(cfg.target_young_modulus, cfg.target_poisson_ratio,
                                           cfg.target_young_modulus, cfg.target_poisson_ratio)
    if cfg.contact_model == "frequency":
        k_contact = mass * (cfg.contact_frequency * cfg.contact_frequency)
        c_contact = 2.0 * cfg.contact_damping_ratio * mass * cfg.contact_frequency
    else:
        k_contact = materials.hertz_linear_stiffness(radius, e_net, cfg.hertz_penetration,
                                                     cfg.hertz_divisor)
        k_contact[corners] = materials.hertz_linear_stiffness(
            radius[corners], e_corner, cfg.hertz_penetration, cfg.hertz_divisor)
        c_contact = 2.0 * cfg.contact_damping_ratio * np.sqrt(k_contact * mass)
    k_contact[~contact.astype(bool)] = 0.0
    c_contact[~contact.astype(bool)] = 0.0
    if cfg.contact_model == "hertz":   # the tether's masses collide once the winch locks
        k_contact[tether] = materials.hertz_linear_stiffness(
            radius[tether], e_net, cfg.hertz_penetration, cfg.hertz_divisor)
    return radius, contact, k_contact, c_contact


def kernel_params(design: Design, cfg: SimConfig, th: Threads, omega_1: float) -> kn.Params:
    """The kernel's scalar parameters (``kernel.Params``), the step left at 0."""
    return kn.Params(
        dt=0.0, close_force=cfg.closing_force_factor * design.m_c * design.L_n,
        lock_dist=cfg.lock_distance,
        mu=cfg.friction, mu_static=cfg.friction * cfg.static_friction_scale,
        contact_model=kn.CONTACT_MODELS.index(cfg.contact_model),
        omega_contact=cfg.contact_frequency,
        zeta_contact=cfg.contact_damping_ratio, tether_lin_density=th.tether_lin_density,
        tether_EA=th.tether_EA, zeta_thread=cfg.damping_ratio,
        thread_damping=kn.THREAD_DAMPING_MODELS.index(cfg.thread_damping), omega_1=omega_1,
        lock_model=kn.LOCK_MODELS.index(cfg.lock_model),
        restitution=(materials.kelvin_voigt_restitution(cfg.contact_damping_ratio)
                     if cfg.implicit_impacts == "rebound" else 0.0))
