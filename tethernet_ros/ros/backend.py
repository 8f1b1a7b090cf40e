"""Monte Carlo episode backend that runs every sample through the ROS 2 node suite.

:class:`RosBackend` is an :class:`~tethernet_ros.montecarlo.EpisodeBackend`: each
:class:`~tethernet_ros.montecarlo.EpisodeTask` becomes one RunCapture service call on a
long-lived :class:`~tethernet_ros.ros.suite.RosSuite` (the four nodes as processes),
with the episode recorded to an MCAP bag.  The sample's result is then **read back from
the bag** (:func:`tethernet_ros.ros.results.result_from_bag`): the simulation's
EpisodeResult message on the result topic, checked against the monitor's verdict in the
same bag and against the service response; a bag that is incomplete, lacks the result or disagrees is a failed
task (the evaluator retries it once, then records a worker error).  So the optimiser and
``tethernet validate`` can drive episodes through the services and read the logs, and the
numbers are the in-process ones bit for bit (same core, same noise sampler).

A suite serves one episode at a time; ``workers`` = K runs K suites side by side, each in
a ROS domain of its own (the first in the environment's or this process's domain, the
others in the next ones), with a thread per suite taking the next task as its suite frees
up: the same results as in process, sample for sample.  A suite is started on its first
task and kept for the backend's lifetime; it is restarted when a task needs another
SimConfig or other noise spreads (carried by node parameters), and after a node died.
Bags are written under ``bag_dir`` (a temporary folder by default) and deleted once read
unless ``keep_bags`` (an optimisation run would otherwise keep tens of thousands).

``lockstep`` runs every episode's closing policy through ROS; ``controller`` runs a user's
controller in place of the built-in policy (:class:`~tethernet_ros.ros.suite.RosSuite`),
so that a Monte Carlo run measures that controller's P*_s.  A sample whose controller did
not answer in time (the capture node's ABORTED with names.CONTROLLER_TIMEOUT) is a failed
sample with that reason (category 'controller did not answer'), not retried; the suite
goes on with the next.

Every field of the library's result comes back (``steps`` and ``max_penetration`` in the
EpisodeResult message; a bag recorded before they were: -1 and NaN).
"""
from __future__ import annotations

import json
import math
import queue
import shutil
import tempfile
import threading
import time
from pathlib import Path

from ..bags.naming import sample_name
from ..core.metrics import failure_category
from ..montecarlo import (EpisodeBackend, EpisodeTask, Outcome, SampleResult, error_text,
                          sample_result)
from .conversions import episode_result_from_msg
from .names import (ABORTED, CONTROLLER_TIMEOUT, REJECTED, STATUS_NAMES, SUCCEEDED,
                    is_controller_timeout)
from .results import BagResultError, compare_results, result_from_bag

#: the failure category of a sample whose controller did not answer (core.metrics)
CONTROLLER_FAILURE = failure_category(CONTROLLER_TIMEOUT)
#: the highest ROS domain id the suites may take (Fast DDS's ports: 7400 + 250 * domain)
MAX_DOMAIN = 232

__all__ = ["RosBackend", "result_from_bag", "BagResultError"]


def controller_failure_result(task: EpisodeTask, reason: str, wall_time: float) -> SampleResult:
    """A failed sample whose controller did not answer (``reason``, the capture node's
    error); its T is undefined (NaN: left out of mean T, as a worker error is)."""
    return SampleResult(
        key=task.key, index=task.index, seed=task.seed, success=False, settled_cqi=math.nan,
        locked_pairs=0, closing_time=math.nan, completion_time=math.nan,
        mass=task.design.mass(task.config.density), failure_reason=reason,
        category=CONTROLLER_FAILURE, steps=-1, wall_time=wall_time, attempts=task.attempt + 1,
        criterion=task.config.criterion)


class _Slot:
    """One suite of the backend and what it was started for."""

    def __init__(self, domain_id: int):
        self.domain_id = domain_id
        self.suite = None
        self.key = None


class RosBackend(EpisodeBackend):
    """Episodes through the ROS suite's RunCapture service, results read from the bags.

    bag_dir: where bags are written (default: a temporary folder removed by ``close``);
    keep_bags: keep each bag after reading it; params: extra node parameters
    (:class:`~tethernet_ros.ros.suite.RosSuite`); log_dir: node logs (a folder per suite
    when workers > 1); start_timeout / episode_timeout: wall seconds for a suite to come
    up / per episode; workers: suites side by side, each in its own ROS domain from
    ``domain_id`` on (default: the environment's, else one of this process's own);
    lockstep, controller: as RosSuite has them.
    """

    name = "ros suite"

    def __init__(self, bag_dir: str | Path | None = None, keep_bags: bool = False,
                 params: dict | None = None, log_dir: str | Path | None = None,
                 start_timeout: float = 300.0, episode_timeout: float = 900.0,
                 workers: int = 1, lockstep: bool = False, controller: str | None = None,
                 domain_id: int | None = None):
        from .suite import controller_identity, default_domain

        self._tmp = None
        if bag_dir is None:
            self._tmp = tempfile.mkdtemp(prefix="tethernet_ros_bags_")
            bag_dir = self._tmp
        self.bag_dir = Path(bag_dir)
        self.keep_bags = bool(keep_bags)
        self.params = params
        self.log_dir = log_dir
        self.start_timeout = float(start_timeout)
        self.episode_timeout = float(episode_timeout)
        self.workers = max(1, int(workers))
        self.lockstep = bool(lockstep)
        self.controller = controller
        #: the controller's spec and source hash enter the run key (EpisodeBackend)
        self.episode_source = controller_identity(controller) if controller else None
        base = default_domain() if domain_id is None else int(domain_id)
        self._slots = [_Slot((base + i) % (MAX_DOMAIN + 1)) for i in range(self.workers)]
        self._count = threading.Lock()
        self.episodes = 0
        self.suite_starts = 0

    @property
    def suite(self):
        """The first suite (the only one with one worker), or None before it started."""
        return self._slots[0].suite

    def describe(self) -> str:
        how = (f", controller {self.controller}" if self.controller
               else ", closing policy through ROS" if self.lockstep else "")
        many = f" x {self.workers} (domains {self._slots[0].domain_id}.." \
               f"{self._slots[-1].domain_id})" if self.workers > 1 else ""
        return f"ROS 2 suite{many} (RunCapture service, results read from MCAP bags{how})"

    # -- suite lifetime --------------------------------------------------------------------
    @staticmethod
    def _key(task: EpisodeTask) -> str:
        spreads = task.noise_model.spreads()
        return json.dumps({"config": task.config.to_dict(), "spreads": spreads},
                          sort_keys=True, default=str)

    def _suite_for(self, slot: _Slot, task: EpisodeTask):
        from .suite import RosSuite

        key = self._key(task)
        if slot.suite is not None and key != slot.key:
            self._stop_suite(slot)
        if slot.suite is None:
            self.bag_dir.mkdir(parents=True, exist_ok=True)
            log_dir = self.log_dir
            if log_dir is not None and self.workers > 1:
                log_dir = Path(log_dir) / f"suite{self._slots.index(slot)}"
            suite = RosSuite(config=task.config, noise_model=task.noise_model,
                             params=self.params, bag_dir=self.bag_dir, log_dir=log_dir,
                             lockstep=self.lockstep, controller=self.controller,
                             domain_id=slot.domain_id)
            suite.start(timeout=self.start_timeout)
            slot.suite, slot.key = suite, key
            with self._count:
                self.suite_starts += 1
        return slot.suite

    @staticmethod
    def _stop_suite(slot: _Slot) -> None:
        if slot.suite is not None:
            try:
                slot.suite.stop()
            finally:
                slot.suite, slot.key = None, None

    def close(self) -> None:
        for slot in self._slots:
            self._stop_suite(slot)
        if self._tmp is not None:
            shutil.rmtree(self._tmp, ignore_errors=True)
            self._tmp = None

    # -- episodes --------------------------------------------------------------------------
    def map(self, tasks, max_in_flight=None):
        k = 1 if max_in_flight == 1 else self.workers
        if k == 1:
            for task in tasks:
                yield self._outcome(self._slots[0], task)
            return
        source = iter(tasks)
        take = threading.Lock()
        stop = threading.Event()
        done = object()
        out: queue.Queue = queue.Queue()

        def work(slot):
            try:
                while not stop.is_set():
                    with take:
                        task = next(source, None)
                    if task is None:
                        return
                    out.put(self._outcome(slot, task, cancel=stop))
            finally:
                out.put(done)

        threads = [threading.Thread(target=work, args=(slot,), name=f"ros-suite-{i}",
                                    daemon=True) for i, slot in enumerate(self._slots[:k])]
        for t in threads:
            t.start()
        try:
            finished = 0
            while finished < len(threads):
                item = out.get()
                if item is done:
                    finished += 1
                else:
                    yield item
        finally:
            # left early (an interrupt, SIGTERM, a consumer that has what it needs): the
            # episodes in flight are cancelled, not waited for
            stop.set()
            for t in threads:
                t.join()

    def _outcome(self, slot: _Slot, task: EpisodeTask,
                 cancel: threading.Event | None = None) -> Outcome:
        try:
            return Outcome(task, self.run_task(task, slot, cancel=cancel))
        except Exception as exc:  # noqa: BLE001 - every task error becomes an outcome
            if cancel is not None and cancel.is_set():
                self._stop_suite(slot)        # its nodes may still run the abandoned episode
                return Outcome(task, error=error_text(exc))
            crashed = False
            if slot.suite is not None:
                try:
                    slot.suite.check_alive()
                except Exception:  # noqa: BLE001 - a node died: restart for the next task
                    crashed = True
            if crashed or slot.suite is None:
                self._stop_suite(slot)
            return Outcome(task, error=error_text(exc), crashed=crashed)

    def run_task(self, task: EpisodeTask, slot: _Slot | None = None,
                 cancel: threading.Event | None = None) -> SampleResult:
        """One sample through a suite; the result as recorded in the episode's bag
        (``cancel``: abandon the episode once set, :meth:`.suite.RosSuite.call`)."""
        suite = self._suite_for(slot or self._slots[0], task)
        name = sample_name(task.key, task.seed, task.attempt)
        t0 = time.perf_counter()
        resp = suite.call(suite.request(task.design, task.seed, task.noise_model,
                                        record_bag=True, bag_name=name),
                          timeout=self.episode_timeout, cancel=cancel)
        wall = time.perf_counter() - t0
        if resp.status == REJECTED:
            raise RuntimeError(f"RunCapture refused the sample: {resp.error}")
        bag = resp.bag_path
        try:
            if resp.status == ABORTED and is_controller_timeout(resp.error):
                with self._count:
                    self.episodes += 1
                return controller_failure_result(task, resp.error, wall)
            if resp.status != SUCCEEDED:
                raise RuntimeError(f"RunCapture failed ({STATUS_NAMES.get(resp.status, resp.status)}): "
                                   f"{resp.error}")
            if not bag:
                raise RuntimeError("RunCapture recorded no bag")
            msg, metrics = result_from_bag(bag, name, with_metrics=task.record_trace)
            mismatch = compare_results(msg, resp.result)
            if mismatch:
                raise BagResultError(f"bag {bag} and the service response differ: {mismatch}")
        finally:
            if bag and not self.keep_bags:
                shutil.rmtree(bag, ignore_errors=True)
        with self._count:
            self.episodes += 1
        r = episode_result_from_msg(msg)
        if int(msg.seed) != task.seed or msg.nominal:
            raise BagResultError(f"bag {bag}: result of seed {msg.seed}, expected {task.seed}")
        trace = None
        if task.record_trace:
            trace = {"time": [float(m.sim_time) for m in metrics],
                     "cqi": [float(m.cqi) for m in metrics],
                     "locked_pairs": [int(m.locked_pairs) for m in metrics]}
        return sample_result(task, r, trace=trace, wall_time=wall, steps=r.steps,
                             max_penetration=r.max_penetration)
