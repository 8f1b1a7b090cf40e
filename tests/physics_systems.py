"""Small hand-made systems that run through the real kernel, for analytic checks."""
from __future__ import annotations

import numpy as np

from tethernet_ros.core import kernel as kn
from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.core.scenario import Scenario, ideal_control
from tethernet_ros.core.shapes import target_shape


def particle_system(x, v, mass, links, stiffness, damping, rest=None, dt=1e-4,
                    target_distance=1e6, config=None) -> Scenario:
    """Bodies at x (N, 3) with velocities v and masses (inf = fixed) joined by
    tension-only spring-dampers (stiffness N/m, damping N s/m), each link its own group.
    The target sits ``target_distance`` m away on +z (out of reach unless moved).  The
    configuration (default: the "spec-text" model on the explicit method) chooses the
    integrator and the drawstring's lock model."""
    x = np.array(x, dtype=float)
    v = np.array(v, dtype=float)
    mass = np.array(mass, dtype=float)
    links = np.array(links, dtype=np.int64).reshape(-1, 2)
    nb, nl = len(x), len(links)
    if rest is None:
        rest = np.linalg.norm(x[links[:, 1]] - x[links[:, 0]], axis=1)
    w = np.where(np.isinf(mass), 0.0, 1.0 / mass)
    cfg = config or SimConfig.preset("spec-text")
    slots = np.full((nb, kn.N_SLOTS), -1, dtype=np.int64)
    signs = np.zeros((nb, kn.N_SLOTS))
    used = np.zeros(nb, dtype=int)
    for m, (a, b) in enumerate(links):
        for body, sign in ((a, 1.0), (b, -1.0)):
            slots[body, used[body]], signs[body, used[body]] = m, sign
            used[body] += 1
    target = target_shape(cfg.target)
    params = kn.Params(dt=dt, close_force=0.0, lock_dist=1.0,
                       mu=cfg.friction, mu_static=cfg.friction * cfg.static_friction_scale,
                       contact_model=kn.CONTACT_MODELS.index(cfg.contact_model),
                       omega_contact=cfg.contact_frequency,
                       zeta_contact=cfg.contact_damping_ratio, tether_lin_density=0.0, tether_EA=0.0,
                       zeta_thread=0.0, thread_damping=0, omega_1=0.0,
                       lock_model=kn.LOCK_MODELS.index(cfg.lock_model), restitution=0.0)
    return Scenario(
        design=REFERENCE_DESIGNS["baseline"], config=cfg, target=target,
        bodies=kn.Bodies(x=x, v=v, w=w, mass=np.where(np.isinf(mass), 1e300, mass),
                         radius=np.full(nb, 0.02), contact_mask=np.ones(nb, dtype=np.uint8),
                         k_contact=np.zeros(nb), c_contact=np.zeros(nb)),
        grid=kn.empty_grid(),
        links=kn.Links(pairs=links, rest=np.asarray(rest, dtype=float),
                       k=np.broadcast_to(stiffness, (nl,)).astype(float).copy(),
                       c=np.broadcast_to(damping, (nl,)).astype(float).copy(),
                       active=np.ones(nl, dtype=np.uint8), slots=slots, signs=signs),
        drawstring=kn.empty_drawstring(),
        tether=kn.TetherModel(nodes=np.zeros(0, dtype=np.int64), links=np.zeros(0, dtype=np.int64),
                              centre=0, winch=0),
        target_body=kn.TargetBody(pos=np.array([0.0, 0.0, target_distance]),
                                  quat=np.array([1.0, 0, 0, 0]), vel=np.zeros(3), omega=np.zeros(3),
                                  ang_mom=np.zeros(3),
                                  inertia=target.inertia.copy(), inv_mass=1.0 / cfg.target.mass,
                                  com_offset=np.zeros(3), bound=target.bounding_radius,
                                  geometry=target.geometry()),
        params=params, events=kn.new_events(closing_armed=False, tether_locked=True),
        warm=kn.new_warm_start(0, nl, nb, 0),
        dt=dt, stable_step=dt, net_nodes=np.arange(nb, dtype=np.int64),
        corner_bodies=np.zeros(0, dtype=np.int64), close_threshold=1e9,
        control=ideal_control(nb),
        iterations=cfg.implicit_iterations)
