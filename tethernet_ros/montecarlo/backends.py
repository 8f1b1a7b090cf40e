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
from collections import deque
from dataclasses import dataclass
from collections.abc import Iterable, Iterator

from .records import EpisodeTask, SampleResult, error_text
from .worker import iter_group, same_batch

#: tasks a worker process takes at once, as one group on the batched kernel (its lanes
#: refill from the group); fewer when a map's tasks spread over the workers need fewer
#: (:func:`group_size_for`)
GROUP_SIZE = 8


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
    #: what decides the episodes besides the library, or None: the backends that reproduce
    #: ``run_episode`` bit for bit leave it None; one that runs a user's controller names
    #: it (its spec and source hash), and that enters the run key (:func:`.keys.run_key`),
    #: so that a resumed results file never mixes another controller's samples in
    episode_source: str | None = None

    @property
    def batch_size(self) -> int:
        """Samples a sequential sampler draws at a time: one per lane of every worker.
        More would keep the lanes refilled, but every sample drawn past the decision is
        an episode spent for nothing (docs/studies/step.md, "Samples per batch": with 8
        per worker, a Case 1 design decided by its third failure drew 16 samples for 3)."""
        return self.workers

    @property
    def max_batch_size(self) -> int:
        """The most samples a sequential sampler draws at a time, when its rule expects its
        decision to take that many (refilling the lanes as episodes end)."""
        return self.batch_size

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


def group_size_for(n_tasks: int, workers: int, group_size: int = GROUP_SIZE) -> int:
    """Tasks per group when ``n_tasks`` go to ``workers`` worker processes: at most
    ``group_size``, and few enough that every worker gets a group (8 tasks on 2 workers:
    two groups of 4, not one of 8 and an idle worker)."""
    return max(1, min(int(group_size), -(-int(n_tasks) // max(1, int(workers)))))


class GroupedBackend(EpisodeBackend):
    """A backend whose workers each take groups of up to ``group_size`` tasks of one design
    on the batched kernel (the process pool, Dask).  A sequential sampler draws one sample
    per lane of every worker (the lanes as ``core.batch.choose_lanes`` picks them for the
    default configuration in this process; each worker measures its own, which a loaded
    machine may make differ: only the batch size, never a result, depends on it), up to a
    whole group per worker."""

    group_size = GROUP_SIZE

    @property
    def batch_size(self) -> int:
        from ..core.batch import choose_lanes
        return self.workers * min(self.group_size, choose_lanes())

    @property
    def max_batch_size(self) -> int:
        return self.workers * self.group_size

    def groups(self, tasks, workers: int, max_in_flight: int | None) -> deque:
        """The tasks of a map as groups spread over ``workers`` (one task a group when
        ``max_in_flight`` is 1)."""
        tasks = list(tasks)
        size = 1 if max_in_flight == 1 else group_size_for(len(tasks), workers, self.group_size)
        return deque(chunk_tasks(tasks, size))


def chunk_tasks(tasks, size: int) -> list[list[EpisodeTask]]:
    """Consecutive tasks that can share a batch, in groups of at most ``size``."""
    out: list[list[EpisodeTask]] = []
    for t in tasks:
        if out and len(out[-1]) < size and same_batch(out[-1][0], t):
            out[-1].append(t)
        else:
            out.append([t])
    return out


def group_outcomes(group: list[EpisodeTask], results) -> list[Outcome]:
    """The outcomes of a group from its worker's (task, result, error) triples; a task
    the worker did not report gets an error."""
    def ident(t):
        return t.key, t.index, t.seed

    mine = {ident(t): t for t in group}
    out = [Outcome(mine.get(ident(t), t), r) if err is None
           else Outcome(mine.get(ident(t), t), error=err) for t, r, err in results]
    seen = {ident(o.task) for o in out}
    out += [Outcome(t, error="not reported by its worker") for t in group if ident(t) not in seen]
    return out


class InProcessBackend(EpisodeBackend):
    """Serial, in the calling process, on the batched kernel (``lanes`` per batch, None:
    chosen per CPU); tasks are taken as lanes free up."""

    name = "in-process"

    def __init__(self, lanes: int | None = None):
        self.lanes = lanes

    @property
    def batch_size(self) -> int:
        if self.lanes:
            return int(self.lanes)
        from ..core.batch import choose_lanes
        return choose_lanes()

    def map(self, tasks, max_in_flight=None):
        lanes = 1 if max_in_flight == 1 else self.lanes
        try:
            for t, r, err in iter_group(tasks, lanes):
                yield Outcome(t, r) if err is None else Outcome(t, error=err)
        except Exception as exc:  # noqa: BLE001 - an error outside a task: report, never drop
            raise RuntimeError(f"in-process batch failed: {error_text(exc)}") from exc
