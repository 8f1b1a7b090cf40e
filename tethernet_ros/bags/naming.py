"""The bag naming rule, in one place.

A bag is a folder ``<bag_dir>/<name>/`` holding ``metadata.yaml`` and ``<name>_0.mcap``.
While it is recorded it is ``<bag_dir>/<name>.partial/`` with an ``INCOMPLETE`` marker
file; it gets its final name (marker removed) only when it is complete.  A name is 1 to
200 letters, digits, '_', '-' or '.', not starting with '.'.  Names made up here:
``capture_<date>-<time>_<seed|nominal>_<hex>`` for a capture and
``mc_<design key>_seed<N>_a<attempt>_<hex>`` for a Monte Carlo sample.
"""
from __future__ import annotations

import re
import secrets
import time
from pathlib import Path

MARKER = "INCOMPLETE"
PARTIAL_SUFFIX = ".partial"
NAME = re.compile(r"[A-Za-z0-9_\-][A-Za-z0-9_.\-]{0,199}")
NAME_RULE = "use up to 200 letters, digits, '_', '-' or '.', not starting with '.'"


class BagError(Exception):
    """A bag cannot be opened, named or written (one line)."""


def check_name(name: str) -> str:
    """``name`` if it is a valid bag name, else BagError saying the rule."""
    if not NAME.fullmatch(name or "") or name.endswith(PARTIAL_SUFFIX):
        raise BagError(f"bag name {name!r}: {NAME_RULE} (and not ending in {PARTIAL_SUFFIX!r})")
    return name


def partial_path(final: Path) -> Path:
    """Where the bag ``final`` is recorded until it is complete."""
    return final.with_name(final.name + PARTIAL_SUFFIX)


def storage_file(name: str) -> str:
    """The MCAP file of bag ``name``, as rosbag2 names its first storage file."""
    return f"{name}_0.mcap"


def taken(bag_dir: Path, name: str) -> Path | None:
    """The folder that already holds bag ``name`` (complete or partial), or None."""
    for path in (bag_dir / name, partial_path(bag_dir / name)):
        if path.exists():
            return path
    return None


def capture_name(seed: int | None) -> str:
    """A fresh name for one capture (seed None: nominal)."""
    return (time.strftime("capture_%Y%m%d-%H%M%S_")
            + ("nominal" if seed is None else f"seed{seed}") + "_" + secrets.token_hex(2))


def sample_name(design_key: str, seed: int, attempt: int) -> str:
    """A fresh name for one Monte Carlo sample's bag."""
    return f"mc_{design_key[:12]}_seed{seed}_a{attempt}_{secrets.token_hex(3)}"
