"""Monte Carlo throughput: episodes per second in-process, with a process pool of 1 and 2
workers (scaling efficiency), and on a local Dask cluster of 2 workers (its overhead
against the pool).

    .venv/bin/python benchmarks/bench_montecarlo.py [--samples N] [--design NAME]
        [--settle-time S] [--workers K] [--rounds R] [--skip-dask] [--skip-serial]

Every backend runs the same samples (same seeds, so the same work).  Worker start-up
(spawn, imports, numba cache load) is timed apart and excluded from the throughput: the
workers are started and warmed first.  Efficiency = eps(K) / (K * eps(1)); Dask overhead =
t(dask, K) / t(pool, K) - 1, from --rounds interleaved pool/Dask pairs (median and range).
"workers busy" = sum of episode wall times / (K * run wall):
the share of the run the workers spent simulating (100 % = no scheduling loss), which
other load on the machine does not change; episode CPU < episode wall shows that load.
Numbers only, no asserts.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def timed_run(backend, design, n, config, seed):
    from tethernet_ros.montecarlo import evaluate

    t0 = time.perf_counter()
    r = evaluate(design, n, seed, config=config, backend=backend)
    wall = time.perf_counter() - t0
    return wall, r


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=12, help="samples per backend (default 12)")
    ap.add_argument("--design", default="time-min")
    ap.add_argument("--settle-time", type=float, default=None,
                    help="settling time (s); default 20 s, docs/model.md §7")
    ap.add_argument("--workers", type=int, default=2, help="pool size for the scaling run (default 2)")
    ap.add_argument("--seed", type=int, default=7, help="base seed of the samples (default 7)")
    ap.add_argument("--skip-dask", action="store_true")
    ap.add_argument("--rounds", type=int, default=3,
                    help="interleaved pool/Dask rounds for the overhead (default 3)")
    ap.add_argument("--skip-serial", action="store_true", help="skip the in-process baseline")
    args = ap.parse_args(argv)

    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.design import load_design
    from tethernet_ros import montecarlo as mc

    design = load_design(args.design)
    config = SimConfig() if args.settle_time is None else SimConfig(settle_time=args.settle_time)
    n, k = args.samples, args.workers
    print(f"Monte Carlo benchmark: {n} samples of {args.design} (settle {config.settle_time:g} s), "
          f"base seed {args.seed}, {os.cpu_count()} CPUs visible, load average "
          f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}")
    rows = []

    def report(name, wall, r, startup, workers):
        eps = n / wall
        busy = sum(s.wall_time for s in r.samples)
        cpu = sum(s.cpu_time for s in r.samples)
        rows.append((name, wall, eps))
        print(f"  {name:26s} start {startup:5.1f} s   run {wall:6.1f} s   {eps:6.3f} episodes/s   "
              f"episode wall {busy / n:5.2f} s, CPU {cpu / n:5.2f} s   "
              f"workers busy {busy / (workers * wall) * 100:5.1f} %", flush=True)
        return eps

    if not args.skip_serial:
        mc.warm_worker()
        wall, r = timed_run(mc.InProcessBackend(), design, n, config, args.seed)
        report("in-process", wall, r, 0.0, 1)

    res = {}
    for w in sorted({1, k}):
        t0 = time.perf_counter()
        with mc.ProcessPoolBackend(w).start() as be:
            startup = time.perf_counter() - t0
            wall, r = timed_run(be, design, n, config, args.seed)
        res[w] = (wall, r)
        report(f"process pool, {w} worker{'s' if w > 1 else ''}", wall, r, startup, w)
    eps1 = n / res[1][0]
    epsk = n / res[k][0]
    if k > 1:
        print(f"  scaling efficiency {k} vs 1 workers: {epsk / (k * eps1) * 100:5.1f} %  "
              f"(speed-up {epsk / eps1:.2f}x)")

    if not args.skip_dask:
        # The pool and the Dask cluster stay up side by side and take turns on the same
        # samples, --rounds times: this VM's speed drifts by 10-30 % over a minute (same
        # samples, same backend), so an overhead is only read from interleaved pairs.
        t0 = time.perf_counter()
        dask_be = mc.DaskBackend("local", k).start()
        startup = time.perf_counter() - t0
        pool_be = mc.ProcessPoolBackend(k).start()
        ratios = []
        try:
            for rnd in range(args.rounds):
                pw, pr = timed_run(pool_be, design, n, config, args.seed)
                report(f"pool, {k} (round {rnd + 1})", pw, pr, 0.0, k)
                dw, dr = timed_run(dask_be, design, n, config, args.seed)
                report(f"dask local, {k} (round {rnd + 1})", dw, dr, startup if rnd == 0 else 0.0, k)
                same = [s.outcome() for s in dr.samples] == [s.outcome() for s in pr.samples]
                ratios.append(dw / pw - 1)
                print(f"  round {rnd + 1}: dask overhead {ratios[-1] * 100:+5.1f} %  "
                      f"(results identical: {same})", flush=True)
        finally:
            pool_be.close()
            dask_be.close()
        ratios.sort()
        med = ratios[len(ratios) // 2] if len(ratios) % 2 else \
            0.5 * (ratios[len(ratios) // 2 - 1] + ratios[len(ratios) // 2])
        print(f"  dask overhead vs process pool ({k} workers, {len(ratios)} interleaved rounds): "
              f"median {med * 100:+5.1f} %, range {ratios[0] * 100:+5.1f} % .. "
              f"{ratios[-1] * 100:+5.1f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
