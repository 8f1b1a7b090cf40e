"""`tethernet cost RUN`: where a run's CPU went, by optimiser stage, by the verdict its
design ends with and by the phase within an episode (optimizer/cost.py; docs/optimizer.md
§9).  The split within an episode is measured by re-simulating ``--phases`` of the run's
episodes in this process, timing each phase (the records hold no such split)."""
from __future__ import annotations

import sys
import time

from .common import SCENARIO_FLAGS, add_config_argument, config_from_args, print_json

NAME = "cost"
HELP = ("where a run's CPU went: by optimiser stage (seed points, BO iterations, racing, "
        "validation), by design verdict and by episode phase (launch wait, flight, "
        "wrapping, settle)")


def add_arguments(p):
    p.add_argument("run", metavar="RUN",
                   help="a run directory of tethernet optimize (records: exact CPU), or a "
                        "directory with history.csv, or a PREFIX-history.csv with its "
                        "PREFIX-results.md beside it (as docs/cases/ keeps a run: CPU "
                        "estimated from simulated time)")
    p.add_argument("--phases", type=int, default=20, metavar="K",
                   help="re-simulate K of the run's episodes (drawn in proportion to their CPU) "
                        "to split an episode's CPU into launch wait, flight, wrapping and "
                        "settle; about 1-2 CPU-s each (default 20; 0: no episode-phase table)")
    p.add_argument("--phase-seed", type=int, default=0, metavar="S",
                   help="seed of the draw of those episodes (default 0)")
    add_config_argument(p)
    p.add_argument("--json", action="store_true", help="print the tables as JSON")


def measure_phases(design, sample, config) -> dict:
    """One episode of ``design`` under noise ``sample`` (core.episode's steps, unchanged),
    its process CPU (s) split into the wait before a launch policy fires (docs/model.md
    §16; with the building of the episode's kernel data, which it starts), flight (to the
    first contact with the target; building the scenario counts here), wrapping (to closing
    start) and settle (from closing start), attributed per metric interval (0.1 s of
    simulated time) by the state at the interval's end; ``sim_s``: its simulated length
    (s: its completion time T, which counts the wait)."""
    from ..core.episode import CaptureSimulation, run_simulation
    from ..core.scenario import actions_for, build_scenario, world_for
    from ..core.sensing import seed_state

    cpu = {"wait": 0.0, "flight": 0.0, "wrapping": 0.0, "settle": 0.0}
    start = time.process_time()
    sc = build_scenario(design, actions_for(design, sample),
                        world_for(design, sample, config.tumble), config)
    sc.sensor_seed = seed_state(sample.seed)
    built = time.process_time()
    sc.kernel()                                           # (the launch policy waits here)
    last = [time.process_time(), "flight"]
    cpu["flight"] += built - start
    cpu["wait"] += last[0] - built

    def observer(sim):
        now = time.process_time()
        phase = ("settle" if sim.closing_active else "wrapping" if sim.contact_count > 0
                 else "flight")
        cpu[phase] += now - last[0]
        last[:] = [now, phase]

    r = run_simulation(CaptureSimulation(sc), record_trace=False, observer=observer)
    cpu[last[1]] += time.process_time() - last[0]          # the last partial interval
    return {**cpu, "sim_s": float(r.completion_time)}


def _scenario(run, args):
    """The config and noise model of the run's episodes: run.json's, or (a history without
    one) the defaults with --config and the scenario flags."""
    from ..core.config import SimConfig
    from ..core.noise import NoiseModel
    from ..errors import UserError

    given = [f for f in ("--config", *SCENARIO_FLAGS)
             if getattr(args, f[2:].replace("-", "_"), None) is not None]
    if run.settings.get("config") is not None:
        if given:
            raise UserError(f"{given[0]}: the run records its own configuration in run.json; "
                            "scenario options apply only to a history without one")
        try:
            return (SimConfig.from_dict(run.settings["config"]),
                    NoiseModel(**run.settings.get("noise_model", {})))
        except (TypeError, ValueError) as exc:
            raise UserError(f"{run.path}: run.json's config or noise_model is unreadable "
                            f"({exc})") from None
    return config_from_args(args), NoiseModel()


def _measure(run, draws, args) -> list[dict]:
    from ..core.design import Design
    from ..montecarlo.seeds import sample_seed
    from ..montecarlo.worker import warm_kernels

    config, noise = _scenario(run, args)
    configs = {"reference": config}
    warm_kernels()                              # numba's cache loaded before any timing
    out = []
    print(f"tethernet cost: re-simulating {len(draws)} episodes for the phase split",
          file=sys.stderr)
    for d in draws:
        if d.fidelity not in configs:
            from ..core.fidelity import at_fidelity
            configs[d.fidelity] = at_fidelity(config, d.fidelity)
        design = (Design.from_dict(d.design) if isinstance(d.design, dict)
                  else Design.from_vector(d.design))
        seed = d.seed if d.seed is not None else sample_seed(d.base_seed, d.index)
        out.append(measure_phases(design, noise.sample(seed), configs[d.fidelity]))
    return out


def run(args) -> int:
    from optimizer.cost import CostError, cost_tables, cost_text, draw_episodes, read_run

    from ..errors import UserError

    if args.phases < 0:
        raise UserError(f"--phases {args.phases}: must be an integer >= 0")
    try:
        run_cost = read_run(args.run)
    except CostError as exc:
        raise UserError(str(exc)) from None
    draws = draw_episodes(run_cost, args.phases, args.phase_seed)
    measured = _measure(run_cost, draws, args) if draws else []
    tables = cost_tables(run_cost, draws, measured)
    if args.json:
        print_json(tables)
    else:
        print(cost_text(tables))
    return 0
