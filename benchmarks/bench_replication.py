"""Replication benchmark of the final choice (issue 21 point 4): does the design a run
chooses truly meet C_P, at what regret and cost?

The problem has a known truth and fails as the simulator does
(:class:`optimizer.testproblems.LatentDifficulty`: minimise x1 + x2 over [0, 1]^2 s.t.
P_s(x) = Phi(-c1(x)/0.1) >= 0.98; sample i fails design x when its shared difficulty u_i
>= P_s(x), so nearby designs fail on the same samples).  ``--dims 4`` adds two variables
that lower P_s away from 0.5 without entering the objective: near-copies of one
objective and different reliability, as on Case 1's edge.  Every replication is a whole run
of Case 1 through :func:`optimizer.run.run_optimization` (seed design, model-based
iterations, sequential sampling, racing, validations in turn); replication r uses
optimiser seed r and its own sample, validation and racing seeds, the same for every
method, so the methods are compared on the same luck.

Methods (``--methods``, comma-separated):

  estimate       the source's rule: common random numbers, validations by their estimate
  wilson         the Wilson rule alone (common random numbers, no racing)
  racing+fresh   Wilson rule + racing + fresh samples for every design
  racing+shared  Wilson rule + racing + common random numbers whose shared luck the
                 constraint model takes into account
  racing+fresh+level  racing+fresh, ranking and clearing against the P*_s at which the
                 validation passes half the time (``selection_level`` "validation")
  racing         Wilson rule + racing (common random numbers, independent model)
  fresh          Wilson rule + fresh samples (no racing)
  shared         Wilson rule + the shared-luck model (no racing)

``--explore-fidelity`` searches (seed points and model-based iterations) at the problem's
exploration fidelity, whose verdicts differ from the truth's by a stated discrepancy
(``--explore-jitter``: how often a verdict flips, 0.5 near the simulator's 2 ms step;
``--explore-shift``: a bias of the probit, > 0 optimistic), and races and validates at
the reference, as ``tethernet optimize --explore-fidelity exploration`` does.
``--racing-max-samples M`` caps each raced candidate's samples (default: the
validation's size).
``--pair FILE`` prints, per method, the paired difference of this file's replications
from the records of FILE run under the same settings but for these two (the same
replication numbers: the same luck), regret with its standard
error and the truly-feasible count of each.

Each finished replication is appended to ``--out`` (JSON lines) at once; a rerun skips
the (method, replication) pairs already there with the same configuration, so a killed
benchmark resumes (after a change of the optimiser, start another ``--out``).
``--table`` prints the table of the file without running.

    .venv/bin/python benchmarks/bench_replication.py [--replications 30] [--methods ...]
        [--out out/bench/replication.jsonl] [--seed-points 10] [--iterations 60]
        [--explore-fidelity [--explore-jitter 0.5] [--explore-shift 0]]
        [--table] [--markdown] [--pair OTHER.jsonl]
"""
from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
# one BLAS thread: the GP's matrices are small, and a second thread only contends for the
# cores (set before numpy loads OpenBLAS)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from optimizer.cases import CASE_MASS  # noqa: E402
from optimizer.observation import wilson_interval  # noqa: E402
from optimizer.run import run_optimization  # noqa: E402
from optimizer.settings import RunSettings  # noqa: E402
from optimizer.testproblems import LatentDifficulty  # noqa: E402

METHODS = {
    "estimate": dict(validation_rule="estimate", racing_candidates=0, fresh_samples=False,
                     shared_luck=False),
    "wilson": dict(validation_rule="wilson", racing_candidates=0, fresh_samples=False,
                   shared_luck=False),
    "racing+fresh": dict(validation_rule="wilson", fresh_samples=True, shared_luck=False),
    "racing+shared": dict(validation_rule="wilson", fresh_samples=False, shared_luck=True),
    "racing+fresh+level": dict(validation_rule="wilson", fresh_samples=True, shared_luck=False,
                               selection_level="validation"),
    "racing": dict(validation_rule="wilson", fresh_samples=False, shared_luck=False),
    "fresh": dict(validation_rule="wilson", racing_candidates=0, fresh_samples=True,
                  shared_luck=False),
    "shared": dict(validation_rule="wilson", racing_candidates=0, fresh_samples=False,
                   shared_luck=True),
}
#: the objective's margins reported beside the regret: f*(C) - f*(0.98)
MARGIN_LEVELS = (0.985, 0.99)


_CODE: dict = {}


def code_version() -> str:
    """A hash of the optimiser's source as this process loaded it (read once)."""
    if "code" not in _CODE:
        h = hashlib.sha256()
        for f in sorted((ROOT / "optimizer").glob("*.py")):
            h.update(f.name.encode() + b"\0" + f.read_bytes())
        _CODE["code"] = h.hexdigest()[:12]
    return _CODE["code"]


def configuration(args) -> dict:
    """What decides a replication's result besides its method, its number and the code
    (each record carries a hash of the optimiser's source, ``code``; the table says when
    a file mixes several: start another ``--out`` after changing the optimiser)."""
    return {"seed_points": args.seed_points, "iterations": args.iterations,
            "samples": args.samples, "validation_samples": args.validation_samples,
            "validation_candidates": args.validation_candidates,
            "racing_candidates": args.racing_candidates, "racing_round": args.racing_round,
            "racing_budget": args.racing_budget, "gp_restarts": args.gp_restarts,
            **({"racing_max_samples": args.racing_max_samples}
               if args.racing_max_samples else {}),
            "candidates": args.candidates, "problem": problem_of(args).settings(),
            "search_fidelity": search_fidelity(args)}


def search_fidelity(args) -> dict | None:
    """None when the search runs at the reference; else the exploration's discrepancy."""
    if not args.explore_fidelity:
        return None
    return {"fidelity": "exploration", "jitter": args.explore_jitter,
            "shift": args.explore_shift}


def problem_of(args) -> LatentDifficulty:
    return LatentDifficulty(dims=args.dims, penalty=args.penalty,
                            jitter=args.explore_jitter, shift=args.explore_shift)


def settings_for(method: str, r: int, args) -> RunSettings:
    """Replication ``r`` of ``method``: optimiser seed r; samples, validation and racing
    of base seeds 3r + 1, 3r + 2, 3r + 3 (fresh samples above 1 000 000)."""
    options = {"n_restarts_gp": args.gp_restarts}
    if args.candidates:
        options["n_candidates"] = args.candidates
    fields = dict(iterations=args.iterations, seed_points=args.seed_points,
                  samples=args.samples, validation_samples=args.validation_samples,
                  validation_candidates=args.validation_candidates, seed=r,
                  sample_seed=3 * r + 1, validation_seed=3 * r + 2, racing_seed=3 * r + 3,
                  racing_candidates=args.racing_candidates, racing_round=args.racing_round,
                  racing_budget=args.racing_budget,
                  racing_max_samples=args.racing_max_samples, optimizer_options=options)
    if args.explore_fidelity:
        fields["fidelity"] = {"initial": "exploration", "iterations": "exploration"}
    return RunSettings(**{**fields, **METHODS[method]})


def replicate(method: str, r: int, args, truth: dict) -> dict:
    """One whole run; what it chose, against the truth."""
    problem = problem_of(args)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        s = run_optimization(CASE_MASS, problem, settings_for(method, r, args),
                             run_dir=Path(tmp) / "run")
    wall = time.perf_counter() - t0
    rows = [row for row in s["table"] if row["evaluation"]]
    validation = s["validation"]
    passed = bool(validation and validation["meets_requirement"])
    x = s["best_vector"]
    p_true = problem.success_probability(x) if x is not None else None
    race = s.get("racing") or {}
    return {
        "method": method, "replication": r, "config": configuration(args),
        "code": code_version(),
        "chosen_evaluation": s["best_evaluation"], "x": x,
        "objective": s["best_objective"], "p_true": p_true,
        "truly_meets": bool(p_true is not None and p_true >= CASE_MASS.p_threshold),
        "regret": (s["best_objective"] - truth["f_star"]) if x is not None else None,
        "validation_passed": passed, "validations": len(rows),
        "validations_failed": len(rows) - (1 if passed else 0),
        "episodes": s["episodes"], "episodes_racing": s["episodes_racing"],
        "episodes_validation": s["episodes_validation"], "episodes_total": s["episodes_total"],
        "racing_rounds": race.get("rounds"), "racing_stopped_by": race.get("stopped_by"),
        "racing_dropped": sum(e["status"] == "dropped" for e in race.get("entries", [])),
        "feasible_evaluations": s["feasible_evaluations"], "wall_s": wall,
    }


def load(path: Path) -> list[dict]:
    if not path.exists():
        return []
    out = []
    for line in path.read_text().splitlines():
        try:
            out.append(json.loads(line))
        except ValueError:          # a line cut short by a kill
            continue
    return out


def append(path: Path, record: dict) -> None:
    """One line, one write (O_APPEND), flushed to disk; after a line cut short by a kill
    it starts a new line."""
    path.parent.mkdir(parents=True, exist_ok=True)
    cut = path.exists() and path.stat().st_size and not path.read_bytes().endswith(b"\n")
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        os.write(fd, (("\n" if cut else "") + json.dumps(record) + "\n").encode())
        os.fsync(fd)
    finally:
        os.close(fd)


def _mean(values) -> float:
    values = [v for v in values if v is not None]
    return sum(values) / len(values) if values else math.nan


def _quantile(values, q: float) -> float:
    values = sorted(v for v in values if v is not None)
    if not values:
        return math.nan
    i = min(len(values) - 1, max(0, math.ceil(q * len(values)) - 1))
    return values[i]


def table(records: list[dict], truth: dict, markdown: bool) -> str:
    """Per method: the share of runs whose chosen design truly meets C_P [Wilson 95 %],
    the regret (mean, median, 90th percentile), the episodes (optimisation, racing,
    validation, all) and the validations failed before a pass."""
    head = ["method", "runs", "truly meets C_P [95 %]", "no validation passed",
            "regret mean", "median", "90 %", "episodes: optimisation", "racing",
            "validation", "all", "validations failed before a pass (mean, max)",
            "first validation passes"]
    lines = []
    for method in METHODS:
        rs = [r for r in records if r["method"] == method]
        if not rs:
            continue
        n = len(rs)
        k = sum(r["truly_meets"] for r in rs)
        lo, hi = wilson_interval(k, n)
        passed = [r for r in rs if r["validation_passed"]]
        before = [r["validations_failed"] for r in passed]
        lines.append([
            method, str(n), f"{k}/{n} = {100 * k / n:.0f} % [{100 * lo:.0f}, {100 * hi:.0f}]",
            str(n - len(passed)),
            f"{_mean(r['regret'] for r in rs):.4f}", f"{_quantile([r['regret'] for r in rs], .5):.4f}",
            f"{_quantile([r['regret'] for r in rs], .9):.4f}",
            f"{_mean(r['episodes'] for r in rs):.0f}",
            f"{_mean(r['episodes_racing'] for r in rs):.0f}",
            f"{_mean(r['episodes_validation'] for r in rs):.0f}",
            f"{_mean(r['episodes_total'] for r in rs):.0f}",
            f"{_mean(before):.2f}, {max(before) if before else 'n/a'}",
            f"{sum(r['validation_passed'] and r['validations_failed'] == 0 for r in rs)}/{n}"])
    margins = ", ".join(f"f*({c:g}) - f*(0.98) = {truth['margins'][str(c)]:.4f}"
                        for c in MARGIN_LEVELS)
    foot = (f"f*(0.98) = {truth['f_star']:.4f} (the true optimum); the margin that "
            f"confidence costs: {margins}")
    codes = sorted({r.get("code") for r in records})
    foot += (f"; optimiser source {codes[0]}" if len(codes) == 1
             else f"; WARNING: records of {len(codes)} optimiser sources: {codes}")
    return render(head, lines, markdown) + ("\n\n" if markdown else "\n") + foot


def render(head: list[str], lines: list[list[str]], markdown: bool) -> str:
    """A table: markdown, or columns padded to their widest cell."""
    if markdown:
        out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        return "\n".join(out + ["| " + " | ".join(row) + " |" for row in lines])
    widths = [max([len(h), *(len(row[i]) for row in lines)]) for i, h in enumerate(head)]
    out = ["  ".join(h.ljust(w) for h, w in zip(head, widths))]
    return "\n".join(out + ["  ".join(c.ljust(w) for c, w in zip(row, widths))
                            for row in lines])


def paired(records: list[dict], others: list[dict], markdown: bool) -> str:
    """Per method, over the replications in both: this file's regret minus the other's
    (mean, its standard error, how many are lower / equal / higher) and the truly
    feasible choices of each."""
    head = ["method", "pairs", "regret this - other: mean", "standard error",
            "lower / same / higher", "truly meets C_P: this", "other"]
    by_other = {(r["method"], r["replication"]): r for r in others}
    lines = []
    for method in METHODS:
        pairs = [(r, by_other[(method, r["replication"])]) for r in records
                 if r["method"] == method and (method, r["replication"]) in by_other]
        if not pairs:
            continue
        d = [a["regret"] - b["regret"] for a, b in pairs
             if a["regret"] is not None and b["regret"] is not None]
        n = len(d)
        mean = sum(d) / n if n else math.nan
        se = (math.sqrt(sum((v - mean) ** 2 for v in d) / (n - 1) / n) if n > 1
              else math.nan)
        lines.append([method, str(len(pairs)), f"{mean:+.4f}", f"{se:.4f}",
                      f"{sum(v < -1e-12 for v in d)} / {sum(abs(v) <= 1e-12 for v in d)} / "
                      f"{sum(v > 1e-12 for v in d)}",
                      f"{sum(a['truly_meets'] for a, _ in pairs)}/{len(pairs)}",
                      f"{sum(b['truly_meets'] for _, b in pairs)}/{len(pairs)}"])
    return render(head, lines, markdown)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--replications", type=int, default=30)
    ap.add_argument("--first", type=int, default=0, help="first replication number")
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--out", default="out/bench/replication.jsonl")
    ap.add_argument("--dims", type=int, default=2,
                    help="variables; those past the second act on P_s only (default 2)")
    ap.add_argument("--penalty", type=float, default=0.4,
                    help="how strongly the variables past the second lower P_s")
    ap.add_argument("--seed-points", type=int, default=10)
    ap.add_argument("--iterations", type=int, default=60)
    ap.add_argument("--samples", type=int, default=100)
    ap.add_argument("--validation-samples", type=int, default=1000)
    ap.add_argument("--validation-candidates", type=int, default=10)
    ap.add_argument("--racing-candidates", type=int, default=5)
    ap.add_argument("--racing-round", type=int, default=100)
    ap.add_argument("--racing-budget", type=int, default=2000)
    ap.add_argument("--racing-max-samples", type=int, default=0,
                    help="racing samples of one candidate, at most (0: the validation's)")
    ap.add_argument("--gp-restarts", type=int, default=0,
                    help="GP fit restarts (default 0: in two dimensions restarts rarely "
                         "change a fit, and they triple its cost; runs use 2)")
    ap.add_argument("--candidates", type=int, default=0, help="acquisition candidates (0: default)")
    ap.add_argument("--explore-fidelity", action="store_true",
                    help="search at the exploration fidelity; race and validate at the "
                         "reference")
    ap.add_argument("--explore-jitter", type=float, default=0.5,
                    help="the exploration's own noise on a verdict, in [0, 1) (default 0.5: "
                         "flip rates near the simulator's 2 ms step)")
    ap.add_argument("--explore-shift", type=float, default=0.0,
                    help="the exploration's bias on the probit scale, in [-3, 3] (> 0 "
                         "optimistic; default 0)")
    ap.add_argument("--pair", default=None,
                    help="another results file: print the paired differences from it")
    ap.add_argument("--table", action="store_true", help="print the file's table, run nothing")
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args(argv)
    code_version()
    methods = [m for m in args.methods.split(",") if m]
    bad = sorted(set(methods) - set(METHODS))
    if bad:
        ap.error(f"--methods: unknown {bad}; known: {', '.join(METHODS)}")
    if not args.explore_fidelity and (args.explore_jitter != ap.get_default("explore_jitter")
                                      or args.explore_shift != ap.get_default("explore_shift")):
        ap.error("--explore-jitter and --explore-shift apply only with --explore-fidelity")
    path = Path(args.out)
    try:
        problem = problem_of(args)
    except ValueError as e:         # its message starts with the field's name
        field = str(e).split(":", 1)[0]
        flag = {"jitter": "explore-jitter", "shift": "explore-shift"}.get(field, field)
        ap.error(f"--{flag}{str(e)[len(field):]}")
    truth = {"f_star": problem.optimum(CASE_MASS.p_threshold),
             "margins": {str(c): problem.optimum(c) - problem.optimum(CASE_MASS.p_threshold)
                         for c in MARGIN_LEVELS}}
    config = configuration(args)
    records = [r for r in load(path) if r.get("config") == config]
    if not args.table:
        done = {(r["method"], r["replication"]) for r in records}
        for r in range(args.first, args.first + args.replications):
            for method in methods:
                if (method, r) in done:
                    continue
                rec = replicate(method, r, args, truth)
                append(path, rec)
                records.append(rec)
                print(f"{method:14s} replication {r:3d}: chose {rec['chosen_evaluation']}, "
                      f"p_true {rec['p_true'] if rec['p_true'] is None else round(rec['p_true'], 4)}, "
                      f"regret {rec['regret'] if rec['regret'] is None else round(rec['regret'], 4)}, "
                      f"{rec['validations']} validations, {rec['episodes_total']} episodes, "
                      f"{rec['wall_s']:.0f} s", flush=True)
    wanted = set(range(args.first, args.first + args.replications))
    shown = [r for r in records if r["method"] in methods and r["replication"] in wanted]
    print(table(shown, truth, args.markdown))
    if args.pair:
        print(f"\npaired with {args.pair} (this minus that, the same replications):")
        varied = ("search_fidelity", "racing_max_samples")
        same = {k: v for k, v in config.items() if k not in varied}
        others = [r for r in load(Path(args.pair))
                  if {k: v for k, v in r.get("config", {}).items()
                      if k not in varied} == same]
        print(paired(shown, others, args.markdown))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
