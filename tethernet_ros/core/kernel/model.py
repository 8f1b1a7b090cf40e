"""The kernel's constant model: what every lane of a batch shares (one design, one
configuration), in the style of MuJoCo's mjModel: masses and radii that never change,
stiffnesses, topology, target geometry, the step and the solver's settings.  Each part's
changing half is in :mod:`data`; :mod:`state` joins the two halves into one episode's parts.

:func:`build_model` builds the Model of an episode's parts.  Units: SI (m, s, kg, N).
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from .broadphase import BROAD_ON

#: Scalar model parameters.  dt (s); close_force F_c (N) per drawstring pair; lock_dist (m);
#: mu, mu_static: kinetic and static Coulomb friction coefficients; contact_model (index
#: into CONTACT_MODELS); omega_contact (rad/s), zeta_contact: contact natural frequency
#: ("frequency" model) and damping ratio; tether_lin_density (kg/m), tether_EA (N),
#: zeta_thread, thread_damping (index into THREAD_DAMPING_MODELS), omega_1 (rad/s): for the
#: tether segments made when the winch locks; lock_model: index into LOCK_MODELS;
#: restitution: the implicit method's coefficient of restitution of a new impact (0: none);
#: tug_creep (m/s): the tug test's speed away from the target at which the chaser takes up
#: the slack, until the tether carries half the thrust (``tug``; acting only once the host
#: starts it, ``E_TUG_STEP``; the thrust itself is per lane, ``Data.tug_force``).
Params = namedtuple("Params", "dt close_force lock_dist mu mu_static "
                              "contact_model omega_contact zeta_contact "
                              "tether_lin_density tether_EA zeta_thread thread_damping omega_1 "
                              "lock_model restitution tug_creep",
                    defaults=(0.0,))

#: Modelling choices held as small integers in Params (the index of the name).
CONTACT_MODELS = ("frequency", "hertz")
THREAD_DAMPING_MODELS = ("element", "stiffness")
LOCK_MODELS = ("ratchet", "latch", "cinch")
CONTACT_FREQUENCY, CONTACT_HERTZ = 0, 1
DAMPING_ELEMENT, DAMPING_STIFFNESS = 0, 1
LOCK_RATCHET, LOCK_LATCH, LOCK_CINCH = 0, 1, 2

#: slots of LinkModel.slots: the (non-grid) threads acting on a body
N_SLOTS = 2

#: radius (N,): contact sphere radius (m); k_contact (N,): the body's contact stiffness
#: (N/m, "hertz" model).
BodyModel = namedtuple("BodyModel", "radius k_contact")

#: The net's grid threads, implicit in the body layout: n x n nodes, rest length (m),
#: x-threads (i, j)-(i, j+1) with stiffness kh and damping ch ((n, n - 1), N/m, N s/m),
#: y-threads (i, j)-(i+1, j) with kv, cv ((n - 1, n)).  The implicit step's constants
#: per thread (the grid nodes' masses never change): hconst (n, n - 1, 4) and vconst
#: (n - 1, n, 4) hold k / (h k + c) (1/s), 1 / (h (h k + c)) (1/kg), and the inverse
#: effective mass taut 1 / (w_a + w_b + gamma) and slack 1 / (w_a + w_b) (kg), None in an
#: episode's part (``state``) until :func:`build_model` computes them.  n = 0: no grid.
GridModel = namedtuple("GridModel", "n rest kh ch kv cv hconst vconst", defaults=(None, None))

#: Other threads (corner threads, main-tether segments): pairs (M, 2) of bodies; slots
#: (N, N_SLOTS) the threads acting on each body (or -1), signs (N, N_SLOTS) +1 where the
#: body is the thread's first end.
LinkModel = namedtuple("LinkModel", "pairs slots signs")

#: The drawstring: pairs (P, 2) of adjacent ring bodies.
RingModel = namedtuple("RingModel", "pairs")

#: Sensing and the closing policy (``sensing``, ``policy``): policy (index
#: into policy.POLICIES); period: steps between measurements (the control period);
#: latency (steps); the net's reference point: the mean of ref_nodes weighted by
#: ref_weights (kg, or 1), over ref_total; target_position (sensing.TARGET_*) and the
#: planned target distance planned_z (m); noise: sigma_position (m), sigma_attitude (rad),
#: sigma_rate (rad/s), sigma_velocity (m/s); the adaptive policy's closing_time (s) and
#: apex (bool).
ControlModel = namedtuple("ControlModel", "policy period latency ref_nodes ref_weights ref_total "
                                          "target_position planned_z sigma_position "
                                          "sigma_attitude sigma_rate sigma_velocity "
                                          "closing_time apex")

#: The main tether: nodes (T,) its lumped masses in chain order from the net's centre,
#: links (T + 1,) its segments (indices into the other threads), centre the net's centre
#: node, winch the body carrying the winch; order: where the paid-out tether places its
#: masses (TETHER_ORDERS: 0 "reversed", node k the (k+1)-th from the winch, against the
#: chain, as every result before 2026-12-06 had it; 1 "chain", node k the (k+1)-th from
#: the centre; docs/model.md §5).
TetherModel = namedtuple("TetherModel", "nodes links centre winch order", defaults=(0,))
TETHER_ORDERS = ("reversed", "chain")
TETHER_REVERSED, TETHER_CHAIN = 0, 1

#: The target's constant: its shape (``geometry.TargetGeometry``); its mass properties are
#: per lane (``data.TargetData``: the noise model may draw them, docs/noise.md §1).
TargetModel = namedtuple("TargetModel", "geometry")

#: The whole constant model; launch: the launch policy's constants (``launch.LaunchModel``);
#: iterations: Gauss-Seidel sweeps per implicit step; broadphase: the contacts' broad phase
#: (index into broadphase.BROADPHASE_MODES; it changes no result).
Model = namedtuple("Model", "bodies grid links ring tether target control launch params "
                            "iterations broadphase", defaults=(BROAD_ON,))


def steps_every(rate_hz: float, dt: float) -> int:
    """Steps between events at ``rate_hz`` (Hz) for a step of ``dt`` (s): the nearest whole
    number, at least 1.  The one home of this conversion (the control period, metrics,
    traces, publishing, markers)."""
    return max(1, int(round(1.0 / (rate_hz * dt))))


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


def build_model(bodies, grid: GridModel, links, drawstring, tether: TetherModel, target_body,
                control: ControlModel, launch, params: Params, iterations: int,
                broadphase: int = BROAD_ON) -> Model:
    """The constant model of an episode's parts (``state``): each part's constant half, the
    grid's step constants for the step ``params.dt``; ``launch`` the launch policy's
    constants (``launch.LaunchModel``); ``broadphase`` the contacts' broad phase mode
    (``broadphase.BROADPHASE_MODES``)."""
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
    return Model(
        bodies=BodyModel(radius=np.ascontiguousarray(bodies.radius, dtype=np.float64),
                         k_contact=np.ascontiguousarray(bodies.k_contact, dtype=np.float64)),
        grid=GridModel(n=int(n), rest=float(grid.rest), kh=grid.kh, ch=grid.ch, kv=grid.kv,
                       cv=grid.cv, hconst=hconst, vconst=vconst),
        links=LinkModel(pairs=links.pairs, slots=links.slots, signs=links.signs),
        ring=RingModel(pairs=drawstring.pairs),
        tether=TetherModel(nodes=tether.nodes, links=tether.links, centre=int(tether.centre),
                           winch=int(tether.winch), order=int(tether.order)),
        target=TargetModel(geometry=target_body.geometry),
        control=control, launch=launch, params=params, iterations=int(iterations),
        broadphase=int(broadphase))


def reference_point(nodes, weights) -> tuple[np.ndarray, np.ndarray, float]:
    """(nodes, weights, their sum in node order) of a reference point, as the sensing
    kernel sums them."""
    total = 0.0
    for wgt in weights:
        total += float(wgt)
    return (np.ascontiguousarray(nodes, dtype=np.int64),
            np.ascontiguousarray(weights, dtype=np.float64), total)
