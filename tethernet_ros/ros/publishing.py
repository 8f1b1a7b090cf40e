"""Publishing while the kernel runs: a simulation that calls back at publish steps, and
the one thread that builds and publishes the messages in order.

The episode thread only copies the state at a publish step (a StateArrays snapshot); an
:class:`Outbox` thread builds and publishes the messages while the kernel (which releases
the GIL) goes on.  The outbox is bounded, so a slow publisher holds the episode back
rather than dropping states.  No ROS import.
"""
from __future__ import annotations

import queue
import threading

from .loop import ControlledSimulation


class EpisodeAborted(Exception):
    pass


class PublishingSimulation(ControlledSimulation):
    """A simulation that calls ``on_publish(self)`` at every multiple of ``every`` steps
    while advancing (splitting advance() there does not change the result), after the
    closing decision of that step if a ``controller`` decides outside the kernel
    (:class:`~.loop.ControlledSimulation`, a lockstep episode), and while it waits to
    launch (:meth:`hold`)."""

    def __init__(self, scenario, every: int, on_publish, should_stop, controller=None):
        super().__init__(scenario, controller)
        self.every = max(1, int(every))
        self.on_publish = on_publish
        self.should_stop = should_stop
        self.last_published = -1

    def advance(self, n_steps: int) -> None:
        target = self.step + n_steps
        while self.step < target:
            if self.should_stop():
                raise EpisodeAborted()
            nxt = min(target, (self.step // self.every + 1) * self.every)
            super().advance(nxt - self.step)
            if self.step % self.every == 0:
                self.publish()

    def hold(self) -> None:
        """A control step of the wait before the launch (lockstep): the target turns; its
        state is published once the mission's clock has passed another multiple of
        ``every`` steps (the kernel holds the steps between control steps itself), so that
        viewers see it turn and the capture node sees the simulation alive."""
        if self.should_stop():
            raise EpisodeAborted()
        super().hold()
        if self.mission_step // self.every > max(self.last_published, 0) // self.every:
            self.publish()

    def next_phase(self) -> bool:
        """Publish the state at the end of a phase before the next begins: the settle
        time's end is the state the capture is judged on (``episode.CaptureSimulation.
        settled``), which the monitor must see when the tug test follows."""
        self.publish()
        return super().next_phase()

    def publish(self) -> None:
        if self.mission_step != self.last_published:
            self.last_published = self.mission_step
            self.on_publish(self)


class Outbox:
    """One thread that runs queued publishing jobs in order (bounded: ``put`` blocks when
    ``depth`` jobs wait).  ``drain()`` waits until every job put so far has run."""

    def __init__(self, logger, depth: int = 8):
        self._q: queue.Queue = queue.Queue(maxsize=depth)
        self._log = logger
        self._closed = False
        self._thread = threading.Thread(target=self._run, name="outbox", daemon=True)
        self._thread.start()

    def put(self, job) -> None:
        self._q.put(job)

    def drain(self) -> None:
        self._q.join()

    def _run(self) -> None:
        while True:
            job = self._q.get()
            try:
                if job is None:
                    return
                job()
            except Exception as exc:  # noqa: BLE001 - e.g. publishing after shutdown began
                if not self._closed:
                    self._log.error(f"publishing failed: {exc}")
            finally:
                self._q.task_done()

    def close(self, timeout: float = 5.0) -> None:
        self._closed = True
        try:
            self._q.put(None, timeout=timeout)
        except queue.Full:
            return
        self._thread.join(timeout=timeout)
