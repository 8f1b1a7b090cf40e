"""Small hand-made systems that run through the real kernel, for analytic checks."""
from __future__ import annotations

import numpy as np

from tethernet_ros.core import dynamics as dyn
from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.core.scenario import Scenario
from tethernet_ros.core.target import Target


def particle_system(x, v, mass, links, stiffness, damping, rest=None, dt=1e-4,
                    target_distance=1e6) -> Scenario:
    """Bodies at x (N, 3) with velocities v and masses (inf = fixed) joined by
    tension-only spring-dampers (stiffness N/m, damping N s/m), each link its own group.
    The target sits ``target_distance`` m away on +z (out of reach unless moved)."""
    x = np.array(x, dtype=float)
    v = np.array(v, dtype=float)
    mass = np.array(mass, dtype=float)
    links = np.array(links, dtype=np.int64).reshape(-1, 2)
    nb, nl = len(x), len(links)
    if rest is None:
        rest = np.linalg.norm(x[links[:, 1]] - x[links[:, 0]], axis=1)
    w = np.where(np.isinf(mass), 0.0, 1.0 / mass)
    cfg = SimConfig()
    slots = np.full((nb, dyn.N_SLOTS), -1, dtype=np.int64)
    signs = np.zeros((nb, dyn.N_SLOTS))
    used = np.zeros(nb, dtype=int)
    for m, (a, b) in enumerate(links):
        for body, sign in ((a, 1.0), (b, -1.0)):
            slots[body, used[body]], signs[body, used[body]] = m, sign
            used[body] += 1
    target = Target(cfg.target)
    verts, offsets = target.packed_polygons()
    prm = np.zeros(dyn.N_PRM)
    prm[dyn.P_DT] = dt
    prm[dyn.P_CLOSE_THRESHOLD] = 1e9
    prm[dyn.P_LOCK_DIST] = 1.0
    prm[dyn.P_MU] = cfg.friction
    prm[dyn.P_OMEGA_CONTACT] = cfg.contact_frequency
    prm[dyn.P_ZETA_CONTACT] = cfg.contact_damping_ratio
    prm[dyn.P_TGT_INV_MASS] = 1.0 / cfg.target.mass
    prm[dyn.P_TGT_BOUND] = target.bounding_radius
    ev = np.zeros(dyn.N_EV, dtype=np.int64)
    ev[dyn.E_TETHER_LOCKED] = 1
    ev[dyn.E_CLOSING_STEP] = -1
    return Scenario(
        design=REFERENCE_DESIGNS["baseline"], config=cfg, target=target, x=x, v=v, w=w,
        mass=np.where(np.isinf(mass), 1e300, mass), radius=np.full(nb, 0.02),
        contact_mask=np.ones(nb, dtype=np.uint8), grid_n=0, grid_rest=1.0,
        grid_kh=np.zeros((0, 0)), grid_ch=np.zeros((0, 0)), grid_kv=np.zeros((0, 0)),
        grid_cv=np.zeros((0, 0)), links=links,
        link_rest=np.asarray(rest, dtype=float), link_k=np.broadcast_to(stiffness, (nl,)).astype(float).copy(),
        link_c=np.broadcast_to(damping, (nl,)).astype(float).copy(),
        link_active=np.ones(nl, dtype=np.uint8), node_links=slots, node_link_sign=signs,
        dt=dt, stable_step=dt, net_nodes=np.arange(nb, dtype=np.int64),
        ring_pairs=np.zeros((0, 2), dtype=np.int64), pair_locked=np.zeros(0, dtype=np.uint8),
        pair_maxdist=np.zeros(0), pair_lock_step=np.zeros(0, dtype=np.int64),
        tether_nodes=np.zeros(0, dtype=np.int64), tether_links=np.zeros(0, dtype=np.int64),
        centre_node=0, winch_body=0, corner_bodies=np.zeros(0, dtype=np.int64),
        tgt_pos=np.array([0.0, 0.0, target_distance]), tgt_quat=np.array([1.0, 0, 0, 0]),
        tgt_vel=np.zeros(3), tgt_omega=np.zeros(3), tgt_inertia=target.inertia.copy(),
        cyl=target.cylinder(), verts=verts, offsets=offsets, prm=prm, ev=ev)
