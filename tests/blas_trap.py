"""A preloadable library that stops the process at the first double-precision BLAS or
LAPACK call (test_reproducibility.py).

OpenBLAS picks its compute kernels per CPU at load time, so a BLAS or LAPACK result may
differ in its last bits between machines.  An episode must not depend on one.  The
library defines every double-precision (d*, z*, id*, iz*) entry point that numpy's and
scipy's OpenBLAS export; preloaded with LD_PRELOAD it takes their place, and a call writes
``BLAS_TRAP <name>`` to stderr and exits with status 97.  Single-precision entry points are
left alone (numpy calls sdot once at import to check its BLAS; no episode uses float32).
"""
from __future__ import annotations

import glob
import os
import re
import shutil
import subprocess
from pathlib import Path

EXIT_STATUS = 97
_PREFIX = re.compile(r"^scipy_(?:cblas_|LAPACKE_)?(?:i?[dz])[a-z0-9_]*$")


def openblas_libraries() -> list[str]:
    """The OpenBLAS shared libraries bundled with numpy and scipy."""
    import numpy
    import scipy

    out = []
    for pkg in (numpy, scipy):
        libs = Path(pkg.__file__).resolve().parent.parent / f"{pkg.__name__}.libs"
        out += sorted(glob.glob(str(libs / "libscipy_openblas*.so*")))
    return out


def double_precision_symbols(libraries: list[str]) -> list[str]:
    """The exported double-precision BLAS/LAPACK functions of the libraries."""
    names = set()
    for lib in libraries:
        out = subprocess.run(["nm", "-D", "--defined-only", lib], capture_output=True,
                             text=True, check=True).stdout
        for line in out.splitlines():
            parts = line.split()
            if len(parts) == 3 and parts[1] == "T" and _PREFIX.match(parts[2]):
                names.add(parts[2])
    return sorted(names)


def missing_tools() -> str:
    """'' if the trap can be built here, else what is missing."""
    missing = [t for t in ("gcc", "nm") if shutil.which(t) is None]
    return ", ".join(missing)


def build(directory: str | os.PathLike) -> tuple[Path, int]:
    """Compile the trap library into ``directory``; returns its path and the number of
    entry points it traps."""
    names = double_precision_symbols(openblas_libraries())
    src = Path(directory) / "blas_trap.c"
    lines = ["#include <stdio.h>", "#include <unistd.h>",
             "static void trap(const char *n) { fprintf(stderr, \"BLAS_TRAP %s\\n\", n);"
             f" fflush(stderr); _exit({EXIT_STATUS}); }}"]
    lines += [f"void {n}(void) {{ trap(\"{n}\"); }}" for n in names]
    src.write_text("\n".join(lines) + "\n")
    lib = Path(directory) / "blas_trap.so"
    subprocess.run(["gcc", "-O0", "-shared", "-fPIC", "-o", str(lib), str(src)], check=True)
    return lib, len(names)
