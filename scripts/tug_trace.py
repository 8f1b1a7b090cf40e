"""One episode's tug test in time (docs/studies/tug-checks.md, "Where the peaks come from"):
every 10 ms of the test, the largest main-tether tension in that window (N), the chaser's
speed away from the target (m/s), the net's offset from the target (m) and the pull (N),
with the analytic snatch load of the tether caught at that speed (v sqrt(k mu): k = EA / L
the locked tether's stiffness, mu the reduced mass of chaser and target).

    .venv/bin/python scripts/tug_trace.py --design docs/cases/case1-new-chosen.yaml \\
        --seed 0 [--config C.yaml] [--criterion held] --out PATH (.png and .json)
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import read_design_file, load_design
from tethernet_ros.core.episode import CaptureSimulation, run_simulation
from tethernet_ros.core.noise import NoiseModel
from tethernet_ros.core.scenario import scenario_for
from tethernet_ros.montecarlo.seeds import sample_seed


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--design", required=True)
    p.add_argument("--seed", type=int, default=0, help="base seed (sample 0 of it)")
    p.add_argument("--sample", type=int, default=0)
    p.add_argument("--config", default=None)
    p.add_argument("--out", required=True)
    args = p.parse_args(argv)
    import yaml

    data = yaml.safe_load(Path(args.config).read_text()) if args.config else {}
    data = {"criterion": "held", **(data or {})}
    cfg = SimConfig.from_dict(data)
    design = (read_design_file(args.design)[0] if Path(args.design).is_file()
              else load_design(args.design))
    seed = sample_seed(args.seed, args.sample)
    sc = scenario_for(design, NoiseModel().sample(seed), cfg)
    sim = CaptureSimulation(sc)
    rows = []

    def observe(s):
        if s.tug is None or not s.tug.started:
            return
        lane = s.s.lane
        winch = s.s.tether.winch
        rel = s.s.bodies.x[winch] - s.s.target_body.pos
        u = rel / max(float(np.linalg.norm(rel)), 1e-12)
        away = float((s.s.bodies.v[winch] - s.s.target_body.vel) @ u)
        rows.append({"t": s.time, "peak_tension": float(s.data.tug_peak[lane]),
                     "pull": float(s.data.tug_force[lane]), "away_speed": away,
                     "net_offset": float(np.linalg.norm(s.net_centre_of_mass()
                                                        - s.s.target_body.pos))})
        s.data.tug_peak[lane] = 0.0          # the next window's largest tension
    res = run_simulation(sim, record_trace=False, observer=observe)
    k = sc.params.tether_EA / max(design.d_L, 1e-9)
    m_c, m_t = cfg.chaser_mass, sim.target_mass
    mu = m_c * m_t / (m_c + m_t)
    snatch = [r["away_speed"] * math.sqrt(k * mu) if r["away_speed"] > 0 else 0.0 for r in rows]
    out = Path(args.out)
    out.with_suffix(".json").write_text(json.dumps(
        {"design": args.design, "seed": seed, "k_tether": k, "reduced_mass": mu,
         "tug": res.tug, "success": res.success, "rows": rows}, default=str) + "\n")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = [r["t"] for r in rows]
    fig, (a, b) = plt.subplots(2, 1, figsize=(7.0, 5.2), sharex=True)
    a.plot(t, [r["peak_tension"] / 1e3 for r in rows], lw=0.8, label="largest tether tension, 10 ms windows")
    a.plot(t, [r["pull"] / 1e3 for r in rows], lw=1.2, label="pull")
    a.plot(t, [x / 1e3 for x in snatch], lw=0.8, ls="--", label="v sqrt(k mu), the snatch at the speed away")
    a.set_ylabel("kN")
    a.legend(fontsize=7)
    b.plot(t, [r["away_speed"] for r in rows], lw=0.8, label="chaser's speed away from target (m/s)")
    b.plot(t, [r["net_offset"] / 10 for r in rows], lw=0.8, label="net offset / 10 (m)")
    b.set_xlabel("mission time (s)")
    b.legend(fontsize=7)
    a.set_title(f"{Path(args.design).stem}, seed {seed}: {'held' if res.tug and res.tug['held'] else 'lost'}")
    fig.tight_layout()
    fig.savefig(out.with_suffix(".png"), dpi=110)
    print(json.dumps({"tug": res.tug, "k_tether": k, "reduced_mass": mu,
                      "max_window_peak": max((r["peak_tension"] for r in rows), default=0)},
                     default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
