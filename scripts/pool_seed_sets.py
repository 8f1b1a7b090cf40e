"""One cell measured on several seed sets: the summaries of the same study (same cells,
same designs, same settings) run with other base seeds, pooled cell by cell.  One
markdown row per (cell, design) present in every summary: the successes of each seed set,
the pooled successes, P*_s and its Wilson 95 % interval, and the smallest and largest
P*_s of one seed set.  Seed sets of different base seeds never share a sample
(montecarlo/seeds.py), so the pooled sample is N = the sum of theirs.

Refused: two summaries with the same base seed, or a cell whose settings differ between
summaries (a field both configurations have, with other values).  A field only one of
them has (a setting added to the configuration after the other was run, at its default)
is listed under the table, as are cells whose run keys differ (another model version).
Used for docs/studies/launch-tilt.md.

    .venv/bin/python scripts/pool_seed_sets.py A.json B.json [C.json ...] [--design NAME]
"""
from __future__ import annotations

import argparse
import json
import sys

from tethernet_ros.core.metrics import wilson_interval
from tethernet_ros.studies.summary import CellRecord


def _flat(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flat(v, f"{prefix}{k}."))
        else:
            out[prefix + k] = v
    return out


def _configs(summary: dict) -> dict[str, dict]:
    return {str(c["label"]): _flat(c["config"]) for c in summary.get("cells", [])}


def compare_configs(a: dict, b: dict) -> tuple[list[str], list[str]]:
    """(fields with other values, fields only one configuration has) of two flattened
    configurations; values compared as JSON numbers (15 and 15.0 are one value)."""
    differ = sorted(k for k in set(a) & set(b) if a[k] != b[k])
    only = sorted(set(a) ^ set(b))
    return differ, only


def pool(paths: list[str], design: str | None = None) -> tuple[list[str], list[str]]:
    """(markdown rows, notes) of the cells every summary has."""
    summaries = [json.loads(open(p).read()) for p in paths]
    seeds = [int(s["seed"]) for s in summaries]
    if len(set(seeds)) != len(seeds):
        raise SystemExit(f"two summaries have the same base seed ({seeds}): their samples "
                         "are the same, not another seed set")
    cells = []
    for s in summaries:
        # this run's cells only ("stats"): the summary states their settings ("cells");
        # those kept from earlier runs ("kept") may be of other settings under one label
        cells.append({(str(r["label"]), str(r["design"])): r for r in s.get("stats", [])
                      if isinstance(r, dict) and "verdicts" in r
                      and (design is None or r["design"] == design)})
    configs = [_configs(s) for s in summaries]
    common = [k for k in cells[0] if all(k in c for c in cells[1:])]
    rows, notes = [], []
    only_fields: set[str] = set()
    other_keys = 0
    for label, dsg in common:
        recs = [c[(label, dsg)] for c in cells]
        for i in range(1, len(summaries)):
            if label not in configs[0] or label not in configs[i]:
                raise SystemExit(f"cell {label!r}: a summary does not state its settings")
            differ, only = compare_configs(configs[0][label], configs[i][label])
            if differ:
                raise SystemExit(f"cell {label!r}: settings differ between {paths[0]} and "
                                 f"{paths[i]}: {', '.join(differ)}")
            only_fields.update(only)
        if len({r["key"] for r in recs}) > 1:
            other_keys += 1
        stats = [CellRecord.from_json(r, label, dsg).stats for r in recs]   # (checks them)
        ks, ns = [st.successes for st in stats], [st.n for st in stats]
        k, n = sum(ks), sum(ns)
        lo, hi = wilson_interval(k, n)
        each = " | ".join(f"{a}/{b}" for a, b in zip(ks, ns))
        ps = [a / b for a, b in zip(ks, ns)]
        rows.append(f"| {label} | {each} | {k}/{n} | **{100 * k / n:.1f}** "
                    f"[{100 * lo:.1f}, {100 * hi:.1f}] | {100 * min(ps):.1f}-{100 * max(ps):.1f} |")
    if other_keys:
        notes.insert(0, f"run keys differ between seed sets in {other_keys} of {len(common)} "
                     "cells (a configuration with other fields, or another model version; "
                     "the settings they share are equal)")
    if only_fields:
        notes.insert(0, "fields only some configurations have (added later, at their "
                     "defaults): " + ", ".join(sorted(only_fields)))
    header = ("| cell | " + " | ".join(f"seed {s}" for s in seeds)
              + " | pooled | P*_s pooled % [95 %] | one set's P*_s % |")
    sep = "|---|" + "---|" * len(seeds) + "---|---|---|"
    return [header, sep, *rows], notes


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("summaries", nargs="+", help="study summaries (JSON), one per seed set")
    p.add_argument("--design", help="only this design (as the summaries name it)")
    args = p.parse_args(argv)
    if len(args.summaries) < 2:
        p.error("give at least two summaries")
    rows, notes = pool(args.summaries, args.design)
    print("\n".join(rows))
    for line in notes:
        print(f"- {line}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
