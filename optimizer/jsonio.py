"""The project's two JSON rules, in one place (the optimiser's files and the Monte Carlo
results alike use them):

* :func:`json_clean` -- strict JSON values: a non-finite float becomes ``null``, numpy
  scalars and arrays become Python numbers and lists, tuples become lists, mapping keys
  become strings;
* :func:`atomic_write_text` / :func:`atomic_write_json` -- a file is written to a temporary
  file in the same directory, flushed and fsync'ed, then moved over the target with
  :func:`os.replace`, so a crash at any moment leaves either the previous complete file or
  the new one, never a half-written file.

Standard library only, so importing it costs nothing.
"""
from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any
from collections.abc import Mapping

__all__ = ["json_clean", "atomic_write_text", "atomic_write_json"]


def json_clean(obj: Any) -> Any:
    """Strict-JSON copy of ``obj`` (see the module docstring); other values unchanged."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, Mapping):
        return {str(k): json_clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_clean(v) for v in obj]
    if hasattr(obj, "tolist") and callable(obj.tolist):  # numpy scalar or array
        return json_clean(obj.tolist())
    return obj


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Replace ``path`` by ``text`` (UTF-8) atomically; parent directories are created."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def atomic_write_json(path: str | os.PathLike, obj: Any, indent: int | None = 1) -> None:
    """:func:`atomic_write_text` of ``obj`` after :func:`json_clean` (strict JSON)."""
    atomic_write_text(path, json.dumps(json_clean(obj), indent=indent, allow_nan=False))
