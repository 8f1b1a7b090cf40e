"""The numba kernel.  Its state is a constant :class:`~.model.Model` shared by every lane
and a per-lane :class:`~.data.Data` (lane axis last), with per-step :mod:`scratch`; a
single episode is a batch of one lane.  One phase per module (threads, contact and its
broad phase, drawstring, tether, rigid target, events), the implicit method's constraint
rows (``thread_rows``, ``contact_rows``, ``lock_rows``) and the two step methods that compose
them: ``implicit.advance_implicit`` (the default) and ``explicit.advance_explicit``.
:mod:`model` and :mod:`data` declare each part once, its constant half and its changing
half; :mod:`state` joins them into one episode's parts, which :func:`model.build_model` and
:func:`data.one_lane` split.  ``sensing`` and ``policy`` are the sensor and the closing
policy inside the kernel, ``launch`` the wait before the net leaves.  The kernel imports nothing of ``core`` above it.

Units: SI throughout (m, s, kg, N).
"""
from .broadphase import BROAD_CHECK, BROAD_OFF, BROAD_ON, BROADPHASE_MODES
from .data import (CONTACT_OFF, CONTACT_ON, CONTACT_ONCE_OUTSIDE, E_CLOSING_ACTIVE, E_CLOSING_ARMED,
                   E_CLOSING_STEP, E_LAUNCH_STEP, E_LAUNCHED, E_STEP, E_TETHER_LOCKED, N_EV, Data, WarmStart, copy_lane,
                   empty_like, lane_count, new_events, new_warm_start, take)
from .explicit import advance_explicit
from .geometry import (SHAPE_KINDS, SHAPE_MESH, SHAPE_REVOLUTION, TargetGeometry, mesh_geometry,
                       quat_to_matrix, revolution_geometry, target_signed_distance,
                       target_signed_distances)
from .implicit import advance_implicit
from .launch import (LAUNCH_EXTERNAL, LAUNCH_IMMEDIATE, LAUNCH_POLICIES, LAUNCH_PREDICTIVE,
                     LaunchModel, wait_for_launch)
from .model import (CONTACT_MODELS, LOCK_MODELS, N_SLOTS, THREAD_DAMPING_MODELS, ControlModel,
                    GridModel, Model, Params, TetherModel)
from .scratch import Scratch, new_scratch
from .stability import stable_step
from .state import Bodies, Drawstring, Links, TargetBody, empty_drawstring, empty_grid

__all__ = ["BROADPHASE_MODES", "BROAD_CHECK", "BROAD_OFF", "BROAD_ON",
           "CONTACT_MODELS", "LOCK_MODELS", "THREAD_DAMPING_MODELS", "Data", "Model", "Scratch",
           "advance_explicit", "advance_implicit", "ControlModel", "copy_lane", "empty_like",
           "lane_count", "new_scratch", "take", "WarmStart", "new_warm_start", "quat_to_matrix",
           "target_signed_distance", "target_signed_distances", "SHAPE_KINDS", "SHAPE_MESH",
           "SHAPE_REVOLUTION", "TargetGeometry", "mesh_geometry", "revolution_geometry",
           "stable_step", "CONTACT_OFF", "CONTACT_ON",
           "CONTACT_ONCE_OUTSIDE", "E_CLOSING_ACTIVE", "E_CLOSING_ARMED", "E_CLOSING_STEP",
           "E_STEP", "E_TETHER_LOCKED", "E_LAUNCH_STEP", "E_LAUNCHED", "LAUNCH_EXTERNAL",
           "LAUNCH_IMMEDIATE", "LAUNCH_POLICIES", "LAUNCH_PREDICTIVE", "LaunchModel",
           "wait_for_launch", "N_EV", "N_SLOTS", "Bodies", "Drawstring", "GridModel",
           "Links", "Params", "TargetBody", "TetherModel", "empty_drawstring", "empty_grid",
           "new_events"]
