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

The report's Markdown keeps what follows :data:`KEEP_MARK` in an existing report (the
hand-written findings), so that rewriting the tables after each cell loses none of it.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

from ..montecarlo.seeds import sample_seed
from .paired import CellStats

#: a line in a study's report after which the text is written by hand and kept
KEEP_MARK = "<!-- written by hand below this line; `tethernet study` keeps it -->"

_STAT_FIELDS = ("n", "successes", "p", "lo", "hi", "mean_t", "failures")


@dataclass(frozen=True)
class Verdict:
    """One sample's verdict: its noise seed and whether the capture succeeded."""

    seed: int
    success: bool


@dataclass(frozen=True)
class CellRecord:
    """One cell of one design as the summary keeps it: statistics, run key, base seed and
    verdicts in sample order."""

    stats: CellStats
    key: str
    base_seed: int
    verdicts: tuple[Verdict, ...]

    @classmethod
    def from_samples(cls, label: str, design: str, key: str, base_seed: int,
                     samples) -> CellRecord:
        """From the cell's samples (``SampleResult``, index order)."""
        return cls(CellStats.from_samples(label, design, samples), key, base_seed,
                   tuple(Verdict(int(s.seed), bool(s.success)) for s in samples))

    def to_json(self) -> dict:
        return {**vars(self.stats), "key": self.key, "seed": self.base_seed,
                "verdicts": "".join("1" if v.success else "0" for v in self.verdicts)}

    @classmethod
    def from_json(cls, rec: dict, label: str, design: str) -> CellRecord:
        """A recorded cell under this run's ``label`` and ``design`` name."""
        base = int(rec["seed"])
        bits = str(rec["verdicts"])
        if set(bits) - {"0", "1"}:
            raise ValueError("verdicts must be a string of 0 and 1")
        verdicts = tuple(Verdict(sample_seed(base, i), b == "1") for i, b in enumerate(bits))
        fields = {f: rec[f] for f in _STAT_FIELDS}
        fields["mean_t"] = math.nan if fields["mean_t"] is None else float(fields["mean_t"])
        stats = CellStats(label, design, **fields)
        if stats.n != len(verdicts) or stats.successes != sum(v.success for v in verdicts):
            raise ValueError(f"cell {rec.get('label')!r}: n and successes disagree with its "
                             "verdicts")
        return cls(stats, str(rec["key"]), base, verdicts)


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
    for rec in data.get("stats", []) if isinstance(data, dict) else []:
        try:
            if int(rec["seed"]) != base_seed or int(rec["n"]) != n_samples:
                continue
            CellRecord.from_json(rec, str(rec["label"]), str(rec["design"]))   # readable
        except (KeyError, TypeError, ValueError):
            continue
        out[str(rec["key"])] = rec
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
