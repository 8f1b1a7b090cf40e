"""Many episodes of one design side by side: K lanes of one kernel call, in lockstep.

:class:`BatchRunner` takes episodes (noise samples) from an iterator as lanes free up and
yields each episode's :class:`~.episode.EpisodeResult` when it ends.  Every lane follows
the single episode's rules (:class:`~.episode.EpisodeClock`, :func:`~.episode.after_stop`,
:func:`~.episode.episode_result`): the batch advances by the fewest steps until some lane
reaches one of its own clock's steps, so each lane is looked at on exactly the steps a
single run looks at, and gives its episode bit for bit (lanes never read each other).  A
lane whose episode has ended takes the next episode at once; when the iterator has none
left and at most half the lanes are busy, the busy ones move into a batch half the size.

The lane count K is chosen per CPU by :func:`choose_lanes` (or given): it changes the
speed, never a result.
"""
from __future__ import annotations

import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from functools import lru_cache

from . import kernel as kn
from .config import SimConfig
from .design import Design
from .episode import (CaptureSimulation, EpisodeClock, EpisodeRecorder, EpisodeResult,
                      after_stop, episode_result)
from .noise import NoiseSample
from .scenario import Scenario, advance_kernel, scenario_for

#: lane counts :func:`choose_lanes` tries
LANE_CHOICES = (1, 2, 4, 8, 16)


@dataclass
class _Lane:
    """A busy lane: its episode's tag, simulation, clock, recorder, next stop, CPU time."""

    tag: object
    sim: CaptureSimulation
    clock: EpisodeClock
    rec: EpisodeRecorder
    stop: int
    cpu: float
    wall0: float


def _same_model(a: kn.Model, b: kn.Model) -> bool:
    """Whether two models are the same (the constants a lane shares with its batch)."""
    import numpy as np

    def eq(x, y):
        if isinstance(x, np.ndarray):
            return isinstance(y, np.ndarray) and x.shape == y.shape and np.array_equal(x, y)
        if isinstance(x, tuple):
            return len(x) == len(y) and all(eq(p, q) for p, q in zip(x, y))
        return x == y
    return eq(a, b)


class BatchRunner:
    """Runs episodes of ``design`` under ``config`` on ``lanes`` lanes (None:
    :func:`choose_lanes`).  ``run(samples)`` yields (tag, EpisodeResult, cpu_time) as
    episodes end, where ``samples`` yields (tag, NoiseSample or None) and cpu_time is the
    episode's share of the batch's CPU time (s).  ``broadphase``: the contacts' broad phase
    (``kernel.BROADPHASE_MODES``; it changes no result, only the speed)."""

    def __init__(self, design: Design, config: SimConfig | None = None,
                 lanes: int | None = None, record_trace: bool = False,
                 broadphase: str = "on"):
        self.design = design
        self.broadphase = broadphase
        self.config = config or SimConfig()
        self.record_trace = record_trace
        self.lanes = int(lanes) if lanes else choose_lanes(self.config)
        if self.lanes < 1:
            raise ValueError(f"lanes: got {lanes}; must be >= 1")

    def _scenario(self, sample: NoiseSample | None) -> Scenario:
        sc = scenario_for(self.design, sample, self.config)
        sc.broadphase = self.broadphase
        return sc

    def run(self, samples: Iterable[tuple[object, NoiseSample | None]]
            ) -> Iterator[tuple[object, EpisodeResult, float]]:
        feed = iter(samples)
        model = data = scratch = None
        lanes: list[_Lane | None] = []

        def load(slot: int, tag, sample) -> None:
            sc = self._scenario(sample)
            m1, d1 = sc.kernel()
            if not _same_model(m1, model):
                raise ValueError("a sample changed the model of its batch (design or config)")
            if d1.events[kn.E_LAUNCHED, 0] == 0:
                raise ValueError("the launch policy 'external' needs a controller outside the "
                                 "kernel; a batch runs in-kernel policies only")
            kn.copy_lane(data, slot, d1, 0)
            sc.attach(model, data, slot)
            sim = CaptureSimulation(sc)
            clock = EpisodeClock(self.config, sim.dt)
            rec = EpisodeRecorder(sim, clock, self.record_trace)
            rec.sample(sim.step)
            lanes[slot] = _Lane(tag, sim, clock, rec, clock.next_stop(sim.step, sim.end_step()),
                                0.0, time.perf_counter())

        exhausted = False

        def fill() -> None:
            nonlocal exhausted
            for slot in range(len(lanes)):
                if lanes[slot] is None and not exhausted:
                    nxt = next(feed, None)
                    if nxt is None:
                        exhausted = True
                        return
                    load(slot, *nxt)

        first = next(feed, None)
        if first is None:
            return
        sc0 = self._scenario(first[1])
        model, d0 = sc0.kernel()
        data = kn.empty_like(d0, self.lanes)
        scratch = kn.new_scratch(model, self.lanes)
        lanes = [None] * self.lanes
        load(0, *first)
        fill()
        finished: list[tuple[object, EpisodeResult, float]] = []
        while any(lane is not None for lane in lanes):
            busy = [lane for lane in lanes if lane is not None]
            n = min(lane.stop - lane.sim.step for lane in busy)
            cpu0 = time.process_time()
            advance_kernel(self.config, model, data, scratch, n)
            share = (time.process_time() - cpu0) / len(lanes)
            for slot, lane in enumerate(lanes):
                if lane is None:
                    continue
                lane.cpu += share
                if lane.sim.step < lane.stop:
                    continue
                c0 = time.process_time()
                ended, reason = after_stop(lane.sim, lane.rec)
                lane.cpu += time.process_time() - c0
                if ended:
                    res = episode_result(lane.sim, reason, time.perf_counter() - lane.wall0,
                                         lane.rec.trace)
                    finished.append((lane.tag, res, lane.cpu))
                    lanes[slot] = None
                else:
                    lane.stop = lane.clock.next_stop(lane.sim.step, lane.sim.end_step())
            fill()
            yield from finished
            finished.clear()
            if exhausted:
                model, data, scratch, lanes = self._compact(model, data, scratch, lanes)

    @staticmethod
    def _compact(model, data, scratch, lanes):
        """With no episode left to start and at most half the lanes busy, move the busy
        lanes into a batch half the size (the same bits: lanes are independent)."""
        busy = [i for i, lane in enumerate(lanes) if lane is not None]
        size = len(lanes)
        if not busy or size == 1 or len(busy) > size // 2:
            return model, data, scratch, lanes
        new_size = size // 2
        while new_size // 2 >= len(busy) and new_size > 1:
            new_size //= 2
        order = busy + [busy[0]] * (new_size - len(busy))   # padding: copies of a busy lane
        data = kn.take(data, order)
        scratch = kn.new_scratch(model, new_size)
        new_lanes: list[_Lane | None] = [None] * new_size
        for slot, old in enumerate(busy):
            lane = lanes[old]
            lane.sim.s.attach(model, data, slot)
            lane.sim.data = data
            new_lanes[slot] = lane
        return model, data, scratch, new_lanes


def choose_lanes(config: SimConfig | None = None) -> int:
    """The lane count with the least CPU time per lane-step on this CPU for the config's
    step method (:func:`_timed_lanes`, measured once per process; it changes no episode)."""
    cfg = config or SimConfig()
    return _timed_lanes(cfg.integrator, cfg.implicit_iterations)


@lru_cache(maxsize=8)
def _timed_lanes(integrator: str, iterations: int, steps: int = 300) -> int:
    """Each of LANE_CHOICES timed on ``steps`` steps of a nominal deploying time-min
    episode (about 0.3 s); a larger batch must be 10 % cheaper per lane-step to be chosen
    (every larger batch idles more at the end of a run and draws more samples past the
    decision of a sequential sampler)."""
    from .design import REFERENCE_DESIGNS

    cfg = SimConfig().replace(integrator=integrator, implicit_iterations=iterations)
    sc = scenario_for(REFERENCE_DESIGNS["time-min"], None, cfg)
    model, d1 = sc.kernel()
    best, best_cost = 1, float("inf")
    for k in LANE_CHOICES:
        data = kn.empty_like(d1, k)
        for lane in range(k):
            kn.copy_lane(data, lane, d1, 0)
        scratch = kn.new_scratch(model, k)
        advance_kernel(cfg, model, data, scratch, 2)   # compiled, caches warm
        t0 = time.process_time()
        advance_kernel(cfg, model, data, scratch, steps)
        cost = (time.process_time() - t0) / (steps * k)
        if cost < best_cost * 0.9:
            best, best_cost = k, cost
    return best
