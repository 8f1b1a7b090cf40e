"""One episode's parts: what a scenario is built as, and the view of one lane of a batch
that single-episode code reads (``Scenario`` rebinds each part's changing arrays to views
of its lane of the kernel's ``Data``, :func:`bind_lane`).

Each part is declared once, in two halves: its constants in :mod:`model` (shared by every
lane) and what a step changes in :mod:`data` (per lane).  An episode's part has the fields
of both halves, without the lane axis; :func:`model.build_model` and :func:`data.one_lane`
split it.  Parts with one half only are that half: the grid and the main tether
(``model.GridModel``, ``model.TetherModel``), the warm start (``data.WarmStart``).
Units: SI.

Body layout (indices into every per-body array, ``layout.BodyLayout``):
  [0, n^2)      net nodes of the n x n grid, node (i, j) = n i + j
  then          the four corner masses, the main tether's lumped masses, the chaser
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from .data import BodyData, LinkData, RingData, TargetData, lane_of
from .model import BodyModel, GridModel, LinkModel, RingModel, TargetModel


def _joined(name: str, model_half, data_half):
    """A part with the fields of its lane half (``data``) then its constant half
    (``model``)."""
    return namedtuple(name, data_half._fields + model_half._fields)


#: The bodies (``data.BodyData`` and ``model.BodyModel``).
Bodies = _joined("Bodies", BodyModel, BodyData)
#: The other threads (``data.LinkData`` and ``model.LinkModel``).
Links = _joined("Links", LinkModel, LinkData)
#: The drawstring's ring of pairs (``data.RingData`` and ``model.RingModel``).
Drawstring = _joined("Drawstring", RingModel, RingData)
#: The target as a free rigid body (``data.TargetData`` and ``model.TargetModel``).
TargetBody = _joined("TargetBody", TargetModel, TargetData)


def bind_lane(part, lane_data, lane: int):
    """``part`` with its changing arrays (the fields of ``lane_data``, a part of ``Data``)
    replaced by views of lane ``lane``."""
    return part._replace(**lane_of(lane_data, lane)._asdict())


def empty_grid() -> GridModel:
    z = np.zeros((0, 0))
    return GridModel(n=0, rest=1.0, kh=z, ch=z.copy(), kv=z.copy(), cv=z.copy())


def empty_drawstring() -> Drawstring:
    return Drawstring(pairs=np.zeros((0, 2), dtype=np.int64), locked=np.zeros(0, dtype=np.uint8),
                      maxdist=np.zeros(0), lock_step=np.zeros(0, dtype=np.int64))
