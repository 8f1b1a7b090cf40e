"""`tethernet study NAME`: a study of the model or of its numerical method over common
random numbers, with its table and figure written under docs/studies/.

  models       the default model, each modelling choice of docs/model.md §10 switched alone
               to the source's text, and all of the text together
  convergence  the default against half its step (P*_s, flipped verdicts, mean T)
  agreement    the default integrator against the other one on the same model
  trigger      which point the closing trigger follows: the net's reference points and the
               planned target distance (docs/model.md §14)
  tumbling     the target spinning at 0.5-8 deg/s about each axis, threshold and adaptive
               policies side by side (designs may be YAML files, e.g. the Case optima)
  launch       the flat spins and a precessing one with noisy sensing, the immediate
               against the predictive launch under each closing policy (docs/model.md §16)
  targets      the designs on every catalogued debris target other than the Zenit-2's own
               meshes, at rest and under a 2 deg/s flat spin (docs/targets.md)
  compare      two results files (e.g. of `tethernet validate` at two commits or with two
               configurations), matched by design and seed: --a FILE --b FILE

Every cell of every design runs on the same samples (sample i of base seed B uses noise
seed B*1000003+i).  Each finished sample is appended to the study's results file, so an
interrupted study resumes where it stopped.  The study runs cell by cell, a design at a
time, and rewrites its table, figure and summary (``<out>/<study>.json``,
studies/summary.py) after each: the summary records every finished cell's run key and
verdicts, and the same command run
later, without the results file (another machine, another session), takes those cells
from it and simulates only the others.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from ..core.design import REFERENCE_DESIGNS
from .common import (add_backend_arguments, add_config_argument, backend_from_args,
                     check_backend_arguments, config_from_args, json_clean, read_design_file)

NAME = "study"
HELP = "model and method studies over common random numbers (tables and figures in docs/studies)"


def add_arguments(p):
    from ..studies.cells import STUDIES

    p.add_argument("study", choices=sorted(STUDIES) + ["compare"], help="which study")
    p.add_argument("--a", default=None, metavar="FILE.jsonl", help="compare: the first results file")
    p.add_argument("--b", default=None, metavar="FILE.jsonl", help="compare: the second results file")
    for side in ("a", "b"):
        p.add_argument(f"--key-{side}", default=None, metavar="PREFIX,...",
                       help=f"compare: only these run keys in --{side} (comma-separated prefixes)")
    p.add_argument("--labels", default="a,b", metavar="A,B", help="compare: the two runs' labels")
    p.add_argument("--name", default=None, metavar="NAME",
                   help="file name of the table, summary and figure (default: the study's name)")
    p.add_argument("--designs", default=",".join(REFERENCE_DESIGNS), metavar="A,B",
                   help="reference designs or design YAML files (default: the four reference "
                        "designs)")
    p.add_argument("--samples", type=int, default=200, metavar="N",
                   help="samples per cell and design (default 200)")
    p.add_argument("--seed", type=int, default=0, metavar="BASE", help="base seed (default 0)")
    p.add_argument("--cells", default=None, metavar="A,B",
                   help="only these cells (labels; the first cell is always kept as the base)")
    add_backend_arguments(p)
    add_config_argument(p)
    p.add_argument("--results", default=None, metavar="FILE.jsonl",
                   help="results file (default out/studies/<study>_seed<BASE>.jsonl)")
    p.add_argument("--out", default="docs/studies", metavar="DIR",
                   help="where the table (.md), summary (.json) and figure (.png) go")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--no-summary", action="store_true",
                   help="simulate every cell, even those the study's summary in --out already "
                        "records with the same run key, seed and samples")
    p.add_argument("--plan", action="store_true",
                   help="simulate nothing: print the episodes the study has left (cells not "
                        "in its summary, samples not in its results file) and their CPU "
                        "time at the CPU seconds per episode the summary records")
    p.add_argument("--report-only", action="store_true",
                   help="simulate nothing: report the samples already in the results file "
                        "(a cell's n may then be below --samples)")
    p.add_argument("--model-version", default=None, metavar="HEX",
                   help="with --report-only: also read records of this model version (16 hex "
                        "digits, montecarlo.keys.model_version of the core that wrote them; "
                        "results files record it from now on)")


def run(args) -> int:
    from ..errors import UserError
    from ..montecarlo import RunSpec, evaluate_many
    from ..montecarlo.keys import run_key
    from ..studies.cells import STUDIES
    from ..studies.summary import CellRecord, reusable_cells

    designs = [d.strip() for d in args.designs.split(",") if d.strip()]
    if args.study == "compare":
        return _compare(args, designs)
    check_backend_arguments(args)
    design_of, scenario_of = {}, {}
    for d in designs:
        if d in REFERENCE_DESIGNS or (d.endswith((".yaml", ".yml")) and Path(d).is_file()):
            design_of[d], scenario_of[d] = read_design_file(d)
        else:
            raise UserError(f"--designs: unknown design {d!r}; allowed {sorted(REFERENCE_DESIGNS)} "
                            "or a design YAML file")
    if args.samples < 1:
        raise UserError(f"--samples {args.samples}: must be an integer >= 1")
    base = config_from_args(args)
    cells = STUDIES[args.study](base)
    launch_of = {d: _design_launch(d, scenario_of[d], args) for d in designs}
    if args.cells:
        keep = {c.strip() for c in args.cells.split(",")}
        unknown = keep - {c.label for c in cells}
        if unknown:
            raise UserError(f"--cells: unknown {sorted(unknown)}; allowed {[c.label for c in cells]}")
        cells = [cells[0]] + [c for c in cells[1:] if c.label in keep]
    specs = {(c.label, d): RunSpec(design_of[d], noise_model=c.noise,
                                   config=with_launch(c.config, launch_of[d]),
                                   label=f"{c.label}|{d}") for c in cells for d in designs}
    results = Path(args.results or f"out/studies/{args.study}_seed{args.seed}.jsonl")
    results.parent.mkdir(parents=True, exist_ok=True)
    outdir = Path(args.out)
    outdir.mkdir(parents=True, exist_ok=True)
    summary_path = outdir / f"{args.name or args.study}.json"
    backend = None if args.report_only or args.plan else backend_from_args(args)
    try:
        source = getattr(backend, "episode_source", None)
        earlier = {} if args.no_summary else reusable_cells(summary_path, args.seed, args.samples)
        keys = {ld: run_key(spec.design, spec.noise_model, spec.config, episode_source=source)
                for ld, spec in specs.items()}
        records: dict[tuple[str, str], CellRecord] = {
            (label, d): CellRecord.from_json(earlier[key], label, d)
            for (label, d), key in keys.items() if key in earlier}
        if records:
            print(f"{summary_path}: {len(records)} of {len(specs)} cells taken as recorded "
                  "(same run key, seed and samples); the others are simulated", file=sys.stderr)
            records = _closing_times_from_file(records, results)
        if args.plan:
            print(_plan(args, cells, designs, keys, records, results))
            return 0
        if args.report_only:
            todo = [s for k, s in specs.items() if k not in records]
            for label_d, got in _from_file(todo, args.samples, args.seed, results,
                                           args.model_version).items():
                label, d = label_d.split("|", 1)
                records[(label, d)] = CellRecord.from_samples(label, d, got.key, args.seed,
                                                              got.samples)
        else:
            # cell by cell and design by design, so that the summary and the report hold
            # every finished (cell, design) pair
            for (label, d), spec in specs.items():
                if (label, d) in records:
                    continue
                got = evaluate_many([spec], args.samples, args.seed, backend, results_path=results,
                                    progress=_progress(args, spec.label))[0]
                records[(label, d)] = CellRecord.from_samples(label, d, got.key, args.seed,
                                                              got.samples)
                _write_report(args, base, cells, designs, records, design_of, launch_of)
    finally:
        if backend is not None:
            backend.close()
    print(_write_report(args, base, cells, designs, records, design_of, launch_of))
    return 0


def _design_launch(d: str, scenario: dict, args) -> dict:
    """The launch settings a design file states for its own cells (its ``launch:`` less
    ``kind``, and less what the command line sets): a design chosen or checked with a tilt
    limit keeps it in every cell.  The file's tumble, target and launch kind give way to
    each cell's and the command line's, with a note."""
    from ..errors import UserError
    from .common import scenario_overrides

    for group in ("tumble", "target"):
        if group in scenario:
            print(f"{d}: its {group} {scenario[group]} is not used; each cell of the study "
                  "and the command line set it", file=sys.stderr)
    launch = dict(scenario.get("launch", {}))
    flagged = {k.split(".", 1)[1] for k in scenario_overrides(args)[1] if k.startswith("launch.")}
    dropped = {k: launch.pop(k) for k in list(launch) if k == "kind" or k in flagged}
    if dropped:
        print(f"{d}: its launch {dropped} is not used; each cell sets the launch policy and "
              "the command line's --launch-* win", file=sys.stderr)
    if launch:
        from ..core.config import ConfigError, SimConfig

        try:        # the configuration's own reading names an unknown field or a bad value
            SimConfig.from_dict({"launch": launch})
        except ConfigError as exc:
            raise UserError(f"--designs {d} (launch:): {exc}") from None
        print(f"{d}: its launch settings {launch} apply to its cells", file=sys.stderr)
    return launch


def with_launch(config, launch: dict):
    """``config`` with the launch fields of ``launch`` (a design file's, checked by
    _design_launch) set."""
    if not launch:
        return config
    from dataclasses import replace

    return config.replace(launch=replace(config.launch, **launch))


def _closing_times_from_file(records: dict, results: Path) -> dict:
    """Recorded cells that lack their samples' closing times (a summary written before it
    kept them) take them from the results file when it holds all of their samples."""
    if all(r.closing_times is not None for r in records.values()) or not results.exists():
        return records
    from ..montecarlo.results_file import ResultsFile

    # records() only reads: load() would cut a partial last line a running study is writing
    known = {(r.key, r.seed): r for _rec, r in ResultsFile(results).records()}
    return {k: r.with_closing_times_from(known) for k, r in records.items()}


def _plan(args, cells, designs, keys: dict, records, results: Path) -> str:
    """--plan: the study's episodes left and their estimated CPU time (``keys``: each
    (cell, design) pair's run key)."""
    from ..montecarlo.results_file import ResultsFile
    from ..montecarlo.seeds import sample_seed
    from ..studies.summary import plan_text

    # records() only reads: load() would cut a partial last line a running study is writing
    known = {(r.key, r.seed) for _rec, r in ResultsFile(results).records()}
    seeds = [sample_seed(args.seed, i) for i in range(args.samples)]
    in_results = {}
    for pair, key in keys.items():
        if pair not in records:
            in_results[pair] = sum(1 for s in seeds if (key, s) in known)
    import os

    workers = args.workers if args.workers else (os.cpu_count() or 1)   # default: all cores
    return plan_text(args.study, designs, [c.label for c in cells], args.samples, records,
                     in_results, workers)


def _progress(args, label: str):
    """A progress bar for one cell's episodes (None with --no-progress)."""
    if args.no_progress:
        return None
    from tqdm import tqdm

    bar = tqdm(desc=f"study {args.study}: {label}", unit="ep", file=sys.stderr)

    def progress(done, total, _r):
        bar.total = total
        bar.n = done
        bar.refresh()
    return progress


def _write_report(args, base, cells, designs, records, design_of, launch_of) -> str:
    """The study's table (.md, keeping its hand-written part), summary (.json, every
    cell's record) and figure (.png) from the cells recorded so far; returns the table
    (``design_of``: each design's name or file -> its Design; ``launch_of``: -> the launch
    settings its file states, _design_launch)."""
    from ..studies.paired import paired_cells
    from ..studies.report import comparison_table, plot_study, study_table
    from ..studies.summary import earlier_records, keep_written_text

    order = {(c.label, d): (i, j) for i, c in enumerate(cells) for j, d in enumerate(designs)}
    records = dict(sorted(records.items(), key=lambda kv: order.get(kv[0], (len(cells), 0))))
    stats = {k: r.stats for k, r in records.items() if r.stats.n}
    paired = {}
    for c in cells[1:]:
        for d in designs:
            got = paired_cells(records.get((cells[0].label, d)), records.get((c.label, d)))
            if got is not None:
                paired[(c.label, d)] = got
    outdir = Path(args.out)
    name = args.name or args.study
    title = f"study {args.study}: N = {args.samples} per cell, base seed {args.seed}"
    if args.study == "tumbling":
        from ..studies.tumbling import (attitude_table, plot_tumbling, policy_pairs,
                                        policy_table, rest_pairs, rest_table,
                                        tumbling_table)
        table = tumbling_table(designs, stats)
        policies = policy_pairs(designs, records)
        vs_rest = rest_pairs(designs, records)
        for part in (policy_table(policies), rest_table(vs_rest),
                     attitude_table(designs, cells, records, design_of),
                     attitude_table(designs, cells, records, design_of, at="closing")):
            if part:
                table += "\n" + part
    elif args.study == "launch":
        from ..studies.launch import launch_table
        table = launch_table(designs, cells, records)
    elif len(cells) == 2:
        table = comparison_table(designs, paired, cells[1].label)
    else:
        table = study_table(designs, cells, stats, paired)
    legend = "\n".join(f"- **{c.label}**: {c.what}" for c in cells)
    cmd = " ".join(["tethernet", "study"] + sys.argv[sys.argv.index("study") + 1:]) \
        if "study" in sys.argv else f"tethernet study {args.study}"
    md = (f"# {title}\n\nCommand: `{cmd}`\n\nBase configuration: integrator "
          f"{base.integrator}" + (f", step {base.implicit_dt:g} s, {base.implicit_iterations} sweeps"
                                  if base.integrator == "implicit" else "")
          + "".join(f".\n\n{d}: its launch settings {launch_of[d]} (its file's launch:) in "
                    "every cell" for d in designs if launch_of.get(d))
          + f".\n\nCells (a: {cells[0].label}" + (f", b: {cells[1].label}" if len(cells) == 2 else "")
          + "):\n" + legend + "\n\n" + table + "\n")
    (outdir / f"{name}.md").write_text(keep_written_text(outdir / f"{name}.md", md))
    summary = {"study": args.study, "samples": args.samples, "seed": args.seed,
               "designs": designs,
               **({"design_launch": {d: v for d, v in launch_of.items() if v}}
                  if any(launch_of.values()) else {}),
               "cells": [{"label": c.label, "what": c.what,
                                               "config": c.config.to_dict()} for c in cells],
               "stats": [r.to_json() for k, r in records.items() if r.stats.n],
               # cells of earlier runs this one did not cover (other cells, designs, seeds
               # or sample counts): kept, so that no run loses what another recorded
               "kept": earlier_records(outdir / f"{name}.json",
                                       [r for r in records.values() if r.stats.n]),
               "paired": [{"a": p.a.label, "b": p.b.label, "design": p.a.design, "flips": p.flips,
                           "a_only": p.a_only, "b_only": p.b_only, "mcnemar_p": p.mcnemar_p,
                           "p_diff": p.p_diff, "t_rel_diff": p.t_rel_diff,
                           "within_half_width": p.within_half_width} for p in paired.values()]}
    if args.study == "tumbling":
        summary["adaptive_vs_threshold"] = [
            {"axis": axis, "rate_deg_s": rate, "design": d, "p_diff": p.p_diff,
             "adaptive_only": p.b_only, "threshold_only": p.a_only, "mcnemar_p": p.mcnemar_p,
             "t_diff": p.t_diff} for (axis, rate, d), p in policies.items()]
        summary["tumble_vs_rest"] = [
            {"axis": axis, "rate_deg_s": rate, "policy": pol, "design": d,
             "p_diff": p.p_diff, "spun_only": p.b_only, "rest_only": p.a_only,
             "mcnemar_p": p.mcnemar_p, "t_diff": p.t_diff}
            for (axis, rate, pol, d), p in vs_rest.items()]
    if args.study == "launch":
        from ..studies.launch import launch_pairs, launch_summary
        summary["predictive_vs_immediate"] = launch_summary(launch_pairs(designs, cells,
                                                                         records))
    (outdir / f"{name}.json").write_text(json.dumps(json_clean(summary), indent=1))
    if args.study == "tumbling":
        plot_tumbling(designs, stats, outdir / f"{name}.png", title)
    elif args.study == "launch":
        from ..studies.launch import plot_launch
        plot_launch(designs, cells, stats, outdir / f"{name}.png", title)
    else:
        plot_study(designs, cells, stats, outdir / f"{name}.png", title)
    return md


def _from_file(specs, n_samples: int, base_seed: int, path: Path,
               extra_model: str | None = None) -> dict:
    """The samples of each spec already in the results file (seeds of samples
    0..n_samples-1, in index order), as MonteCarloResults by label."""
    from dataclasses import replace as dc_replace

    from ..montecarlo.keys import run_key
    from ..montecarlo.results_file import ResultsFile
    from ..montecarlo.seeds import sample_seed
    from ..montecarlo.summary import MonteCarloResult

    rf = ResultsFile(path)
    known = rf.load() if path.exists() else {}
    versions = [None] + sorted(rf.models) + ([extra_model] if extra_model else [])
    out = {}
    for spec in specs:
        samples, kept_key = [], None
        for version in versions:
            key = run_key(spec.design, spec.noise_model, spec.config, version)
            got = [dc_replace(known[(key, sample_seed(base_seed, i))], index=i)
                   for i in range(n_samples) if (key, sample_seed(base_seed, i)) in known]
            if len(got) > len(samples):
                samples, kept_key = got, key
        if samples:
            out[spec.label] = MonteCarloResult.from_samples(
                spec.design, samples, base_seed, kept_key, spec.config, label=spec.label)
    return out


def _compare(args, designs) -> int:
    """Paired table and figure of two results files (no simulation)."""
    from ..errors import UserError
    from ..studies.cells import Cell
    from ..studies.files import samples_by_design
    from ..studies.paired import CellStats, PairedStats
    from ..studies.report import comparison_table, plot_study

    if not (args.a and args.b):
        raise UserError("compare: --a FILE and --b FILE are both needed")
    labels = [x.strip() for x in args.labels.split(",")]
    if len(labels) != 2 or not all(labels) or labels[0] == labels[1]:
        raise UserError(f"--labels {args.labels!r}: two different labels, A,B")
    runs = []
    for path, key in ((args.a, args.key_a), (args.b, args.key_b)):
        if not Path(path).is_file():
            raise UserError(f"compare: results file {path!r} does not exist")
        try:
            runs.append(samples_by_design(path, key))
        except ValueError as exc:
            raise UserError(str(exc)) from None
    stats, paired, used = {}, {}, []
    for d in designs:
        if d not in runs[0] or d not in runs[1]:
            continue
        seeds = sorted({s.seed for s in runs[0][d]} & {s.seed for s in runs[1][d]})
        if args.samples:
            seeds = seeds[:args.samples]
        pick = [[s for s in run[d] if s.seed in set(seeds)] for run in runs]
        a = CellStats.from_samples(labels[0], d, pick[0])
        b = CellStats.from_samples(labels[1], d, pick[1])
        stats[(labels[0], d)], stats[(labels[1], d)] = a, b
        paired[(labels[1], d)] = PairedStats.from_samples(a, b, pick[0], pick[1])
        used.append(d)
    if not used:
        raise UserError("compare: the two files share no design of --designs "
                        f"({', '.join(designs)}) with samples of the same seeds (compare "
                        "reads the reference designs' samples only)")
    name = args.name or "compare"
    outdir = Path(args.out)
    outdir.mkdir(parents=True, exist_ok=True)
    cells = [Cell(labels[0], args.a, None), Cell(labels[1], args.b, None)]
    table = comparison_table(used, paired, labels[1])
    md = (f"# {name}: {labels[0]} (a) against {labels[1]} (b), paired by seed\n\n"
          f"- a: `{args.a}`\n- b: `{args.b}`\n\n{table}\n")
    (outdir / f"{name}.md").write_text(md)
    plot_study(used, cells, stats, outdir / f"{name}.png", f"{labels[0]} vs {labels[1]}")
    print(md)
    return 0
