"""The numba kernel: named state (``state``), one phase per module (threads, contact,
drawstring, tether, rigid target), the implicit method's constraint rows (``rows``,
``thread_rows``, ``contact_rows``, ``lock_rows``) and the step methods that compose them
(``explicit``, ``implicit``).

Units: SI throughout (m, s, kg, N).
"""
from .explicit import advance
from .implicit import advance_implicit
from .geometry import quat_to_matrix, target_signed_distance
from .stability import stable_step
from .state import (CONTACT_MODELS, E_CLOSING_ACTIVE, E_CLOSING_ARMED, E_CLOSING_STEP, E_STEP,
                    E_TETHER_LOCKED, LOCK_MODELS, N_EV, N_SLOTS, THREAD_DAMPING_MODELS, Bodies,
                    Diagnostics, Drawstring, Grid, Links, Params, Solver, TargetBody, Tether,
                    empty_drawstring, empty_grid, new_diagnostics, new_events, new_solver)

__all__ = ["CONTACT_MODELS", "LOCK_MODELS", "THREAD_DAMPING_MODELS", "advance",
           "advance_implicit", "Solver", "new_solver", "quat_to_matrix", "target_signed_distance",
           "stable_step",
           "E_CLOSING_ACTIVE", "E_CLOSING_ARMED", "E_CLOSING_STEP", "E_STEP", "E_TETHER_LOCKED",
           "N_EV", "N_SLOTS", "Bodies", "Diagnostics", "Drawstring", "Grid", "Links", "Params",
           "TargetBody", "Tether", "empty_drawstring", "empty_grid", "new_diagnostics",
           "new_events"]
