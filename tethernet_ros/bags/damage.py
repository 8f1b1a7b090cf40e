"""Damaged copies of bags, to test and demonstrate damage-tolerant reading."""
from __future__ import annotations

import os
import shutil
from pathlib import Path


def copy_truncated(src: str | os.PathLike, dst: str | os.PathLike, fraction: float) -> Path:
    """Copy a bag folder with its .mcap cut to ``fraction`` (0..1) of its size in bytes."""
    src, dst = Path(src), Path(dst)
    shutil.copytree(src, dst)
    for f in dst.glob("*.mcap"):
        data = f.read_bytes()
        f.write_bytes(data[: int(len(data) * fraction)])
    return dst
