"""Where each body of an episode sits in the kernel's per-body arrays, and the net's grid
indexing: one home for the body layout that the scenario builder, the kernels and the
metrics share.

Body layout (indices into every per-body array):
  [0, n^2)            net nodes, node (i, j) = n i + j, i along y, j along x (n = 17)
  [n^2, n^2 + 4)      corner masses, in the corner order of ``noise.CORNER_SIGNS``
  [n^2 + 4, ... + S - 1)  main-tether lumped masses, from the net centre toward the winch
  last                the chaser (winch at the launch point)
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .config import SimConfig
from .noise import CORNER_SIGNS


@dataclass(frozen=True)
class BodyLayout:
    """Index ranges of the bodies for a grid of n x n nodes and a main tether of
    ``tether_masses`` lumped masses."""

    n: int
    tether_masses: int

    @classmethod
    def of(cls, config: SimConfig) -> BodyLayout:
        return cls(n=config.grid_nodes, tether_masses=config.tether_segments - 1)

    @property
    def n_net(self) -> int:
        """Net nodes (the first bodies)."""
        return self.n * self.n

    @property
    def corner0(self) -> int:
        return self.n_net

    @property
    def tether0(self) -> int:
        return self.n_net + 4

    @property
    def chaser(self) -> int:
        return self.tether0 + self.tether_masses

    @property
    def n_bodies(self) -> int:
        return self.chaser + 1

    @property
    def corner_bodies(self) -> np.ndarray:
        return np.arange(self.corner0, self.corner0 + 4)

    @property
    def tether_bodies(self) -> slice:
        """The main tether's lumped masses."""
        return slice(self.tether0, self.chaser)

    @property
    def centre(self) -> int:
        """The net's centre node, where the main tether is tied."""
        return grid_index(self.n // 2, self.n // 2, self.n)


def grid_index(i: int, j: int, n: int = 17) -> int:
    return i * n + j


def grid_thread_pairs(n: int) -> np.ndarray:
    """(T, 2) node pairs of the grid threads: the x-threads row by row, then the y-threads
    (the order of the kernel's grid_kh.ravel(), grid_kv.ravel())."""
    if n == 0:
        return np.zeros((0, 2), dtype=np.int64)
    gi = np.arange(n * n).reshape(n, n)
    xs = np.stack([gi[:, :-1].ravel(), gi[:, 1:].ravel()], axis=1)
    ys = np.stack([gi[:-1, :].ravel(), gi[1:, :].ravel()], axis=1)
    return np.concatenate([xs, ys]).astype(np.int64)


def closing_ring(config: SimConfig) -> list[int]:
    """Perimeter nodes of the drawstring in ring order (12 for the default indices)."""
    n = config.grid_nodes
    idx = list(config.closing_indices)
    ring = [(0, j) for j in idx]                       # bottom edge, +x
    ring += [(i, n - 1) for i in idx[1:]]              # right edge, +y
    ring += [(n - 1, j) for j in reversed(idx[:-1])]   # top edge, -x
    ring += [(i, 0) for i in reversed(idx[1:-1])]      # left edge, -y
    return [grid_index(i, j, n) for i, j in ring]


def corner_nodes(config: SimConfig) -> list[int]:
    """Net corner node of each corner mass, same order as CORNER_SIGNS."""
    n = config.grid_nodes - 1
    out = []
    for sx, sy in CORNER_SIGNS:
        out.append(grid_index(n if sy > 0 else 0, n if sx > 0 else 0, config.grid_nodes))
    return out


def drawstring_ring(config: SimConfig) -> list[int]:
    """The bodies the drawstring runs through, in ring order: the perimeter nodes of
    ``closing_ring``, with the net's corner nodes replaced by the corner masses where
    ``drawstring_corners`` is "corner_mass"."""
    ring = closing_ring(config)
    if config.drawstring_corners == "corner_mass":
        corners = BodyLayout.of(config).corner_bodies.tolist()
        by_node = dict(zip(corner_nodes(config), corners))
        ring = [by_node.get(r, r) for r in ring]
    return ring
