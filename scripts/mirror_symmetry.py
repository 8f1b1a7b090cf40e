"""How far the nominal deployment (no noise, no target contact yet) departs from its mirror
symmetries: for the net's nodes at time t, the largest distance from a node's mirror
image (x -> -x, or y -> -y) to the nearest node (m), beside the net's extent along x.  The
nominal launch is symmetric under both mirrors (docs/model.md §2), so an exact integrator
gives 0.  Used for docs/studies/step.md ("Mirror symmetry").

    .venv/bin/python scripts/mirror_symmetry.py [--design time-min] [--times 1,2]
"""
from __future__ import annotations

import argparse

import numpy as np

from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.core.episode import CaptureSimulation
from tethernet_ros.core.scenario import scenario_for


def mirror_gap(nodes: np.ndarray, flip) -> float:
    """Largest distance (m) from a node's mirror image to its nearest node."""
    image = nodes * np.asarray(flip, dtype=float)
    d = np.sqrt(((nodes[:, None, :] - image[None, :, :]) ** 2).sum(-1))
    return float(d.min(axis=1).max())


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--design", default="time-min")
    p.add_argument("--times", default="1,2")
    args = p.parse_args(argv)
    design = REFERENCE_DESIGNS[args.design]
    times = [float(t) for t in args.times.split(",")]
    methods = [("implicit, 4 sweeps (reference)", SimConfig()),
               ("implicit, 8 sweeps", SimConfig(implicit_iterations=8)),
               ("implicit, 16 sweeps", SimConfig(implicit_iterations=16)),
               ("explicit (spec-text)", SimConfig.preset("spec-text"))]
    print("| method | t (s) | y -> -y gap (m) | x -> -x gap (m) | net extent along x (m) |")
    print("|---|---|---|---|---|")
    for label, cfg in methods:
        sim = CaptureSimulation(scenario_for(design, None, cfg))
        for t in times:
            sim.advance(int(round(t / sim.s.dt)) - sim.step)
            x = sim.net_positions()
            print(f"| {label} | {t:g} | {mirror_gap(x, (1, -1, 1)):.3g} | "
                  f"{mirror_gap(x, (-1, 1, 1)):.3g} | {np.ptp(x[:, 0]):.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
