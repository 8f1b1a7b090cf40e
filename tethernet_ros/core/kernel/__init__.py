"""The numba kernel.  Its state is a constant :class:`~.model.Model` shared by every lane
and a per-lane :class:`~.data.Data` (lane axis last), with per-step :mod:`scratch`; a
single episode is a batch of one lane.  One phase per module (threads, contact and its
broad phase, drawstring, tether, rigid target, events), the implicit method's constraint
rows (``thread_rows``, ``contact_rows``, ``lock_rows``) and the two step methods that compose
them: ``implicit.advance_implicit`` (the default) and ``explicit.advance_explicit``.
:mod:`state` names one episode's parts, from which :func:`model.assemble` builds them.

Units: SI throughout (m, s, kg, N).
"""
from .broadphase import BROAD_CHECK, BROAD_OFF, BROAD_ON, BROADPHASE_MODES
from .data import Data, copy_lane, empty_like, lane_count, take
from .explicit import advance_explicit
from .geometry import quat_to_matrix, target_signed_distance
from .implicit import advance_implicit
from .model import ControlModel, Model
from .scratch import Scratch, new_scratch
from .stability import stable_step
from .state import (CONTACT_MODELS, E_CLOSING_ACTIVE, E_CLOSING_ARMED, E_CLOSING_STEP, E_STEP,
                    E_TETHER_LOCKED, LOCK_MODELS, N_EV, N_SLOTS, THREAD_DAMPING_MODELS, Bodies,
                    Diagnostics, Drawstring, Grid, Links, Params, Solver, TargetBody, Tether,
                    empty_drawstring, empty_grid, new_diagnostics, new_events, new_solver)

__all__ = ["BROADPHASE_MODES", "BROAD_CHECK", "BROAD_OFF", "BROAD_ON",
           "CONTACT_MODELS", "LOCK_MODELS", "THREAD_DAMPING_MODELS", "Data", "Model", "Scratch",
           "advance_explicit", "advance_implicit", "ControlModel", "copy_lane", "empty_like",
           "lane_count", "new_scratch", "take", "Solver", "new_solver", "quat_to_matrix",
           "target_signed_distance", "stable_step",
           "E_CLOSING_ACTIVE", "E_CLOSING_ARMED", "E_CLOSING_STEP", "E_STEP", "E_TETHER_LOCKED",
           "N_EV", "N_SLOTS", "Bodies", "Diagnostics", "Drawstring", "Grid", "Links", "Params",
           "TargetBody", "Tether", "empty_drawstring", "empty_grid", "new_diagnostics",
           "new_events"]
