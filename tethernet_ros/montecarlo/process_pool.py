"""Local worker processes: :class:`ProcessPoolBackend` (concurrent.futures)."""
from __future__ import annotations

from .backends import GROUP_SIZE, GroupedBackend, Outcome, default_workers, group_outcomes
from .records import error_text
from .worker import run_group, warm_worker


class ProcessPoolBackend(GroupedBackend):
    """Local worker processes (concurrent.futures, 'spawn' context by default: no forked
    numba/LLVM or ROS state).  Each worker loads the numba cache once at start
    (:func:`warm_worker`) and runs groups of up to ``group_size`` tasks of one design on the
    batched kernel (:func:`~tethernet_ros.montecarlo.worker.run_group`).  A pool broken by
    a dying worker is replaced; every task of a group in flight on it is reported crashed."""

    name = "process pool"

    def __init__(self, workers: int | None = None, context: str = "spawn", warm: bool = True,
                 group_size: int = GROUP_SIZE):
        self.workers = int(workers or default_workers())
        if self.workers < 1:
            raise ValueError("workers must be >= 1")
        self.group_size = int(group_size)
        self.context = context
        self.warm = warm
        self._pool = None

    def start(self) -> ProcessPoolBackend:
        """Start the workers now and wait until all are warm (else they start lazily)."""
        pool = self._get_pool()
        if self.warm:
            futs = [pool.submit(_noop) for _ in range(self.workers * 2)]
            for f in futs:
                f.result()
        return self

    def _get_pool(self):
        if self._pool is None:
            import multiprocessing as mp
            from concurrent.futures import ProcessPoolExecutor

            self._pool = ProcessPoolExecutor(
                max_workers=self.workers, mp_context=mp.get_context(self.context),
                initializer=warm_worker if self.warm else None)
        return self._pool

    def _drop_pool(self):
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def map(self, tasks, max_in_flight=None):
        from concurrent.futures import FIRST_COMPLETED, wait
        from concurrent.futures.process import BrokenProcessPool

        limit = max(1, min(max_in_flight or self.workers, self.workers))
        pending = self.groups(tasks, limit, max_in_flight)
        inflight = {}
        try:
            while pending or inflight:
                broken = False
                while pending and len(inflight) < limit and not broken:
                    try:
                        fut = self._get_pool().submit(run_group, pending[0])
                    except BrokenProcessPool:
                        broken = True
                        break
                    inflight[fut] = pending.popleft()
                if not broken:
                    done, _ = wait(list(inflight), return_when=FIRST_COMPLETED)
                    broken = any(isinstance(f.exception(), BrokenProcessPool) for f in done)
                if broken:  # every future of a broken pool completes at once
                    done, _ = wait(list(inflight))
                for fut in done:
                    group = inflight.pop(fut)
                    exc = fut.exception()
                    if exc is None:
                        yield from group_outcomes(group, fut.result())
                    elif isinstance(exc, KeyboardInterrupt):  # Ctrl-C reached the workers too
                        raise KeyboardInterrupt
                    elif isinstance(exc, BrokenProcessPool):
                        for task in group:
                            yield Outcome(task, error="worker process died (BrokenProcessPool)",
                                          crashed=True)
                    else:
                        for task in group:
                            yield Outcome(task, error=error_text(exc))
                if broken:
                    self._drop_pool()
        except KeyboardInterrupt:
            self.terminate()            # Ctrl-C or SIGTERM: do not wait for the groups
            raise
        finally:
            for fut in inflight:
                fut.cancel()
            if any(not fut.done() for fut in inflight):
                # left with groups running (the consumer raised, e.g. Ctrl-C while it
                # wrote a result, and closed this generator): stop them, do not wait
                self.terminate()

    def terminate(self) -> None:
        """Stop the workers now (SIGTERM to each), dropping what they run; the pool is
        started again at the next ``map``."""
        pool, self._pool = self._pool, None
        if pool is None:
            return
        procs = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        for p in procs:
            if p.is_alive():
                p.terminate()
        for p in procs:
            p.join(timeout=5.0)

    def close(self):
        self._drop_pool()


def _noop():
    return None
