"""The tug study's report (issue 36, point 2; docs/studies/tug.md): for each results file
``<dir>/<design>_<attitude>.jsonl`` (written by ``tethernet validate --tug F``), the
confusion between the source's verdict and the tug test's (``studies/tug.py``); writes
the table as markdown and the cells as JSON.

    .venv/bin/python scripts/tug_confusion.py DIR --out docs/studies/tug
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tethernet_ros.core.tug import TugConfig, breaking_load
from tethernet_ros.studies.files import samples_by_seed
from tethernet_ros.studies.report import write_report
from tethernet_ros.studies.tug import confusion, confusion_table


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("dir")
    p.add_argument("--out", default=None, metavar="PATH (no suffix)")
    p.add_argument("--tether-radius", type=float, default=0.002, metavar="M",
                   help="the main tether's radius, for its breaking load (default 2 mm)")
    args = p.parse_args(argv)
    rows = []
    for path in sorted(Path(args.dir).glob("*.jsonl")):
        samples = list(samples_by_seed(path).values())
        if samples:
            rows.append(confusion(path.stem, samples,
                                  breaking_load(TugConfig(), args.tether_radius)))
    table = confusion_table(rows)
    print(table)
    if args.out:
        write_report(args.out, rows, table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
