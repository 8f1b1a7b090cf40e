"""The contacts' broad phase: skip a body's exact signed-distance test when its last one
proves that it cannot be within the contact's activation distance now.

For each body the lane keeps (``data.BroadData``) the body-frame point b0 (m) at which its
signed distance to the target's surface was last evaluated and that distance d0 (m).  A
signed distance is 1-Lipschitz: |sd(b) - sd(b0)| <= |b - b0| for any two points, whatever
the shape (union of solids of revolution now, any surface with a signed distance later).
The body-frame point b = R^T (x - c) moves only by the body's motion relative to the
target (its own displacement less the target's translation and rotation at the body), so
|b - b0| is the whole relative motion since the last test, measured exactly rather than
accumulated step by step.  Hence

    sd(b) - r >= d0 - |b - b0| - r > reach   whenever   |b - b0| < d0 - r - reach - SLACK,

and a body whose gap sd - r provably exceeds ``reach`` (the distance within which its test
makes a force, a row or any change of state) is skipped.  The test is done on squares
(no square root).  The cache is a value of a fixed function (the target's geometry is
constant, in the Model) at a fixed point, so it stays valid whatever happens between two
tests (a skipped step, a kinematic tether mass, a lane moved by ``data.take``); a zero
cache (d0 = 0, a fresh lane) proves nothing.

Modes (``Model.broadphase``, index into BROADPHASE_MODES): off, every body tested; on,
the default; check, every body tested as when off, the ones that "on" would skip counted
(``skips``) and those of them whose exact test turned out not clear counted
(``misses``: must stay 0).  Units: m.
"""
from __future__ import annotations

from numba import njit

BROADPHASE_MODES = ("off", "on", "check")
BROAD_OFF, BROAD_ON, BROAD_CHECK = 0, 1, 2

#: Slack (m) that the bound must clear beyond the activation distance: it covers the
#: round-off of the transformed point, of the signed distance and of the bound itself
#: (about 1e-15 m at the stage's size), with orders of magnitude to spare.
SLACK = 1e-6


@njit(cache=True, inline='always', error_model='numpy')
def proven_clear(bp, i, l, bx, by, bz, reach) -> bool:
    """Whether lane l's cache proves that body i, now at the body-frame point (bx, by, bz)
    (m), has a signed distance to the surface greater than ``reach`` (m)."""
    clear = bp.dist[i, l] - reach - SLACK
    if clear <= 0.0:
        return False
    dx = bx - bp.point[i, 0, l]
    dy = by - bp.point[i, 1, l]
    dz = bz - bp.point[i, 2, l]
    return dx * dx + dy * dy + dz * dz < clear * clear


@njit(cache=True, inline='always', error_model='numpy')
def remember(bp, i, l, bx, by, bz, sd):
    """Cache body i's exact test of lane l: at the body-frame point (bx, by, bz) its
    signed distance sd (m)."""
    bp.point[i, 0, l] = bx
    bp.point[i, 1, l] = by
    bp.point[i, 2, l] = bz
    bp.dist[i, l] = sd
