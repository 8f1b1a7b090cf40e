"""Paired statistics of the cells two study summaries share (common random numbers): the
same cell label and design, the same base seed and number of samples, another setting
(e.g. the launch study under another ``--launch-max-tilt``).  One markdown row per cell
of B: P*_s of A and of B with B's Wilson 95 % interval, B's mean wait and mean T, the
flips (A only / B only) and McNemar's exact p; with ``--reference WORD`` also B against
A's cell whose label ends in WORD instead (the launch study's immediate launch).  Used
for docs/studies/launch-tilt.md.

    .venv/bin/python scripts/pair_summaries.py A.json B.json [--reference immediate]
"""
from __future__ import annotations

import argparse
import json
import sys

from tethernet_ros.studies.paired import paired_cells
from tethernet_ros.studies.summary import CellRecord, cell_entries


def cell_records(path: str) -> dict[tuple[str, str], CellRecord]:
    """A summary's cells that keep their verdicts, by (label, design)."""
    out = {}
    for rec in cell_entries(json.loads(open(path).read())):
        if "verdicts" not in rec:
            continue
        key = (str(rec["label"]), str(rec["design"]))
        out.setdefault(key, CellRecord.from_json(rec, *key))
    return out


def _pct(x: float) -> str:
    return f"{100 * x:.1f}"


def _same_samples(a, b):
    """Cell record ``a`` when it has ``b``'s base seed (so the pair is over the same
    samples), else None."""
    return a if a is not None and a.base_seed == b.base_seed else None


def _pair_text(pair) -> str:
    if pair is None:
        return "- | -"
    return f"{pair.a_only} / {pair.b_only} | {pair.mcnemar_p:.2g}"


def table(a: dict, b: dict, label_a: str, label_b: str, reference: str | None) -> list[str]:
    head = (f"| design | cell | P*_s {label_a} % | P*_s {label_b} % [95 %] | mean wait (s) | "
            f"mean T (s) | flips {label_a} / {label_b} | McNemar p |")
    cols = 8
    if reference:
        head += f" P*_s {reference} % | flips {reference} / {label_b} | McNemar p |"
        cols += 3
    rows = [head, "|" + "---|" * cols]
    for (label, design), rb in b.items():
        ra = _same_samples(a.get((label, design)), rb)
        s = rb.stats
        row = (f"| {design} | {label} | {_pct(ra.stats.p) if ra else '-'} | {_pct(s.p)} "
               f"[{_pct(s.lo)}, {_pct(s.hi)}] | {s.mean_wait:.1f} | {s.mean_t:.2f} | "
               f"{_pair_text(paired_cells(ra, rb))} |")
        if reference:
            ref_label = " ".join(label.split()[:-1] + [reference])
            rr = _same_samples(a.get((ref_label, design)), rb)
            row += (f" {_pct(rr.stats.p) if rr else '-'} | {_pair_text(paired_cells(rr, rb))} |")
        rows.append(row)
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("a", help="the first summary (.json)")
    p.add_argument("b", help="the second summary (.json): one row per cell")
    p.add_argument("--label-a", default="a")
    p.add_argument("--label-b", default="b")
    p.add_argument("--reference", default=None, metavar="WORD",
                   help="also pair B's cells with A's whose label's last word is WORD")
    args = p.parse_args(argv)
    a, b = cell_records(args.a), cell_records(args.b)
    if not b:
        print(f"{args.b}: no cell keeps its verdicts", file=sys.stderr)
        return 2
    print("\n".join(table(a, b, args.label_a, args.label_b, args.reference)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
