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

One suite serves one episode at a time (``workers`` = 1).  The suite is started on the
first task and kept for the backend's lifetime; it is restarted when a task needs another
SimConfig or other noise spreads (carried by node parameters), and after a node died.
Bags are written under ``bag_dir`` (a temporary folder by default) and deleted once read
unless ``keep_bags`` (an optimisation run would otherwise keep tens of thousands).

Not carried by the messages: ``steps`` (reported as -1) and ``max_penetration`` (NaN).
"""
from __future__ import annotations

import json
import math
import shutil
import tempfile
import time
from pathlib import Path

from ..bags.naming import sample_name
from ..montecarlo import (EpisodeBackend, EpisodeTask, Outcome, SampleResult, error_text,
                          sample_result)
from .conversions import episode_result_from_msg
from .names import REJECTED, STATUS_NAMES, SUCCEEDED
from .results import BagResultError, compare_results, result_from_bag

__all__ = ["RosBackend", "result_from_bag", "BagResultError"]


class RosBackend(EpisodeBackend):
    """Episodes through the ROS suite's RunCapture service, results read from the bags.

    bag_dir: where bags are written (default: a temporary folder removed by ``close``);
    keep_bags: keep each bag after reading it; params: extra node parameters
    (:class:`~tethernet_ros.ros.suite.RosSuite`); log_dir: node logs;
    start_timeout / episode_timeout: wall seconds for the suite to come up / per episode.
    """

    name = "ros suite"
    workers = 1

    def __init__(self, bag_dir: str | Path | None = None, keep_bags: bool = False,
                 params: dict | None = None, log_dir: str | Path | None = None,
                 start_timeout: float = 300.0, episode_timeout: float = 900.0):
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
        self.suite = None
        self._suite_key = None
        self.episodes = 0
        self.suite_starts = 0

    def describe(self) -> str:
        return "ROS 2 suite (RunCapture service, results read from MCAP bags)"

    # -- suite lifetime --------------------------------------------------------------------
    @staticmethod
    def _key(task: EpisodeTask) -> str:
        spreads = task.noise_model.spreads()
        return json.dumps({"config": task.config.to_dict(), "spreads": spreads},
                          sort_keys=True, default=str)

    def _suite_for(self, task: EpisodeTask):
        from .suite import RosSuite

        key = self._key(task)
        if self.suite is not None and key != self._suite_key:
            self._stop_suite()
        if self.suite is None:
            self.bag_dir.mkdir(parents=True, exist_ok=True)
            suite = RosSuite(config=task.config, noise_model=task.noise_model,
                             params=self.params, bag_dir=self.bag_dir, log_dir=self.log_dir)
            suite.start(timeout=self.start_timeout)
            self.suite, self._suite_key = suite, key
            self.suite_starts += 1
        return self.suite

    def _stop_suite(self) -> None:
        if self.suite is not None:
            try:
                self.suite.stop()
            finally:
                self.suite, self._suite_key = None, None

    def close(self) -> None:
        self._stop_suite()
        if self._tmp is not None:
            shutil.rmtree(self._tmp, ignore_errors=True)
            self._tmp = None

    # -- episodes --------------------------------------------------------------------------
    def map(self, tasks, max_in_flight=None):
        for task in tasks:
            try:
                yield Outcome(task, self.run_task(task))
            except Exception as exc:  # noqa: BLE001 - every task error becomes an outcome
                crashed = False
                if self.suite is not None:
                    try:
                        self.suite.check_alive()
                    except Exception:  # noqa: BLE001 - a node died: restart for the next task
                        crashed = True
                if crashed or self.suite is None:
                    self._stop_suite()
                yield Outcome(task, error=error_text(exc), crashed=crashed)

    def run_task(self, task: EpisodeTask) -> SampleResult:
        """One sample through the suite; the result as recorded in the episode's bag."""
        suite = self._suite_for(task)
        name = sample_name(task.key, task.seed, task.attempt)
        t0 = time.perf_counter()
        resp = suite.call(suite.request(task.design, task.seed, task.noise_model,
                                        record_bag=True, bag_name=name),
                          timeout=self.episode_timeout)
        wall = time.perf_counter() - t0
        if resp.status == REJECTED:
            raise RuntimeError(f"RunCapture refused the sample: {resp.error}")
        bag = resp.bag_path
        try:
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
        self.episodes += 1
        r = episode_result_from_msg(msg)
        if int(msg.seed) != task.seed or msg.nominal:
            raise BagResultError(f"bag {bag}: result of seed {msg.seed}, expected {task.seed}")
        trace = None
        if task.record_trace:
            trace = {"time": [float(m.sim_time) for m in metrics],
                     "cqi": [float(m.cqi) for m in metrics],
                     "locked_pairs": [int(m.locked_pairs) for m in metrics]}
        # steps and penetration are not carried by the messages
        return sample_result(task, r, trace=trace, wall_time=wall, steps=-1,
                             max_penetration=math.nan)
