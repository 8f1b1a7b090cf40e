"""The machine facts that decide whether two runs are comparable bit for bit.

An episode is bit-identical on every x86-64 machine that runs the pinned wheels (the
README's reproducibility paragraph, docs/model.md §13): its path uses IEEE operations,
numba code without fast-math and :mod:`tethernet_ros.core.detmath`, and no BLAS, LAPACK
or CPU-dispatched numpy function.  What can still differ between machines is recorded
here: the architecture and the versions of the libraries that compute an episode, and,
for the optimiser (whose Gaussian process uses BLAS and LAPACK), the CPU's features and
the kernel OpenBLAS chose.  Results files and run directories store these facts, and a
resume or a read on a machine whose facts differ says so.
"""
from __future__ import annotations

import hashlib
import json
import os
import platform
from functools import lru_cache

#: environment variables that change which code paths numpy, OpenBLAS or numba take
ENV_VARIABLES = ("NPY_DISABLE_CPU_FEATURES", "NPY_ENABLE_CPU_FEATURES", "OPENBLAS_CORETYPE",
                 "OPENBLAS_L2_SIZE", "NUMBA_CPU_NAME", "NUMBA_CPU_FEATURES", "NUMBA_FASTMATH")

#: the facts that decide whether an episode is the same bit for bit
EPISODE_FACTS = ("arch", "python", "numpy", "numba", "llvmlite", "scipy", "mpmath")


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def _blas() -> str:
    """numpy's BLAS as '<library> <version> <kernel>' (the kernel OpenBLAS picked)."""
    try:
        from threadpoolctl import threadpool_info
        for lib in threadpool_info():
            if lib.get("user_api") == "blas" and "numpy" in lib.get("filepath", ""):
                return f"{lib.get('internal_api')} {lib.get('version')} {lib.get('architecture')}"
    except Exception:  # noqa: BLE001 - a fact we cannot read is recorded as unknown
        pass
    return "unknown"


@lru_cache(maxsize=1)
def machine_facts() -> dict:
    """This process's machine facts (a JSON-able dict, the same for the whole process)."""
    import llvmlite
    import mpmath
    import numba
    import numpy as np
    import scipy

    try:
        from numpy._core._multiarray_umath import __cpu_features__ as feats
        features = sorted(k for k, v in feats.items() if v)
    except ImportError:  # pragma: no cover - numpy 1.x layout
        features = []
    return {
        "arch": platform.machine(),
        "cpu": _cpu_model(),
        "cpu_features": " ".join(features),
        "python": platform.python_version(),
        "libc": " ".join(platform.libc_ver()),
        "numpy": np.__version__,
        "numba": numba.__version__,
        "llvmlite": llvmlite.__version__,
        "scipy": scipy.__version__,
        "mpmath": mpmath.__version__,
        "blas": _blas(),
        "env": {k: os.environ[k] for k in ENV_VARIABLES if k in os.environ},
    }


def machine_id(facts: dict) -> str:
    """A short name of a set of facts (12 hex digits of its SHA-256)."""
    text = json.dumps(facts, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def differences(old: dict, new: dict) -> list[str]:
    """'name: old -> new' for each fact that differs (old facts missing: nothing)."""
    if not old:
        return []
    out = []
    for k in sorted(set(old) | set(new)):
        if old.get(k) != new.get(k):
            out.append(f"{k}: {old.get(k)!r} -> {new.get(k)!r}")
    return out


def episode_comparable(old: dict, new: dict) -> bool:
    """Whether episodes computed under ``old`` and ``new`` are the same bit for bit (the
    guarantee's limits: same architecture and versions; CPU features do not matter)."""
    return all(old.get(k) == new.get(k) for k in EPISODE_FACTS)


def describe(old: dict, new: dict, what: str = "this run") -> str:
    """One line saying how this machine differs from the one that made ``what`` ('' when
    nothing differs)."""
    diff = differences(old, new)
    if not diff:
        return ""
    verdict = ("episodes stay bit-identical (same architecture and versions)"
               if episode_comparable(old, new) else
               "episodes may differ in their last bits (architecture or versions differ)")
    return f"this machine differs from the one that made {what}: {'; '.join(diff)}; {verdict}"
