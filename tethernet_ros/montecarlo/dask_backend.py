"""A dask.distributed cluster: :class:`DaskBackend`."""
from __future__ import annotations

from .backends import GROUP_SIZE, GroupedBackend, Outcome, default_workers, group_outcomes
from .records import error_text
from .worker import run_group, warm_worker


class DaskBackend(GroupedBackend):
    """A dask.distributed cluster: ``scheduler`` is an address ('tcp://host:8786') or
    None / 'local' for a LocalCluster of ``workers`` single-threaded worker processes
    (no dashboard).  Workers need tethernet_ros importable and are warmed with
    :func:`warm_worker`; each takes groups of up to ``group_size`` tasks of one design on
    the batched kernel.  On the local cluster a dying worker fails its task at once
    (allowed-failures 0); on a remote scheduler its own setting applies first."""

    name = "dask"

    def __init__(self, scheduler: str | None = None, workers: int | None = None,
                 group_size: int = GROUP_SIZE):
        self.group_size = int(group_size)
        self.scheduler = None if scheduler in (None, "", "local") else scheduler
        self._n = int(workers or default_workers())
        self._client = None
        self._cluster = None

    @property
    def workers(self) -> int:
        if self._client is None:
            return self._n
        return max(1, sum(self._client.nthreads().values()))

    def describe(self) -> str:
        where = self.scheduler or "local cluster"
        return f"dask ({where}, {self.workers} worker thread{'s' if self.workers != 1 else ''})"

    def start(self) -> DaskBackend:
        if self._client is not None:
            return self
        import logging

        import dask
        from distributed import Client, LocalCluster

        if self.scheduler is None:
            with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
                self._cluster = LocalCluster(n_workers=self._n, threads_per_worker=1,
                                             processes=True, dashboard_address=None,
                                             silence_logs=logging.CRITICAL)
                self._client = Client(self._cluster)
        else:
            self._client = Client(self.scheduler)
        self._client.wait_for_workers(1)
        self._client.run(warm_worker)
        return self

    def map(self, tasks, max_in_flight=None):
        from distributed import as_completed

        self.start()
        client = self._client
        pending = self.groups(tasks, self.workers, max_in_flight)
        limit = max_in_flight or max(len(pending), 1)
        ac = as_completed()
        inflight = {}

        def submit_more():
            while pending and len(inflight) < limit:
                t = pending.popleft()
                fut = client.submit(run_group, t, pure=False, retries=0)
                inflight[fut.key] = (fut, t)
                ac.add(fut)

        submit_more()
        try:
            for fut in ac:
                _, group = inflight.pop(fut.key)
                if fut.status == "finished":
                    yield from group_outcomes(group, fut.result())
                else:
                    try:
                        exc = fut.exception()
                    except BaseException as e:  # noqa: BLE001 - cancelled / lost futures
                        exc = e
                    crashed = type(exc).__name__ == "KilledWorker"
                    for task in group:
                        yield Outcome(task, error="worker process died (KilledWorker)" if crashed
                                      else error_text(exc), crashed=crashed)
                fut.release()
                submit_more()
        finally:
            for fut, _ in inflight.values():
                fut.cancel()

    def close(self):
        if self._client is not None:
            self._client.close()
            self._client = None
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None

