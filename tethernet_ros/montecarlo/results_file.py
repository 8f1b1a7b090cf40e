"""Resumable results: an append-only JSON-lines file of sample records.

Each sample's result is appended as one JSON object per line as soon as it finishes
(written, flushed and fsync'ed).  A record carries ``key``, the run key (a hash of
everything that determines the episode: design, noise model, simulation config, seed
mapping and the source of ``tethernet_ros/core``), and the ``seed``; re-running with the
same file skips every (key, seed) already there, so a killed run resumes where it stopped
and a larger run reuses a smaller one.  A partial last line (the process was killed while
writing it) is cut off before appending.  One file may hold records of several designs;
records with another key are kept and ignored.

Every record names the machine that computed it (``machine_id``), and the file holds one
line ``{"machine_id": ..., "machine": {...}}`` with the facts of each such machine
(:mod:`tethernet_ros.machine`): a file written on several machines says so when it is
read (:meth:`ResultsFile.machine_summary`).
"""
from __future__ import annotations

import json
import os
from pathlib import Path

from optimizer.jsonio import json_clean

from .. import machine
from .records import SampleResult


class ResultsFile:
    """Append-only JSON-lines file of :class:`SampleResult` records (see module doc)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.skipped_lines = 0
        #: machine_id -> facts of the machines named in the file (filled by records())
        self.machines: dict[str, dict] = {}
        #: model versions (``keys.model_version``) that wrote to the file
        self.models: set[str] = set()
        self._machine_written = False

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
                    if "machine" in rec and "seed" not in rec:
                        self.machines[str(rec["machine_id"])] = dict(rec["machine"])
                        if rec.get("model"):
                            self.models.add(str(rec["model"]))
                        continue
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
        from .keys import model_version

        facts = machine.machine_facts()
        mid = machine.machine_id(facts)
        lines = []
        if not self._machine_written:
            if self.path.exists():
                for _ in self.records():
                    pass
            if mid not in self.machines or model_version() not in self.models:
                lines.append({"machine_id": mid, "machine": facts, "model": model_version()})
                self.machines[mid] = facts
                self.models.add(model_version())
            self._machine_written = True
        rec = result.to_record()
        if extra:
            rec.update(json_clean(extra))
        rec["machine_id"] = mid
        lines.append(rec)
        text = "".join(json.dumps(r, separators=(",", ":"), allow_nan=False) + "\n"
                       for r in lines)
        with self.path.open("a", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())

    def machine_counts(self, keys=None) -> dict[str, int]:
        """Samples per machine_id (records of ``keys`` only, if given; records written
        before machine ids existed count under '')."""
        counts: dict[str, int] = {}
        for rec, r in self.records():
            if keys is None or r.key in keys:
                mid = str(rec.get("machine_id", ""))
                counts[mid] = counts.get(mid, 0) + 1
        return counts

    def machine_summary(self, keys=None) -> str:
        """One line when the samples (of ``keys``) come from another machine than this one
        or from several machines, saying how their facts differ; '' otherwise."""
        counts = self.machine_counts(keys)
        here = machine.machine_facts()
        mid_here = machine.machine_id(here)
        others = {m: n for m, n in counts.items() if m != mid_here}
        if not others:
            return ""
        parts = []
        for m, n in sorted(others.items()):
            facts = self.machines.get(m)
            if not facts:
                parts.append(f"{n} sample(s) from a machine whose facts were not recorded")
                continue
            diff = machine.describe(facts, here, "them")
            parts.append(f"{n} sample(s) from machine {m} ({diff or 'same facts'})")
        mixed = len(counts) > 1
        head = (f"{self.path}: samples from {len(counts)} machines" if mixed
                else f"{self.path}: samples from another machine")
        return head + ": " + "; ".join(parts)

