"""A study's summary file (``<out>/<study>.json``): what its report shows, and enough of
every cell to take the study up again without its results file.

Results files hold one record per episode and stay out of git (``out/``); the summary is
small and is committed beside the report (docs/studies).  Each cell of each design
records, besides its statistics (:class:`~.paired.CellStats`), its run key
(:func:`tethernet_ros.montecarlo.keys.run_key`: design, noise model, configuration and
model version), its base seed and its verdicts in sample order ('1' a success, '0' a
failure).  A later run of the same study with the same base seed, number of samples and
run key takes the cell from the summary instead of simulating it, so a study longer than
one machine's session advances across sessions: each writes every cell it finishes, and
the next simulates only the rest.  A changed model (another run key) is simulated again.
A run never drops what an earlier one recorded: cells it does not cover (other cells,
designs, seeds or sample counts) stay in the file under ``kept``.  A cell is reused only
when its verdicts are those of samples 0..N-1; one read with gaps from an interrupted
results file (``--report-only``) is shown but written without verdicts.

The report's Markdown keeps what follows :data:`KEEP_MARK` in an existing report (the
hand-written findings), so that rewriting the tables after each cell loses none of it.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

from ..core.metrics import wilson_interval
from ..montecarlo.seeds import sample_seed
from .paired import CellStats

#: a line in a study's report after which the text is written by hand and kept
KEEP_MARK = "<!-- written by hand below this line; `tethernet study` keeps it -->"


@dataclass(frozen=True)
class Verdict:
    """One sample's verdict: its noise seed and whether the capture succeeded."""

    seed: int
    success: bool


@dataclass(frozen=True)
class CellRecord:
    """One cell of one design as the summary keeps it: statistics, run key, base seed,
    verdicts in sample order, the CPU seconds its episodes took (their sum, as the
    results file recorded them; for planning what remains, :func:`plan_text`) and each
    sample's closing time (s of simulated time, NaN where closing never started; None
    when not known: a summary written before they were kept, and no results file)."""

    stats: CellStats
    key: str
    base_seed: int
    verdicts: tuple[Verdict, ...]
    cpu_time: float = 0.0
    closing_times: tuple[float, ...] | None = None

    @classmethod
    def from_samples(cls, label: str, design: str, key: str, base_seed: int,
                     samples) -> CellRecord:
        """From the cell's samples (``SampleResult``, index order)."""
        cpu = sum(float(s.cpu_time) for s in samples if math.isfinite(float(s.cpu_time)))
        return cls(CellStats.from_samples(label, design, samples), key, base_seed,
                   tuple(Verdict(int(s.seed), bool(s.success)) for s in samples), cpu,
                   _closing_times(samples))

    def with_closing_times_from(self, results: dict) -> CellRecord:
        """This record with its samples' closing times taken from a results file's records
        (``ResultsFile.load()``: (key, seed) -> SampleResult) when it has none and the file
        holds every one of its samples under its key; else this record."""
        if self.closing_times is not None:
            return self
        got = [results.get((self.key, v.seed)) for v in self.verdicts]
        if not got or any(r is None for r in got):
            return self
        return replace(self, closing_times=_closing_times(got))

    @property
    def complete_prefix(self) -> bool:
        """Whether the verdicts are those of samples 0..n-1 of the base seed (a cell read
        from an interrupted results file may have gaps): only such a cell is reusable."""
        return all(v.seed == sample_seed(self.base_seed, i) for i, v in enumerate(self.verdicts))

    def to_json(self) -> dict:
        """The summary's entry; a cell with gaps is written without its verdicts (shown in
        the report, never reused)."""
        out = {**vars(self.stats), "key": self.key, "seed": self.base_seed,
               "cpu_time": self.cpu_time}
        if out["mean_wait"] == 0.0:
            del out["mean_wait"]        # (an immediate launch: as summaries before it)
        if self.complete_prefix:
            out["verdicts"] = "".join("1" if v.success else "0" for v in self.verdicts)
            if self.closing_times is not None:
                out["closing_times"] = [t if math.isfinite(t) else None
                                        for t in self.closing_times]
        return out

    @classmethod
    def from_json(cls, rec: dict, label: str, design: str) -> CellRecord:
        """A recorded cell under this run's ``label`` and ``design`` name."""
        base = int(rec["seed"])
        bits = str(rec["verdicts"])
        if set(bits) - {"0", "1"}:
            raise ValueError("verdicts must be a string of 0 and 1")
        verdicts = tuple(Verdict(sample_seed(base, i), b == "1") for i, b in enumerate(bits))
        n, k = len(verdicts), sum(v.success for v in verdicts)
        if int(rec["n"]) != n or int(rec["successes"]) != k:
            raise ValueError(f"cell {rec.get('label')!r}: n and successes disagree with its "
                             "verdicts")
        mean_t = rec["mean_t"]
        failures = rec["failures"]
        if not isinstance(failures, dict):
            raise ValueError("failures must be a mapping")
        lo, hi = wilson_interval(k, n)            # from the verdicts, not from the file
        wait = rec.get("mean_wait", 0.0)     # (a summary before launch policies: no wait)
        stats = CellStats(label, design, n, k, k / n if n else math.nan, lo, hi,
                          math.nan if mean_t is None else float(mean_t), dict(failures),
                          math.nan if wait is None else float(wait))
        times = rec.get("closing_times")
        if times is not None:
            if not isinstance(times, list) or len(times) != n:
                raise ValueError(f"cell {rec.get('label')!r}: closing_times must be a list of "
                                 f"{n} times (s) or nulls")
            times = tuple(math.nan if t is None else float(t) for t in times)
        return cls(stats, str(rec["key"]), base, verdicts, float(rec.get("cpu_time", 0.0)),
                   times)


def _closing_times(samples) -> tuple[float, ...]:
    """Each sample's closing time (s), NaN where closing never started."""
    out = []
    for s in samples:
        t = s.closing_time
        out.append(math.nan if t is None or not math.isfinite(float(t)) else float(t))
    return tuple(out)


def reusable_cells(path: str | Path, base_seed: int, n_samples: int) -> dict[str, dict]:
    """Recorded cells of a summary file that a run with ``base_seed`` and ``n_samples``
    can take as they are, by run key (the raw JSON objects; :meth:`CellRecord.from_json`
    names them).  Cells of another seed or size, cells written before summaries kept
    their verdicts, and unreadable entries are left out; a missing or unreadable file
    gives none."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    out = {}
    for rec in cell_entries(data):
        try:
            if int(rec["seed"]) != base_seed or int(rec["n"]) != n_samples:
                continue
            CellRecord.from_json(rec, str(rec["label"]), str(rec["design"]))   # readable
        except (KeyError, TypeError, ValueError):
            continue
        out[str(rec["key"])] = rec
    return out


def cell_entries(data) -> list:
    """The cell entries of a summary's JSON: this run's ("stats") and earlier runs'
    ("kept"); none when the file holds something else."""
    if not isinstance(data, dict):
        return []
    out = []
    for part in ("stats", "kept"):
        got = data.get(part)
        if isinstance(got, list):
            out += [e for e in got if isinstance(e, dict)]
    return out


def earlier_records(path: str | Path, records) -> list[dict]:
    """The entries of the summary at ``path`` that ``records`` (this run's CellRecords) do
    not replace: another run key, base seed or sample count, in file order, once each."""
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return []
    mine = {(r.key, r.base_seed, r.stats.n) for r in records}
    out, seen = [], set()
    for e in cell_entries(data):
        try:
            ident = (str(e["key"]), int(e["seed"]), int(e["n"]))
        except (KeyError, TypeError, ValueError):
            continue
        if ident not in mine and ident not in seen:
            seen.add(ident)
            out.append(e)
    return out


def keep_written_text(path: str | Path, generated: str) -> str:
    """``generated`` followed by what an existing report at ``path`` holds after
    :data:`KEEP_MARK` (the mark itself is written either way)."""
    kept = ""
    path = Path(path)
    if path.exists():
        old = path.read_text()
        i = old.find(KEEP_MARK)
        if i >= 0:
            kept = old[i + len(KEEP_MARK):]
    return generated.rstrip("\n") + "\n\n" + KEEP_MARK + (kept if kept else "\n")


def plan_text(study: str, designs: list[str], cells: list[str], n_samples: int,
              records: dict, in_results: dict, workers: int) -> str:
    """What a study still has to simulate, without simulating: cells recorded (``records``,
    (cell, design) -> CellRecord), samples already in the results file (``in_results``,
    (cell, design) -> count), the episodes left per design and their CPU time at each
    design's recorded CPU seconds per episode (the mean over all recorded designs for a
    design without any; none when nothing is recorded yet)."""
    left = {d: sum(n_samples - in_results.get((c, d), 0) for c in cells
                   if (c, d) not in records) for d in designs}
    per_ep = {}
    for d in designs:
        mine = [r for (c, dd), r in records.items() if dd == d and r.cpu_time > 0]
        if mine:
            per_ep[d] = sum(r.cpu_time for r in mine) / sum(r.stats.n for r in mine)
    everyone = [r for r in records.values() if r.cpu_time > 0]
    fallback = (sum(r.cpu_time for r in everyone) / sum(r.stats.n for r in everyone)
                if everyone else None)
    lines = [f"study {study}: {len(cells)} cells x {len(designs)} designs, N = {n_samples}",
             f"recorded in the summary: {len(records)} of {len(cells) * len(designs)} "
             f"(cell, design) pairs; samples in the results file beside them: "
             f"{sum(in_results.values())}",
             "| design | episodes left | CPU-s per episode | CPU-hours left |", "|---|---|---|---|"]
    total_h, unknown = 0.0, False
    for d in designs:
        cost = per_ep.get(d, fallback)
        if cost is None:
            unknown = True
            lines.append(f"| {d} | {left[d]} | - | - |")
            continue
        hours = left[d] * cost / 3600
        total_h += hours
        lines.append(f"| {d} | {left[d]} | {cost:.2f}{'' if d in per_ep else ' (all designs)'} "
                     f"| {hours:.2f} |")
    n_left = sum(left.values())
    if unknown:
        lines.append(f"{n_left} episodes left; no CPU time recorded yet: run a cell first")
    else:
        lines.append(f"{n_left} episodes left, about {total_h:.1f} CPU-hours: "
                     f"{total_h / max(1, workers):.1f} h of wall time on {max(1, workers)} "
                     "worker(s)")
    return "\n".join(lines)
