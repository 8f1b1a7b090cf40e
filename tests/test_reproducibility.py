"""Same seed, same episode on every x86-64 machine (README "Reproducibility",
docs/model.md §13).

Three things could make an episode depend on the machine, and each is shut off and
checked here by running the golden tests (recorded episodes, compared bit for bit) in a
subprocess under another machine's conditions:

1. numpy's CPU dispatch: the goldens pass with numpy's AVX-512 paths, and with its AVX2
   and AVX-512 paths, switched off (NPY_DISABLE_CPU_FEATURES).
2. BLAS and LAPACK (OpenBLAS picks its kernel per CPU): the goldens pass with every
   double-precision BLAS/LAPACK entry point trapped (tests/blas_trap.py), so no such
   result reaches an episode.  OPENBLAS_CORETYPE is never set here: some machines set it
   on purpose, and the episode must not depend on it.
3. numba's code generation: a golden episode compiled for the generic x86-64 CPU.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import blas_trap
from tethernet_ros import machine

ROOT = Path(__file__).resolve().parent.parent
#: the golden episodes of the default model and the Monte Carlo golden (CQI traces)
GOLDEN_TESTS = ["tests/test_kernel_golden.py", "-k", "default or mesh",
                "tests/test_montecarlo_golden.py"]
#: numpy 2.x dispatch groups: X86_V4 (AVX-512) and its extensions, X86_V3 (AVX2, FMA3)
WITHOUT_AVX512 = "X86_V4 AVX512_ICL AVX512_SPR"
WITHOUT_AVX2 = "X86_V3 " + WITHOUT_AVX512


def run_python(args: list[str], env: dict, timeout: float = 600) -> subprocess.CompletedProcess:
    full_env = {**os.environ, **env}
    return subprocess.run([sys.executable, *args], cwd=ROOT, env=full_env, capture_output=True,
                          text=True, timeout=timeout)


def run_pytest(args: list[str], env: dict) -> subprocess.CompletedProcess:
    return run_python(["-m", "pytest", "-q", "-p", "no:cacheprovider", *args], env)


def report(r: subprocess.CompletedProcess) -> str:
    return f"exit {r.returncode}\n{r.stdout[-4000:]}\n{r.stderr[-3000:]}"


@pytest.mark.parametrize("disabled", [WITHOUT_AVX512, WITHOUT_AVX2], ids=["no-avx512", "no-avx2"])
def test_goldens_without_numpy_simd_paths(disabled):
    env = {"NPY_DISABLE_CPU_FEATURES": disabled}
    probe = run_python(["-c", "import json; from numpy._core._multiarray_umath import "
                        "__cpu_features__ as f; print(json.dumps(f))"], env)
    assert probe.returncode == 0, report(probe)
    features = json.loads(probe.stdout)
    assert not any(features.get(k) for k in disabled.split()), features
    r = run_pytest(GOLDEN_TESTS, env)
    assert r.returncode == 0, report(r)


def test_no_blas_or_lapack_result_reaches_an_episode(tmp_path):
    missing = blas_trap.missing_tools()
    if missing:
        pytest.skip(f"cannot build the BLAS trap without {missing}")
    lib, n_trapped = blas_trap.build(tmp_path)
    assert n_trapped > 1000   # the d/z BLAS and LAPACK of two OpenBLAS builds
    env = {"LD_PRELOAD": str(lib)}
    # the trap works: a dot product of float64 vectors stops the process
    control = run_python(["-c", "import numpy as np; a = np.ones(3); print(a @ a)"], env)
    assert control.returncode == blas_trap.EXIT_STATUS, report(control)
    assert "BLAS_TRAP scipy_cblas_ddot" in control.stderr
    r = run_pytest(GOLDEN_TESTS, env)
    assert r.returncode == 0 and "BLAS_TRAP" not in r.stderr, report(r)


def test_golden_episode_with_numba_generic_cpu(tmp_path):
    env = {"NUMBA_CPU_NAME": "generic", "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    r = run_pytest(["tests/test_kernel_golden.py", "-k", "default and time-min"], env)
    assert r.returncode == 0, report(r)


def test_machine_facts_name_what_decides_comparability():
    facts = machine.machine_facts()
    for key in machine.EPISODE_FACTS + ("cpu", "cpu_features", "blas", "env"):
        assert key in facts, key
    other = {**facts, "cpu": "another CPU", "cpu_features": "X86_V2 X86_V3"}
    line = machine.describe(facts, other)
    assert "cpu:" in line and "episodes stay bit-identical" in line
    newer = {**facts, "numpy": "9.9.9"}
    assert "may differ" in machine.describe(facts, newer)
    assert machine.describe(facts, dict(facts)) == ""
    assert machine.machine_id(facts) == machine.machine_id(json.loads(json.dumps(facts)))
