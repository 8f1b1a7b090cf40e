"""Resumable results: an append-only JSON-lines file of sample records.

Each sample's result is appended as one JSON object per line as soon as it finishes
(written, flushed and fsync'ed).  A record carries ``key``, the run key (a hash of
everything that determines the episode: design, noise model, simulation config, seed
mapping and the source of ``tethernet_ros/core``), and the ``seed``; re-running with the
same file skips every (key, seed) already there, so a killed run resumes where it stopped
and a larger run reuses a smaller one.  A partial last line (the process was killed while
writing it) is cut off before appending.  One file may hold records of several designs;
records with another key are kept and ignored.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

from optimizer.jsonio import json_clean

from .records import SampleResult


class ResultsFile:
    """Append-only JSON-lines file of :class:`SampleResult` records (see module doc)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.skipped_lines = 0

    def records(self):
        """Every readable record in file order, as (the raw JSON object, its
        :class:`SampleResult`); unreadable lines are counted in ``skipped_lines``."""
        self.skipped_lines = 0
        if not self.path.exists():
            return
        with self.path.open("r", encoding="utf-8") as f:
            for line in f:
                line = line.strip()
                if not line:
                    continue
                try:
                    rec = json.loads(line)
                    r = SampleResult.from_record(rec)
                except (ValueError, TypeError, KeyError):
                    self.skipped_lines += 1
                    continue
                yield rec, r

    def load(self) -> dict[tuple[str, int], SampleResult]:
        """Records by (key, seed); a record with a trace wins over one without, else the
        later one.  A partial last line is cut off the file; unreadable lines are skipped."""
        out: dict[tuple[str, int], SampleResult] = {}
        if not self.path.exists():
            return out
        self._repair_tail()
        for _rec, r in self.records():
            k = (r.key, r.seed)
            if k in out and out[k].trace is not None and r.trace is None:
                continue
            out[k] = r
        return out

    def _repair_tail(self) -> None:
        with self.path.open("rb+") as f:
            f.seek(0, os.SEEK_END)
            size = f.tell()
            if size == 0:
                return
            f.seek(size - 1)
            if f.read(1) == b"\n":
                return
            # find the last newline; everything after it is a partial record
            pos = size
            block = 65536
            while pos > 0:
                start = max(0, pos - block)
                f.seek(start)
                chunk = f.read(pos - start)
                i = chunk.rfind(b"\n")
                if i >= 0:
                    f.truncate(start + i + 1)
                    return
                pos = start
            f.truncate(0)

    def append(self, result: SampleResult, extra: dict | None = None) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        rec = result.to_record()
        if extra:
            rec.update(json_clean(extra))
        line = json.dumps(rec, separators=(",", ":"), allow_nan=False)
        with self.path.open("a", encoding="utf-8") as f:
            f.write(line + "\n")
            f.flush()
            os.fsync(f.fileno())

