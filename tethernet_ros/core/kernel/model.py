"""The kernel's constant model: what every lane of a batch shares (one design, one
configuration), in the style of MuJoCo's mjModel: masses and radii that never change,
stiffnesses, topology, target geometry, the step and the solver's settings.

:func:`assemble` builds a Model and a one-lane :class:`~.data.Data` from the named parts of
one episode (:mod:`state`).  Units: SI (m, s, kg, N).
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from .state import Params

#: radius (N,): contact sphere radius (m); k_contact (N,): the body's contact stiffness
#: (N/m, "hertz" model).
BodyModel = namedtuple("BodyModel", "radius k_contact")

#: The net's grid threads, implicit in the body layout: n x n nodes, rest length (m),
#: x-threads (i, j)-(i, j+1) with stiffness kh and damping ch ((n, n - 1), N/m, N s/m),
#: y-threads (i, j)-(i+1, j) with kv, cv ((n - 1, n)).  The implicit step's constants
#: per thread (the grid nodes' masses never change): hconst (n, n - 1, 4) and vconst
#: (n - 1, n, 4) hold k / (h k + c) (1/s), 1 / (h (h k + c)) (1/kg), and the inverse
#: effective mass taut 1 / (w_a + w_b + gamma) and slack 1 / (w_a + w_b) (kg).
GridModel = namedtuple("GridModel", "n rest kh ch kv cv hconst vconst")

#: Other threads (corner threads, main-tether segments): pairs (M, 2) of bodies; slots
#: (N, N_SLOTS) the threads acting on each body (or -1), signs (N, N_SLOTS) +1 where the
#: body is the thread's first end.
LinkModel = namedtuple("LinkModel", "pairs slots signs")

#: The drawstring: pairs (P, 2) of adjacent ring bodies; trigger_nodes: the bodies whose
#: centre of mass the closing trigger follows, and their total mass (kg).
RingModel = namedtuple("RingModel", "pairs trigger_nodes trigger_mass")

#: The main tether: nodes (T,) its lumped masses, links (T + 1,) its segments (indices into
#: the other threads), centre the net's centre node, winch the body carrying the winch.
TetherModel = namedtuple("TetherModel", "nodes links centre winch")

#: The target's constants: principal moments of inertia (3,) (kg m^2) and its collision
#: primitives: cyl [axial centre, half length, radius] (m), verts (V, 2), offsets (S + 1,).
TargetModel = namedtuple("TargetModel", "inertia cyl verts offsets")

#: The whole constant model; iterations: Gauss-Seidel sweeps per implicit step.
Model = namedtuple("Model", "bodies grid links ring tether target params iterations")


def grid_step_constants(k, c, wa, wb, h) -> np.ndarray:
    """(..., 4) per grid thread: k / (h k + c), 1 / (h (h k + c)), the inverse effective
    mass taut and slack (the implicit step's constants; see ``implicit``)."""
    out = np.zeros(np.shape(k) + (4,))
    for idx in np.ndindex(np.shape(k)):
        kk, cc, wsum = float(k[idx]), float(c[idx]), float(wa[idx] + wb[idx])
        denom = h * kk + cc
        inv_w = 1.0 / wsum if wsum > 0.0 else 0.0
        if denom <= 0.0:
            out[idx] = (0.0, 0.0, inv_w, inv_w)
            continue
        g = 1.0 / (h * denom)
        out[idx] = (kk / denom, g, 1.0 / (wsum + g), inv_w)
    return out


def build_model(bodies, grid, links, drawstring, tether, target_body, params: Params,
                iterations: int) -> Model:
    """The constant model of an episode's parts (``state``)."""
    n = grid.n
    w = np.asarray(bodies.w, dtype=np.float64)
    h = float(params.dt)
    if n > 0:
        ids = np.arange(n * n).reshape(n, n)
        hconst = grid_step_constants(grid.kh, grid.ch, w[ids[:, :-1]], w[ids[:, 1:]], h)
        vconst = grid_step_constants(grid.kv, grid.cv, w[ids[:-1, :]], w[ids[1:, :]], h)
    else:
        hconst = np.zeros((0, 0, 4))
        vconst = np.zeros((0, 0, 4))
    trigger_mass = 0.0
    for k in drawstring.trigger_nodes:
        trigger_mass += float(bodies.mass[k])
    return Model(
        bodies=BodyModel(radius=np.ascontiguousarray(bodies.radius, dtype=np.float64),
                         k_contact=np.ascontiguousarray(bodies.k_contact, dtype=np.float64)),
        grid=GridModel(n=int(n), rest=float(grid.rest), kh=grid.kh, ch=grid.ch, kv=grid.kv,
                       cv=grid.cv, hconst=hconst, vconst=vconst),
        links=LinkModel(pairs=links.pairs, slots=links.node_links, signs=links.node_sign),
        ring=RingModel(pairs=drawstring.pairs, trigger_nodes=drawstring.trigger_nodes,
                       trigger_mass=trigger_mass),
        tether=TetherModel(nodes=tether.nodes, links=tether.links, centre=int(tether.centre),
                           winch=int(tether.winch)),
        target=TargetModel(inertia=np.ascontiguousarray(target_body.inertia, dtype=np.float64),
                           cyl=target_body.cyl, verts=target_body.verts,
                           offsets=target_body.offsets),
        params=params, iterations=int(iterations))


def assemble(bodies, grid, links, drawstring, tether, target_body, params: Params,
             iterations: int, close_threshold: float, events, solver):
    """(Model, Data with one lane) of an episode's parts (``state``): constants into the
    model, everything a step changes into the data (fresh arrays, lane axis last)."""
    from .data import one_lane

    model = build_model(bodies, grid, links, drawstring, tether, target_body, params,
                        iterations)
    return model, one_lane(bodies, links, drawstring, target_body, close_threshold, events,
                           solver)
