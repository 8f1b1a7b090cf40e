"""The success criterion against the tug test, per target (issue 36, point 3;
docs/studies/criterion.md): for each TARGET=DIR, the results files ``DIR/*.jsonl``
(written by ``tethernet validate --tug F``) pooled; selection set: even seeds, check
set: odd seeds (independent noise draws). Writes the table as markdown and the rows as JSON.

    .venv/bin/python scripts/criterion_report.py zenit-2=RUNS/tugstudy --out docs/studies/criterion
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tethernet_ros.studies.criterion import separation, separation_table, within_cells_table
from tethernet_ros.studies.files import samples_by_seed
from tethernet_ros.studies.report import write_report


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("cells", nargs="+", metavar="TARGET=DIR")
    p.add_argument("--out", default=None, metavar="PATH (no suffix)")
    args = p.parse_args(argv)
    rows, cells = [], {}
    for cell in args.cells:
        label, _, folder = cell.partition("=")
        samples = []
        for path in sorted(Path(folder).glob("*.jsonl")):
            some = list(samples_by_seed(path).values())
            cells[f"{label}: {path.stem}"] = some
            samples += some
        rows.append(separation(label, samples, lambda s: s.seed % 2 == 0))
    table = separation_table(rows) + "\n\n" + within_cells_table(cells)
    print(table)
    for r in rows:
        print(f"{r.label}: fitted {r.fitted.text()}; on the selection set source "
              f"{100 * r.source_selection.balanced_accuracy:.1f} %, fitted "
              f"{100 * r.fitted_selection.balanced_accuracy:.1f} %")
    if args.out:
        write_report(args.out, rows, table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
