"""Episode wall time of this checkout against another git revision, on the same model,
in alternating side-by-side pairs (this machine's speed drifts within a minute: only
neighbours compare).

    .venv/bin/python benchmarks/bench_versions.py --rev b61bf67 [--designs time-min,baseline]
        [--pairs 8] [--preset spec-text]

The other revision is checked out into a temporary git worktree and run with its own
sources (PYTHONPATH) in this venv.  Each run is a fresh process: the numba kernels are
loaded from each tree's cache (or compiled) by a short warm-up episode, which is not
timed.  Prints every pair, the median ratio (this / other) and the range, and checks that
both give the same settled CQI and step count (a refactoring must not change them).
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

EPISODE = r"""
import sys, time
from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.core.episode import run_episode
preset = sys.argv[2]
cfg = SimConfig.preset(preset) if hasattr(SimConfig, "preset") else SimConfig()
d = REFERENCE_DESIGNS[sys.argv[1]]
run_episode(d, None, cfg.replace(settle_time=0.1, horizon=1.0), record_trace=False)
t0 = time.perf_counter()
r = run_episode(d, None, cfg, record_trace=False)
print(time.perf_counter() - t0, r.steps, repr(r.settled_cqi))
"""


def run(tree: str, design: str, preset: str):
    env = dict(os.environ, PYTHONPATH=tree)
    out = subprocess.run([sys.executable, "-c", EPISODE, design, preset], cwd=tree, env=env,
                         capture_output=True, text=True, check=True).stdout.split()
    return float(out[0]), int(out[1]), out[2]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rev", required=True, help="the other git revision")
    ap.add_argument("--designs", default="time-min")
    ap.add_argument("--pairs", type=int, default=8)
    ap.add_argument("--preset", default="spec-text", help="model preset (the other revision "
                    "runs its own defaults if it has no presets)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        other = os.path.join(tmp, "other")
        subprocess.run(["git", "worktree", "add", "--detach", "-q", other, args.rev], cwd=ROOT, check=True)
        try:
            for design in args.designs.split(","):
                ratios = []
                print(f"{design}: this vs {args.rev} ({args.preset}), {args.pairs} pairs")
                for k in range(args.pairs):
                    first_this = k % 2 == 0
                    order = [ROOT, other] if first_this else [other, ROOT]
                    res = {tree: run(tree, design, args.preset) for tree in order}
                    (t_new, n_new, c_new), (t_old, n_old, c_old) = res[ROOT], res[other]
                    same = "same result" if (n_new, c_new) == (n_old, c_old) else \
                        f"DIFFERENT: steps {n_new} / {n_old}, CQI {c_new} / {c_old}"
                    ratios.append(t_new / t_old)
                    print(f"  pair {k + 1}: this {t_new:.3f} s, other {t_old:.3f} s, "
                          f"ratio {t_new / t_old:.3f}  ({same})", flush=True)
                print(f"  median ratio {statistics.median(ratios):.3f} "
                      f"(range {min(ratios):.3f} .. {max(ratios):.3f})")
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", other], cwd=ROOT, check=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
