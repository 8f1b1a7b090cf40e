"""Reading results files in tests: the sample records, without the machine lines
(``montecarlo.results_file``)."""
from __future__ import annotations

import json
from pathlib import Path


def sample_lines(path, keepends: bool = False) -> list[str]:
    """The lines of a results file that are sample records."""
    lines = Path(path).read_text().splitlines(keepends=keepends)
    return [ln for ln in lines if not ln.startswith('{"machine_id"')]


def machine_lines(path) -> list[dict]:
    """The machine records of a results file."""
    return [json.loads(ln) for ln in Path(path).read_text().splitlines()
            if ln.startswith('{"machine_id"')]
