"""Atomic JSON checkpoint I/O for the optimiser.

A checkpoint is one JSON document, written atomically (:mod:`optimizer.jsonio`: a crash
at any moment leaves either the previous complete checkpoint or the new complete one on
disk, never a half-written file). A file that is nevertheless
unreadable (truncated by a copy, edited by hand, ...) raises :class:`CheckpointError`
whose message names the file.

Floats are written with Python's ``repr`` (shortest round-trip form), so every value,
including the random generator state (arbitrary-size integers), is restored bit for bit.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from .jsonio import atomic_write_text

#: Value of the ``"format"`` key of every checkpoint written by this package.
CHECKPOINT_FORMAT = "tethernet_ros.optimizer.checkpoint"
#: Version of the layout; bump when the state layout changes incompatibly.
CHECKPOINT_VERSION = 1


class CheckpointError(RuntimeError):
    """A checkpoint file is missing, corrupt, truncated or of an unknown layout."""


def save_checkpoint(path: str | os.PathLike, state: dict[str, Any]) -> None:
    """Write ``state`` (JSON-serialisable dict) to ``path`` atomically
    (:func:`optimizer.jsonio.atomic_write_text`).

    The keys ``format`` and ``version`` are added. Parent directories are created.
    """
    doc = {"format": CHECKPOINT_FORMAT, "version": CHECKPOINT_VERSION, **state}
    atomic_write_text(path, json.dumps(doc, indent=1))


def load_checkpoint(path: str | os.PathLike) -> dict[str, Any]:
    """Read a checkpoint written by :func:`save_checkpoint`.

    Raises :class:`CheckpointError` (message names the file) if the file is missing,
    is not valid JSON (e.g. truncated), or is not a checkpoint of this layout.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise CheckpointError(f"checkpoint file {str(path)!r} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CheckpointError(f"cannot read checkpoint file {str(path)!r}: {exc}") from exc
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise CheckpointError(
            f"checkpoint file {str(path)!r} is corrupt or truncated "
            f"({len(text)} bytes; JSON error: {exc}); delete it to start afresh"
        ) from exc
    if not isinstance(doc, dict) or doc.get("format") != CHECKPOINT_FORMAT:
        raise CheckpointError(
            f"file {str(path)!r} is not an optimiser checkpoint "
            f"(expected format {CHECKPOINT_FORMAT!r})"
        )
    if doc.get("version") != CHECKPOINT_VERSION:
        raise CheckpointError(
            f"checkpoint file {str(path)!r} has layout version {doc.get('version')!r}; "
            f"this code reads version {CHECKPOINT_VERSION}"
        )
    return doc
