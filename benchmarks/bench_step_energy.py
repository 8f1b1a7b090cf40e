"""Energy of the deploying net against the implicit step and sweep count: the largest rise
of kinetic + strain energy between two samples 10 ms apart over the first 3 s of flight,
far from the target (no contact), as a share of the launch energy.

    .venv/bin/python benchmarks/bench_step_energy.py [--designs suboptimal,baseline]
        [--cells 1e-3:4,2e-3:4,2e-3:8]

The implicit method must never gain energy (tests/test_core_implicit.py holds the default
step to a rise of at most 1e-5, round-off of the sweeps' convergence); this prints the same
measure for other steps and sweep counts, side by side, with the CPU time of the 3 s.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", default="suboptimal,baseline")
    ap.add_argument("--cells", default="1e-3:4,2e-3:4,2e-3:6,2e-3:8",
                    help="comma-separated STEP:SWEEPS pairs (s, count)")
    args = ap.parse_args(argv)

    import numpy as np

    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.design import REFERENCE_DESIGNS
    from tethernet_ros.core.episode import CaptureSimulation
    from tethernet_ros.core.scenario import World, actions_for, build_scenario

    # compile (or load from numba's cache) before anything is timed
    CaptureSimulation(build_scenario(REFERENCE_DESIGNS["time-min"], actions_for(
        REFERENCE_DESIGNS["time-min"], None), World(distance=1e4), SimConfig())).advance(1)
    print(f"{'design':<11} {'step (s)':>9} {'sweeps':>6} {'max rise':>10} {'E(3 s)/E0':>10} "
          f"{'cpu (s)':>8}")
    for name in args.designs.split(","):
        d = REFERENCE_DESIGNS[name]
        for cell in args.cells.split(","):
            dt, sweeps = cell.split(":")
            cfg = SimConfig(implicit_dt=float(dt), implicit_iterations=int(sweeps))
            sim = CaptureSimulation(build_scenario(d, actions_for(d, None), World(distance=1e4), cfg))
            every = int(round(0.01 / sim.dt))
            c0 = time.process_time()
            e = [sim.kinetic_energy()]
            for _ in range(300):
                sim.advance(every)
                e.append(sim.kinetic_energy() + sim.elastic_energy())
            cpu = time.process_time() - c0
            e = np.array(e) / e[0]
            print(f"{name:<11} {sim.dt:9.1e} {int(sweeps):6d} {np.diff(e).max():10.2e} "
                  f"{e[-1]:10.4f} {cpu:8.2f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
