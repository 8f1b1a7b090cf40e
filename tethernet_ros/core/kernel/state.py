"""One episode's state and constants as named parts (named tuples of arrays and scalars):
what a scenario is built as, and the view of one lane of a batch that single-episode code
reads (``Scenario`` rebinds the mutable arrays to views of the kernel's ``Data``).

The kernels themselves take a constant :mod:`model` shared by every lane and the per-lane
:mod:`data`; :func:`model.assemble` splits these parts into them.  Units: SI.

Body layout (indices into every per-body array, ``layout.BodyLayout``):
  [0, n^2)      net nodes of the n x n grid, node (i, j) = n i + j
  then          the four corner masses, the main tether's lumped masses, the chaser
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

#: Per-body arrays.  x, v (N, 3): position (m), velocity (m/s); w (N,): inverse mass
#: (1/kg, 0 for a kinematic body); mass (N,) (kg); radius (N,): contact sphere radius (m);
#: contact_mask (N,) uint8: 1 where the body collides with the target; k_contact,
#: c_contact (N,): the body's contact stiffness (N/m) and damping (N s/m) with the target.
Bodies = namedtuple("Bodies", "x v w mass radius contact_mask k_contact c_contact")

#: The net's grid threads, implicit in the layout: x-threads (i, j)-(i, j+1) with stiffness
#: kh and damping ch ((n, n - 1), N/m and N s/m), y-threads (i, j)-(i+1, j) with kv, cv
#: ((n - 1, n)); all of rest length ``rest`` (m).  n = 0: no grid.
Grid = namedtuple("Grid", "n rest kh ch kv cv")

#: Other threads (corner threads, main-tether segments): pairs (M, 2) of bodies, rest
#: length (m), stiffness k (N/m), damping c (N s/m), active flag (uint8); node_links
#: (N, N_SLOTS) the links acting on each body (or -1) and node_sign (N, N_SLOTS) +1 where
#: the body is the link's first end, -1 where the second.
Links = namedtuple("Links", "pairs rest k c active node_links node_sign")

#: The closing mechanism: pairs (P, 2) of adjacent drawstring ring bodies; locked (P,)
#: uint8; maxdist (P,) the ratchet's maximum distance (m); lock_step (P,) step of locking
#: (-1 before); trigger_nodes: the bodies whose centre of mass starts closing.
Drawstring = namedtuple("Drawstring", "pairs locked maxdist lock_step trigger_nodes")

#: The main tether: nodes (K,) its lumped masses, links (K + 1,) its segments (indices
#: into Links), centre the net's centre node, winch the body carrying the winch.
Tether = namedtuple("Tether", "nodes links centre winch")

#: The target as a free rigid body: pos (3,) (m), quat (4,) (w, x, y, z) body -> world,
#: vel (3,) (m/s), omega (3,) world angular velocity (rad/s), ang_mom (3,) world angular
#: momentum about the CoM (kg m^2/s; the rotation's state, omega follows from it and quat),
#: inertia (3,) principal
#: moments (kg m^2); collision primitives: cyl [axial centre, half length, radius] (m) and
#: the meridional polygons of any extra solid of revolution (verts (K, 2), offsets (P + 1,)).
TargetBody = namedtuple("TargetBody", "pos quat vel omega ang_mom inertia cyl verts offsets")

#: Scalar model parameters.  dt (s); close_force F_c (N) per drawstring pair; lock_dist (m);
#: mu, mu_static: kinetic and static Coulomb friction coefficients; contact_model (index
#: into CONTACT_MODELS); omega_contact (rad/s), zeta_contact: contact natural frequency
#: ("frequency" model) and damping ratio; tgt_inv_mass (1/kg); tgt_bound: radius of a
#: sphere about the target's CoM enclosing it (m); tether_lin_density (kg/m), tether_EA (N),
#: zeta_thread, thread_damping (index into THREAD_DAMPING_MODELS), omega_1 (rad/s): for the
#: tether segments made when the winch locks; lock_model: index into LOCK_MODELS;
#: restitution: the implicit method's coefficient of restitution of a new impact (0: none).
Params = namedtuple("Params", "dt close_force lock_dist mu mu_static "
                              "contact_model omega_contact zeta_contact tgt_inv_mass tgt_bound "
                              "tether_lin_density tether_EA zeta_thread thread_damping omega_1 "
                              "lock_model restitution")

#: Modelling choices held as small integers in Params (the index of the name).
CONTACT_MODELS = ("frequency", "hertz")
THREAD_DAMPING_MODELS = ("element", "stiffness")
LOCK_MODELS = ("ratchet", "latch")
CONTACT_FREQUENCY, CONTACT_HERTZ = 0, 1
DAMPING_ELEMENT, DAMPING_STIFFNESS = 0, 1
LOCK_RATCHET, LOCK_LATCH = 0, 1

#: Bodies.contact_mask values: no contact with the target; contact; contact once the body
#: is outside the target (a tether mass that joins the dynamics when the winch locks may lie
#: inside the stage, on the straight line the paid-out tether was drawn on: it must leave
#: the stage before it can touch it, else its penetration would expel it explosively).
CONTACT_OFF, CONTACT_ON, CONTACT_ONCE_OUTSIDE = 0, 1, 2

#: Integer episode state, one int64 array; these name its slots.
E_STEP, E_CLOSING_ARMED, E_CLOSING_ACTIVE, E_CLOSING_STEP, E_TETHER_LOCKED = range(5)
N_EV = 5

#: Diagnostics accumulated by the kernel: contact_count (1,) body-steps in contact,
#: max_penetration (1,) deepest penetration seen (m).
Diagnostics = namedtuple("Diagnostics", "contact_count max_penetration")

#: The implicit method's accumulated impulses (N s) of the last step, its warm start:
#: grid_ph (n, n - 1) x-threads, grid_pv (n - 1, n) y-threads and link_p (M,) other threads
#: (negative: tension), contact_pn (N,) normal (>= 0) and contact_pt (N, 3) friction
#: impulse on each body from the target, lock_p (P,) drawstring locks.
Solver = namedtuple("Solver", "grid_ph grid_pv link_p contact_pn contact_pt lock_p")


def new_solver(n_grid: int, n_links: int, n_bodies: int, n_pairs: int) -> Solver:
    return Solver(grid_ph=np.zeros((n_grid, max(n_grid - 1, 0))),
                  grid_pv=np.zeros((max(n_grid - 1, 0), n_grid)), link_p=np.zeros(n_links),
                  contact_pn=np.zeros(n_bodies), contact_pt=np.zeros((n_bodies, 3)),
                  lock_p=np.zeros(n_pairs))


#: slots of Links.node_links: the (non-grid) threads acting on a body
N_SLOTS = 2


def new_events(closing_armed: bool = True, tether_locked: bool = False) -> np.ndarray:
    """A fresh events array: step 0, closing armed (or not), closing step -1."""
    ev = np.zeros(N_EV, dtype=np.int64)
    ev[E_CLOSING_ARMED] = 1 if closing_armed else 0
    ev[E_CLOSING_STEP] = -1
    ev[E_TETHER_LOCKED] = 1 if tether_locked else 0
    return ev


def new_diagnostics() -> Diagnostics:
    return Diagnostics(contact_count=np.zeros(1, dtype=np.int64), max_penetration=np.zeros(1))


def empty_grid() -> Grid:
    z = np.zeros((0, 0))
    return Grid(n=0, rest=1.0, kh=z, ch=z.copy(), kv=z.copy(), cv=z.copy())


def empty_drawstring() -> Drawstring:
    return Drawstring(pairs=np.zeros((0, 2), dtype=np.int64), locked=np.zeros(0, dtype=np.uint8),
                      maxdist=np.zeros(0), lock_step=np.zeros(0, dtype=np.int64),
                      trigger_nodes=np.zeros(0, dtype=np.int64))
