"""`tethernet capture`: one capture of a design, in-process or through the ROS suite."""
from __future__ import annotations

import time
from pathlib import Path

from ..core.shapes import target_shape
from ..core.episode import run_episode
from ..core.metrics import criterion_of
from ..core.tug import outcome_text
from .common import (add_config_argument, add_design_argument, add_fidelity_argument,
                     add_noise_arguments, add_ros_arguments, check_ros_arguments,
                     config_from_args, controller_config, design_from_args, fidelity_config,
                     node_params_from_args, noise_model_from_args, print_json)

NAME = "capture"
HELP = "simulate one capture of a design (nominal or one noise sample)"


def add_arguments(p):
    add_design_argument(p)
    g = p.add_mutually_exclusive_group()
    g.add_argument("--seed", type=int, default=None, metavar="N",
                   help="noise sample seed (an integer >= 0); default: nominal")
    g.add_argument("--nominal", action="store_true", help="no noise (the default)")
    add_noise_arguments(p)
    add_config_argument(p)
    add_fidelity_argument(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--via", choices=("library", "ros"), default="library",
                   help="run in-process (default) or through the ROS 2 node suite")
    add_ros_arguments(p, via=False)
    p.add_argument("--no-bag", action="store_true", help="with --via ros: do not record a bag")
    p.add_argument("--bag-name", default=None, help="with --via ros: bag folder name under bags/")
    p.add_argument("--png", default=None, metavar="PATH",
                   help="where to write the CQI / n_L figure (default out/capture_<design>_<seed>.png)")
    p.add_argument("--state-rate", type=float, default=0.0, metavar="HZ",
                   help="also record node positions at this rate (0: none)")


def run(args) -> int:
    from ..errors import UserError

    design = design_from_args(args)
    model = noise_model_from_args(args)
    if args.seed is not None and args.seed < 0:
        raise UserError(f"--seed {args.seed}: must be an integer >= 0")
    check_ros_arguments(args)
    sample = None if args.seed is None else model.sample(args.seed)
    config = fidelity_config(args, controller_config(args, config_from_args(
        args, **({"state_rate": args.state_rate} if args.state_rate else {}))))
    t0 = time.perf_counter()
    bag_path = None
    if args.via == "ros":
        from ..ros.suite import capture_via_ros

        result, bag_path = capture_via_ros(design, seed=args.seed, noise_model=model, config=config,
                                           record_bag=not args.no_bag, bag_name=args.bag_name,
                                           lockstep=args.lockstep, controller=args.controller,
                                           params=node_params_from_args(args))
    else:
        result = run_episode(design, sample, config)
    wall = time.perf_counter() - t0
    result.wall_time = wall
    label = args.design if not Path(args.design).suffix else Path(args.design).stem
    seed_label = "nominal" if args.seed is None else f"seed{args.seed}"
    if args.json:
        d = result.to_dict()
        d.update(design=design.to_dict(), design_name=label, via=args.via, bag_path=bag_path,
                 fidelity=args.fidelity,
                 target={**config.target.identity(),
                         "repairs": list(target_shape(config.target).repairs)})
        print_json(d)
        return 0
    png = Path(args.png) if args.png else Path("out") / f"capture_{label}_{seed_label}.png"
    if result.trace is not None and result.trace.time:
        from ..figures.capture import plot_capture_trace

        plot_capture_trace(result, png, title=f"{label}, {seed_label}")
    else:
        png = None
    print(summary_text(label, seed_label, result, wall, args.via, bag_path, png))
    if args.fidelity != "reference":
        from ..core.fidelity import fidelity_text

        print(f"  fidelity           {fidelity_text(args.fidelity, config)}: not a reference-"
              "fidelity result (docs/studies/step.md)")
    return 0


def fmt(v, unit="", digits=3):
    return "n/a" if v is None or v != v else f"{v:.{digits}f}{unit}"


def summary_text(label, seed_label, r, wall, via, bag_path, png) -> str:
    verdict = "SUCCESS" if r.success else "FAILURE"
    judged = ("the source's criterion" if criterion_of(r) == "source"
              else "criterion held: the source's and the tug at the required pull")
    lines = [
        f"capture of {label} ({seed_label}, via {via}): {verdict}  (by {judged})",
        f"  settled CQI        {fmt(r.settled_cqi)}   (success needs <= 2.0)",
        f"  locked pairs n_L   {r.locked_pairs} / 12   (success needs >= 10)",
        f"  closing time       {fmt(r.closing_time, ' s', 2)}",
        f"  completion time T  {fmt(r.completion_time, ' s', 2)}",
        f"  system mass m_a    {fmt(r.mass, ' kg', 2)}",
        f"  max penetration    {fmt(r.max_penetration * 100, ' cm', 2)}",
        f"  wall time          {wall:.2f} s  (real-time factor {r.completion_time / wall:.1f})",
    ]
    if r.failure_reason:
        lines.append(f"  failure reason     {r.failure_reason}")
    tug = getattr(r, "tug", None)
    if tug:
        lines.append(f"  tug test           {outcome_text(tug)}")
    if bag_path:
        lines.append(f"  bag                {bag_path}")
    if png:
        lines.append(f"  figure             {png}")
    return "\n".join(lines)
