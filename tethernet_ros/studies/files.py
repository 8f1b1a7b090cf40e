"""Study cells read back from Monte Carlo results files (``tethernet validate`` or a study's
own), for comparing runs made at different commits or with different commands.

A results file's records name their design (the ``design`` field each record carries);
records are matched to the reference designs by that design and, between two files, by
seed.  A file holding several run keys for one design (several configurations) is
ambiguous and refused.
"""
from __future__ import annotations

from collections import defaultdict
from pathlib import Path

from ..core.design import REFERENCE_DESIGNS, Design
from ..montecarlo import ResultsFile, SampleResult


def samples_by_seed(path: str | Path) -> dict[int, SampleResult]:
    """seed -> SampleResult of every record in a results file (a later record of the same
    seed replaces an earlier one), whatever its design or run key."""
    return {r.seed: r for _, r in ResultsFile(path).records()}


def samples_by_design(path: str | Path, key: str | None = None) -> dict[str, list[SampleResult]]:
    """The samples of each reference design in a results file, ordered by seed (one record
    per seed; a later record of the same seed replaces an earlier one); ``key``: only the
    records whose run key starts with one of its comma-separated prefixes."""
    prefixes = tuple(k.strip() for k in key.split(",") if k.strip()) if key else ()
    names = {d.to_dict().__repr__(): n for n, d in REFERENCE_DESIGNS.items()}
    by: dict[str, dict[int, SampleResult]] = defaultdict(dict)
    keys: dict[str, set] = defaultdict(set)
    for rec, r in ResultsFile(path).records():
        try:
            design = Design.from_dict(rec["design"])
        except (ValueError, TypeError, KeyError):
            continue
        name = names.get(design.to_dict().__repr__())
        if name is None or (prefixes and not r.key.startswith(prefixes)):
            continue
        keys[name].add(r.key)
        by[name][r.seed] = r
    for name, ks in keys.items():
        if len(ks) > 1:
            raise ValueError(f"results file {str(path)!r}: design {name!r} has records of "
                             f"{len(ks)} run keys (configurations: {sorted(ks)}); choose one "
                             "with --key-a / --key-b (a prefix)")
    return {name: [recs[s] for s in sorted(recs)] for name, recs in by.items()}
