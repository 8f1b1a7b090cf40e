"""Local worker processes: :class:`ProcessPoolBackend` (concurrent.futures)."""
from __future__ import annotations

from collections import deque

from .backends import EpisodeBackend, Outcome, default_workers, error_text
from .worker import run_task, warm_worker


class ProcessPoolBackend(EpisodeBackend):
    """Local worker processes (concurrent.futures, 'spawn' context by default: no forked
    numba/LLVM or ROS state).  Each worker loads the numba cache once at start
    (:func:`warm_worker`).  A pool broken by a dying worker is replaced."""

    name = "process pool"

    def __init__(self, workers: int | None = None, context: str = "spawn", warm: bool = True):
        self.workers = int(workers or default_workers())
        if self.workers < 1:
            raise ValueError("workers must be >= 1")
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
        pending = deque(tasks)
        inflight = {}
        try:
            while pending or inflight:
                broken = False
                while pending and len(inflight) < limit and not broken:
                    try:
                        fut = self._get_pool().submit(run_task, pending[0])
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
                    task = inflight.pop(fut)
                    exc = fut.exception()
                    if exc is None:
                        yield Outcome(task, fut.result())
                    elif isinstance(exc, KeyboardInterrupt):  # Ctrl-C reached the workers too
                        raise KeyboardInterrupt
                    elif isinstance(exc, BrokenProcessPool):
                        yield Outcome(task, error="worker process died (BrokenProcessPool)",
                                      crashed=True)
                    else:
                        yield Outcome(task, error=error_text(exc))
                if broken:
                    self._drop_pool()
        finally:
            for fut in inflight:
                fut.cancel()

    def close(self):
        self._drop_pool()


def _noop():
    return None
