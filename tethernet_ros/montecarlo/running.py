"""Running tasks on a backend: the backend a command line asks for (:func:`make_backend`)
and :func:`run_tasks`, which retries a failed task and never drops one.

A sample whose worker raises or dies is retried once (a worker death is retried with
nothing else in flight, so that an innocent sample that shared the dead pool is not blamed
twice); if it fails again it is a failed sample with reason ``"worker error: ..."``.
Nothing is dropped: P*_s always divides by N.
"""
from __future__ import annotations

from dataclasses import replace
from collections.abc import Iterator, Sequence

from .backends import EpisodeBackend, InProcessBackend
from .dask_backend import DaskBackend
from .process_pool import ProcessPoolBackend
from .records import EpisodeTask, SampleResult, worker_error_result


def make_backend(workers: int | None = None, scheduler: str | None = None) -> EpisodeBackend:
    """The backend a command line asks for: ``scheduler`` (address or 'local') -> Dask;
    ``workers`` 0 -> in-process; else a process pool of ``workers`` (default all cores)."""
    if scheduler:
        return DaskBackend(scheduler, workers)
    if workers == 0:
        return InProcessBackend()
    return ProcessPoolBackend(workers)


def run_tasks(backend: EpisodeBackend, tasks: Sequence[EpisodeTask],
              retries: int = 1) -> Iterator[SampleResult]:
    """Run tasks on a backend and yield one :class:`SampleResult` per task as it finishes.

    A task whose worker raised is retried (up to ``retries`` times) with the others; one
    whose worker died is retried alone, with nothing else in flight, so that an innocent
    task that shared a broken pool is not blamed twice.  A task that fails its last try
    becomes a 'worker error' failure; none is dropped."""
    todo, isolated = list(tasks), []
    for attempt in range(retries + 1):
        last = attempt == retries
        again = []
        for batch, limit in ((todo, None), (isolated, 1)):
            if not batch:
                continue
            for out in backend.map(batch, max_in_flight=limit):
                if out.result is not None:
                    yield out.result
                elif last:
                    yield worker_error_result(out.task, out.error or "unknown error")
                else:
                    again.append((replace(out.task, attempt=attempt + 1), out.crashed))
        todo = [t for t, crashed in again if not crashed]
        isolated = [t for t, crashed in again if crashed]
        if not again:
            return

