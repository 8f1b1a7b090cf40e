"""Where a run's CPU goes (issue 33): the CPU of a run directory's episodes by optimiser
stage, by the verdict its design ends with and by the phase within an episode.

Pure accounting, no simulator: :func:`read_run` reads a run directory, :func:`draw_episodes`
picks the episodes to re-simulate for the split within an episode (the caller simulates
them, ``tethernet cost`` does), :func:`cost_tables` makes the three tables.  CPU in CPU
seconds (s) unless a name says hours; simulated time in s.

Two kinds of run directory:

* **records** (a run directory as ``tethernet optimize`` writes it: run.json,
  checkpoint.json, samples.jsonl, racing.jsonl, validation.jsonl): every episode's
  recorded process CPU time (``cpu_time``), its file giving its stage, its run key its
  design (checkpoint ``info["key"]``); exact.
* **history** (a ``history.csv`` and the ``results.md`` beside it, as docs/cases/ keeps a
  finished run: ``RUN/history.csv`` or ``PREFIX-history.csv`` with ``PREFIX-results.md``):
  no CPU is recorded, so a design's CPU is estimated as its simulated time (samples x mean
  T, T being an episode's simulated length) times the CPU per simulated second measured on
  the re-simulated episodes; episodes are the samples each observation rests on (those
  drawn past a decision within a batch are not in the history); racing and validation
  samples are read from results.md.

Verdicts: a design is *best* when it was raced or validated, else *feasible* when observed
feasible, else *infeasible, decided early* when its sampling stopped before N samples
(docs/optimizer.md §3) or *infeasible at N* when it took them all.  Episode phases (from
re-simulating a sample of the run's episodes, drawn with probability proportional to their
CPU, or to their simulated time where no CPU is recorded): *flight* from launch to the
first contact with the target (or to closing start, if earlier), *wrapping* from first
contact to closing start (to the horizon when closing never starts), *settle* the episode's
last ``settle_time`` s, which start at closing start (docs/model.md §7).
"""
from __future__ import annotations

import csv
import json
import math
import random
import re
from dataclasses import dataclass, field
from pathlib import Path

from .checkpoint import CheckpointError, load_checkpoint
from .settings import fresh_base_seed

__all__ = ["CostError", "Unit", "RunCost", "Draw", "read_run", "draw_episodes", "cost_tables",
           "cost_text", "STAGES", "VERDICTS", "EPISODE_PHASES"]

STAGES = ("seed points", "BO iterations", "racing", "validation", "not in the history")
VERDICTS = ("infeasible, decided early", "infeasible at N", "feasible",
            "best: raced or validated", "not in the history")
#: an episode's phases: the wait before a launch policy fires (docs/model.md §16), the
#: flight to the first contact, the wrapping to closing, the settle after it
EPISODE_PHASES = ("wait", "flight", "wrapping", "settle")
OTHER = "not in the history"
RECORD_FILES = {"samples.jsonl": None, "racing.jsonl": "racing", "validation.jsonl": "validation"}


class CostError(ValueError):
    """A run directory cannot be accounted (message: one line naming the path)."""


@dataclass
class Unit:
    """Episodes of one design in one stage: one record (records) or one history row or
    results.md row (history).  ``cpu_s`` None where not recorded; ``sim_s`` simulated
    seconds; ``design``: a record's design dict or a history row's design vector;
    ``seed``: a record's noise seed, else None and ``base_seed`` the base seed of its
    samples 0..episodes-1."""

    stage: str
    verdict: str
    episodes: int
    cpu_s: float | None
    sim_s: float
    evaluation: int | None = None
    design: object = None
    seed: int | None = None
    base_seed: int | None = None
    fidelity: str = "reference"


@dataclass
class RunCost:
    """A run directory read for accounting: ``source`` "records" or "history", its
    ``units``, ``settings`` (run.json, or {} where there is none) and ``notes``."""

    path: Path
    source: str
    units: list[Unit]
    settings: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def cpu_recorded(self) -> bool:
        return self.source == "records"


@dataclass(frozen=True)
class Draw:
    """One episode to re-simulate: its ``design`` (dict or vector), noise ``seed`` or
    (``base_seed``, ``index``), its ``fidelity`` and ``unit`` (index into the run's
    units)."""

    unit: int
    design: object
    seed: int | None
    base_seed: int | None
    index: int
    fidelity: str = "reference"


def read_run(path: str | Path) -> RunCost:
    """The run at ``path``: a run directory with records, a directory with history.csv,
    or a history.csv file (module docstring).  CostError naming the path otherwise."""
    path = Path(path)
    if path.is_file() and path.name.endswith("history.csv"):
        return _read_history(path, Path(str(path)[:-len("history.csv")] + "results.md"),
                             path.parent / "run.json")
    if not path.is_dir():
        raise CostError(f"{path}: no such run directory (nor a history.csv file)")
    if (path / "samples.jsonl").is_file():
        return _read_records(path)
    if (path / "history.csv").is_file():
        return _read_history(path / "history.csv", path / "results.md", path / "run.json")
    raise CostError(f"{path}: not a run directory (neither samples.jsonl with checkpoint.json "
                    "nor history.csv in it)")


def _settings(path: Path, required: bool) -> dict:
    if not path.is_file():
        if required:
            raise CostError(f"{path}: missing, so the run's settings are unknown")
        return {}
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (ValueError, OSError) as exc:
        raise CostError(f"{path}: unreadable run settings ({exc})") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("samples"), int):
        raise CostError(f"{path}: not a run settings file (no integer 'samples')")
    return doc


def _verdict(feasible: bool, samples: int, planned: int, best: bool) -> str:
    if best:
        return VERDICTS[3]
    if feasible:
        return VERDICTS[2]
    return VERDICTS[0] if samples < planned else VERDICTS[1]


def _read_records(run_dir: Path) -> RunCost:
    settings = _settings(run_dir / "run.json", required=True)
    try:
        history = load_checkpoint(run_dir / "checkpoint.json")["optimizer"]["history"]
        evals = [(int(h["info"]["samples"]), bool(h["feasible"]), str(h["info"]["key"]),
                  str(h.get("acquisition", {}).get("phase", "")), list(h["x"]),
                  str(h["info"].get("fidelity", "reference"))) for h in history]
    except CheckpointError as exc:
        raise CostError(str(exc)) from None
    except (KeyError, TypeError, ValueError) as exc:
        raise CostError(f"{run_dir / 'checkpoint.json'}: an evaluation lacks {exc} "
                        "(samples, feasible, key)") from None
    by_key: dict[str, int] = {}
    for i, (_, _, key, *_) in enumerate(evals, 1):
        by_key.setdefault(key, i)
    records, skipped = {}, 0
    for name in RECORD_FILES:
        records[name], bad = _records(run_dir / name)
        skipped += bad
    best_keys = {r["key"] for name in ("racing.jsonl", "validation.jsonl") for r in records[name]}
    planned = settings["samples"]
    units = []
    for name, stage in RECORD_FILES.items():
        for r in records[name]:
            ev = by_key.get(r["key"])
            design, fidelity = r["design"], "reference"
            if ev is None:
                st, verdict = stage or OTHER, OTHER
            else:
                samples, feasible, key, phase, x, fid = evals[ev - 1]
                st = stage or (STAGES[0] if phase == "initial" else STAGES[1])
                verdict = _verdict(feasible, samples, planned, key in best_keys)
                design = design if design is not None else x
                fidelity = fid if stage is None else "reference"
            units.append(Unit(st, verdict, 1, r["cpu_time"], r["completion_time"], ev,
                              design, r["seed"], fidelity=fidelity))
    notes = [f"CPU: each episode's recorded process CPU time ({', '.join(RECORD_FILES)})"]
    if skipped:
        notes.append(f"{skipped} unreadable record line(s) skipped (a run killed while "
                     "writing leaves one)")
    return RunCost(run_dir, "records", units, settings, notes)


def _records(path: Path) -> tuple[list[dict], int]:
    """A results file's sample records (key, seed, cpu_time, completion_time, design) and
    the count of unreadable lines; [] when the file is absent."""
    if not path.is_file():
        return [], 0
    out, bad = [], 0
    with path.open(encoding="utf-8") as fh:
        for n, line in enumerate(fh, 1):
            line = line.strip()
            if not line:
                continue
            try:
                rec = json.loads(line)
            except ValueError:
                bad += 1
                continue
            if not isinstance(rec, dict) or "seed" not in rec or "key" not in rec:
                if not (isinstance(rec, dict) and "machine_id" in rec):
                    bad += 1
                continue
            r = {"key": str(rec["key"]), "seed": rec["seed"], "design": rec.get("design")}
            for f in ("cpu_time", "completion_time"):
                v = rec.get(f)
                if v is None:
                    v = 0.0
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not v >= 0:
                    raise CostError(f"{path} line {n}: field {f!r} is {v!r}; must be a number "
                                    ">= 0 (s)")
                r[f] = float(v) if math.isfinite(v) else 0.0
            out.append(r)
    return out, bad


def _read_history(history: Path, results: Path, run_json: Path) -> RunCost:
    settings = _settings(run_json, required=False)
    try:
        with history.open(encoding="utf-8", newline="") as fh:
            rows = list(csv.DictReader(fh))
        head = list(rows[0]) if rows else []
        names = head[head.index("phase") + 1:head.index("objective")]
        evals = [(int(r["evaluation"]), r["phase"], int(r["samples"]), r["feasible"] == "1",
                  _float(r["mean_completion_time"]), [float(r[k]) for k in names],
                  r.get("fidelity") or "reference") for r in rows]
    except (OSError, ValueError, KeyError, TypeError, IndexError) as exc:
        raise CostError(f"{history}: not a run's history.csv ({exc!r})") from None
    if not evals:
        raise CostError(f"{history}: holds no evaluation")
    planned = int(settings.get("samples") or max(e[2] for e in evals))
    sample_seed = int(settings.get("sample_seed", 1))
    fresh = bool(settings.get("fresh_samples", False))
    raced, validated, notes = _read_results(results)
    best = {ev for ev, _ in raced} | {ev for ev, _, _ in validated if ev is not None}
    mean_t = {e[0]: e[4] for e in evals}
    x = {e[0]: e[5] for e in evals}
    units = []
    for ev, phase, n, feasible, t, xv, fid in evals:
        units.append(Unit(STAGES[0] if phase == "initial" else STAGES[1],
                          _verdict(feasible, n, planned, ev in best), n, None, n * t, ev, xv,
                          base_seed=fresh_base_seed(sample_seed, ev) if fresh else sample_seed,
                          fidelity=fid))
    for ev, n in raced:
        if ev not in mean_t:
            raise CostError(f"{results}: raced evaluation {ev} is not in {history}")
        units.append(Unit(STAGES[2], VERDICTS[3], n, None, n * mean_t[ev], ev, x[ev],
                          base_seed=int(settings.get("racing_seed", 2))))
    for ev, n, t in validated:
        if ev is not None and ev not in mean_t:
            raise CostError(f"{results}: validated evaluation {ev} is not in {history}")
        units.append(Unit(STAGES[3], VERDICTS[3] if ev is not None else OTHER, n, None,
                          n * (t if math.isfinite(t) else mean_t.get(ev, 0.0)), ev,
                          x.get(ev), base_seed=int(settings.get("validation_seed", 0))))
    notes = ["CPU: not recorded in a history; estimated as each design's simulated time "
             "(samples x mean T) x the CPU per simulated second measured on the re-simulated "
             "episodes", "episodes: the samples each observation rests on (history.csv); "
             "samples drawn past a decision within a batch are not counted"] + notes
    return RunCost(history, "history", units, settings, notes)


def _float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        return 0.0
    return v if math.isfinite(v) else 0.0


_CANDIDATE = re.compile(r"candidate \(evaluation (\d+)\)")
_N = re.compile(r"\(N=(\d+)")


def _read_results(path: Path) -> tuple[list, list, list[str]]:
    """results.md's raced designs [(evaluation, racing samples)] and validations
    [(evaluation or None for a reference design, samples, validated mean T)]."""
    if not path.is_file():
        return [], [], [f"no {path.name} beside the history: racing and validation not counted"]
    lines = path.read_text(encoding="utf-8").splitlines()
    best = next((int(m.group(1)) for ln in lines
                 if (m := re.match(r"Best design = evaluation (\d+)\.", ln))), None)
    raced, validated, table, size = [], [], None, None
    for n, ln in enumerate(lines, 1):
        if not ln.startswith("|"):
            table = None
            continue
        cells = [c.strip() for c in ln.strip("|").split("|")]
        if cells[0] == "design" and len(cells) > 4 and cells[4].startswith("validated"):
            table, m = "designs", _N.search(cells[4])
            size = int(m.group(1)) if m else None
            continue
        if cells[0] == "evaluation" and len(cells) > 3 and cells[3] == "samples":
            table = "racing"
            continue
        if cells[0].startswith("---") or table is None:
            continue
        try:
            if table == "racing":
                raced.append((int(cells[0]), int(cells[3])))
            elif table == "designs" and len(cells) >= 7 and cells[4] not in ("not validated", ""):
                label = cells[0]
                m = _CANDIDATE.search(label)
                ev = (int(m.group(1)) if m else best if label.startswith("best")
                      else None if label.startswith("reference") else -1)
                if ev == -1:
                    continue                # the source's Table 4 row: not simulated here
                m = _N.search(cells[4])
                samples = int(m.group(1)) if m else size
                if samples is None:
                    raise ValueError("no sample count")
                validated.append((ev, samples, _float(cells[6]) if cells[6] else math.nan))
        except (ValueError, IndexError) as exc:
            raise CostError(f"{path} line {n}: unreadable {table} row ({exc})") from None
    return raced, validated, []


def draw_episodes(run: RunCost, k: int, seed: int = 0) -> list[Draw]:
    """``k`` episodes of the run, drawn with replacement with probability proportional to
    their recorded CPU (records) or their simulated time (history), for re-simulation."""
    weights = [(u.cpu_s if run.cpu_recorded else u.sim_s) or 0.0 for u in run.units]
    if k <= 0 or not any(w > 0 for w in weights):
        return []
    rng = random.Random(seed)
    out = []
    for i in rng.choices(range(len(run.units)), weights=weights, k=k):
        u = run.units[i]
        index = rng.randrange(u.episodes)
        out.append(Draw(i, u.design, u.seed, u.base_seed, index, u.fidelity))
    return out


def _phase_estimates(run: RunCost, draws: list[Draw], measured: list[dict]) -> dict:
    """The run's CPU in each episode phase (s) with its standard error, from ``measured``
    (per draw: CPU s in each phase of its re-simulation, and ``sim_s``)."""
    if run.cpu_recorded:
        total = sum(u.cpu_s or 0.0 for u in run.units)
    else:
        total = sum(u.sim_s for u in run.units)
    z = {p: [] for p in (*EPISODE_PHASES, "total")}
    for d, m in zip(draws, measured):
        u = run.units[d.unit]
        per = (sum(m[p] for p in EPISODE_PHASES) if run.cpu_recorded
               else u.sim_s / u.episodes)
        for p in EPISODE_PHASES:
            z[p].append(total * m[p] / per if per > 0 else 0.0)
        z["total"].append(sum(z[p][-1] for p in EPISODE_PHASES))
    out = {}
    for p, v in z.items():
        mean = sum(v) / len(v)
        sd = math.sqrt(sum((a - mean) ** 2 for a in v) / (len(v) - 1)) if len(v) > 1 else math.nan
        out[p] = (mean, sd / math.sqrt(len(v)))
    return out


def _rows(groups: dict, names, episodes_total: int | None = None) -> list[dict]:
    total = sum(g[0] for g in groups.values())
    rows = []
    for name in names:
        if name not in groups:
            continue
        cpu, eps, *se = groups[name]
        n = episodes_total if episodes_total is not None else eps
        row = {"name": name, "cpu_h": cpu / 3600, "share": cpu / total if total else math.nan,
               "episodes": n, "cpu_s_per_episode": cpu / n if n else math.nan}
        if se:
            row["cpu_h_se"] = se[0] / 3600
        rows.append(row)
    return rows


def cost_tables(run: RunCost, draws: list[Draw] = (), measured: list[dict] = ()) -> dict:
    """The three tables (lists of rows: name, cpu_h, share, episodes, cpu_s_per_episode)
    and what they rest on.  Without ``measured`` (per draw: CPU s of wait, flight, wrapping,
    settle and ``sim_s``) there is no episode-phase table, and a history's CPU is unknown
    (its shares are then of simulated time and its CPU columns NaN)."""
    phases = _phase_estimates(run, list(draws), list(measured)) if measured else None
    if run.cpu_recorded:
        cpu = [u.cpu_s or 0.0 for u in run.units]
        basis = "recorded CPU"
    elif phases:
        sim = sum(u.sim_s for u in run.units)
        rate, rate_se = (phases["total"][0] / sim, phases["total"][1] / sim) if sim else (0, 0)
        cpu = [u.sim_s * rate for u in run.units]
        basis = (f"simulated time x {rate:.4f} (SE {rate_se:.4f}) CPU-s per simulated s, "
                 f"measured on {len(measured)} re-simulated episodes")
    else:
        cpu = [u.sim_s for u in run.units]
        basis = "simulated time (no CPU recorded and none measured)"
    by_stage, by_verdict = {}, {}
    for u, c in zip(run.units, cpu):
        for groups, key in ((by_stage, u.stage), (by_verdict, u.verdict)):
            g = groups.setdefault(key, [0.0, 0])
            g[0] += c
            g[1] += u.episodes
    episodes = sum(u.episodes for u in run.units)
    out = {"run": str(run.path), "source": run.source, "basis": basis, "notes": list(run.notes),
           "unit": "simulated h" if basis.startswith("simulated time (") else "CPU-h",
           "cpu_h": sum(cpu) / 3600, "episodes": episodes,
           "simulated_h": sum(u.sim_s for u in run.units) / 3600,
           "stages": _rows(by_stage, STAGES), "verdicts": _rows(by_verdict, VERDICTS),
           "episode_phases": None, "phase_episodes_measured": len(measured)}
    if phases:
        out["episode_phases"] = _rows({p: [phases[p][0], episodes, phases[p][1]]
                                       for p in EPISODE_PHASES}, EPISODE_PHASES, episodes)
        out["notes"].append(
            f"episode phases: measured by re-simulating {len(measured)} of the run's episodes "
            "(drawn in proportion to their " + ("recorded CPU" if run.cpu_recorded else
                                                "simulated time")
            + ") on this machine and core, timing each phase; CPU-s per episode is per "
            "episode of the run")
    return out


def cost_text(tables: dict) -> str:
    """The tables for people."""
    cpu = tables["unit"] == "CPU-h"
    head, per = ("CPU-h", "CPU-s/ep") if cpu else ("sim-h", "sim-s/ep")
    lines = [f"{tables['run']}: " + (f"{tables['cpu_h']:.2f} CPU-h over " if cpu else "")
             + f"{tables['episodes']} episodes ({tables['simulated_h']:.1f} simulated h); "
             f"{'CPU from ' if cpu else 'shares of '}{tables['basis']}"]
    for title, key in (("optimiser stage", "stages"), ("design verdict", "verdicts"),
                       ("episode phase", "episode_phases")):
        rows = tables[key]
        if rows is None:
            lines += ["", f"{title}: not measured (--phases K re-simulates K episodes)"]
            continue
        lines += ["", f"{title:<28} {head:>12} {'share':>7} {'episodes':>9} {per:>9}"]
        for r in rows:
            cpu = f"{r['cpu_h']:.3f}" + (f" ±{r['cpu_h_se']:.3f}" if "cpu_h_se" in r else "")
            lines.append(f"{r['name']:<28} {cpu:>12} {100 * r['share']:>6.1f}% "
                         f"{r['episodes']:>9} {r['cpu_s_per_episode']:>9.3f}")
    lines += [""] + [f"note: {n}" for n in tables["notes"]]
    return "\n".join(lines)
