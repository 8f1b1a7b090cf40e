"""The :class:`EpisodeBackend` interface and the serial backend.

A backend runs :class:`~tethernet_ros.montecarlo.records.EpisodeTask` s somewhere and yields
an :class:`Outcome` per task as it finishes.  Implementations: :class:`InProcessBackend`
(here), :class:`~tethernet_ros.montecarlo.process_pool.ProcessPoolBackend` (local worker
processes), :class:`~tethernet_ros.montecarlo.dask_backend.DaskBackend` (a dask.distributed
cluster) and, outside this package, the ROS 2 suite's ``RosBackend``.
"""
from __future__ import annotations

import abc
import os
from dataclasses import dataclass
from collections.abc import Iterable, Iterator

from .records import EpisodeTask, SampleResult
from .worker import run_task


def default_workers() -> int:
    """CPU cores this process may run on (the default pool size)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


@dataclass
class Outcome:
    """What a backend yields for one task: the result, or an error text; ``crashed`` marks
    a worker process that died (every task in flight on a broken pool gets one)."""

    task: EpisodeTask
    result: SampleResult | None = None
    error: str | None = None
    crashed: bool = False


def error_text(exc: BaseException) -> str:
    """One line (at most 300 characters) naming an exception raised by a task."""
    text = f"{type(exc).__name__}: {exc}".strip()
    return text.splitlines()[0][:300] if text else type(exc).__name__


class EpisodeBackend(abc.ABC):
    """Runs :class:`EpisodeTask` s somewhere and yields :class:`Outcome` s as they finish.

    ``map`` never raises for a failing task: the outcome carries the error.  At most
    ``max_in_flight`` tasks run at once (None: the backend's choice).  Backends are
    reusable across calls (workers stay warm) and are context managers; ``close()``
    releases the workers.  ``workers`` is the parallelism (for reports, and the batch size
    of sequential sampling).
    """

    name = "backend"
    workers = 1

    @abc.abstractmethod
    def map(self, tasks: Iterable[EpisodeTask],
            max_in_flight: int | None = None) -> Iterator[Outcome]:
        ...

    def close(self) -> None:  # noqa: B027 - an optional hook: most backends hold nothing
        pass

    def describe(self) -> str:
        return f"{self.name} ({self.workers} worker{'s' if self.workers != 1 else ''})"

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class InProcessBackend(EpisodeBackend):
    """Serial, in the calling process."""

    name = "in-process"

    def map(self, tasks, max_in_flight=None):
        for t in tasks:
            try:
                yield Outcome(t, run_task(t))
            except Exception as exc:  # noqa: BLE001 - any task error becomes an outcome
                yield Outcome(t, error=error_text(exc))
