"""What a worker process does: simulate a group of tasks of one design on the batched
kernel (:func:`run_group`) or one task (:func:`run_task`), warm its numba kernels
(:func:`warm_worker`), and the test hook that makes it fail on purpose."""
from __future__ import annotations

import os
import time

from ..core.config import SimConfig
from .records import TRACE_FIELDS, EpisodeTask, SampleResult, error_text, sample_result

#: Environment variable of the test fault hook (see :func:`fault_hook`).
FAULT_ENV = "TETHERNET_MC_FAULT"


def run_task(task: EpisodeTask) -> SampleResult:
    """Simulate one task (a group of one); raise what the task raised."""
    from ..core.episode import run_episode

    fault_hook(task)
    sample = task.noise_model.sample(task.seed)
    cpu0 = time.process_time()
    r = run_episode(task.design, sample, task.config, record_trace=task.record_trace)
    return _result(task, r, time.process_time() - cpu0)


def _result(task: EpisodeTask, r, cpu: float) -> SampleResult:
    trace = None
    if task.record_trace and r.trace is not None:
        trace = {f: list(getattr(r.trace, f)) for f in TRACE_FIELDS}
    return sample_result(task, r, cpu_time=cpu, trace=trace)


def same_batch(a: EpisodeTask, b: EpisodeTask) -> bool:
    """Whether two tasks can share a batch (one model: same design, config and trace)."""
    return a.design == b.design and a.config == b.config and a.record_trace == b.record_trace


def iter_group(tasks, lanes: int | None = None):
    """Simulate tasks side by side on the batched kernel (``core.batch``): each run of
    consecutive tasks that can share a batch together, ``lanes`` per batch (None: chosen
    per CPU).  Yields (task, SampleResult or None, error text or None) per task as it
    finishes; a task that raises (its noise draw, the fault hook) gets its error and the
    others go on.  ``tasks`` is read lazily, a task when a lane frees up."""
    it = iter(tasks)
    pending = next(it, None)
    while pending is not None:
        head = pending
        pending = None

        def run_of_batch(first=head):
            nonlocal pending
            yield first
            for t in it:
                if not same_batch(first, t):
                    pending = t
                    return
                yield t

        yield from _run_batch(head, run_of_batch(), lanes)


def run_group(tasks, lanes: int | None = None) -> list:
    """:func:`iter_group` as a list (what a worker process returns for a group)."""
    return list(iter_group(tasks, lanes))


def _run_batch(first: EpisodeTask, tasks, lanes):
    from ..core.batch import BatchRunner

    errors = []

    def feed():
        for t in tasks:
            try:
                fault_hook(t)
                sample = t.noise_model.sample(t.seed)
            except Exception as exc:  # noqa: BLE001 - a task's error is its outcome
                errors.append((t, None, error_text(exc)))
                continue
            yield t, sample

    runner = BatchRunner(first.design, first.config, lanes=lanes,
                         record_trace=first.record_trace)
    for task, r, cpu in runner.run(feed()):
        yield from errors
        errors.clear()
        r.seed = task.seed
        yield task, _result(task, r, cpu), None
    yield from errors


def fault_hook(task: EpisodeTask) -> None:
    """Test hook: ``TETHERNET_MC_FAULT="KIND:SEED[,KIND:SEED...]"`` makes the worker fail
    on the sample with that seed; KIND is 'raise' or 'exit' (os._exit, a dying worker) on
    every try, or 'raise-once' / 'exit-once' on the first try only."""
    spec = os.environ.get(FAULT_ENV)
    if not spec:
        return
    for item in spec.split(","):
        kind, _, seed = item.strip().partition(":")
        if not seed or int(seed) != task.seed:
            continue
        if kind.endswith("-once") and task.attempt > 0:
            continue
        if kind.startswith("exit"):
            os._exit(17)
        if kind.startswith("raise"):
            raise RuntimeError(f"injected fault on seed {task.seed}")


def warm_kernels() -> None:
    """Compile (or load from numba's cache) everything an episode runs: both step
    methods, the sensing and policy code, the metrics; raises if compilation fails."""
    from ..core.design import REFERENCE_DESIGNS
    from ..core.episode import CaptureSimulation
    from ..core.policies import Policy
    from ..core.scenario import scenario_for
    from ..core.sensing import Sensor, true_measurement

    for integrator in ("implicit", "explicit"):
        sim = CaptureSimulation(scenario_for(REFERENCE_DESIGNS["time-min"], None,
                                             SimConfig(integrator=integrator)))
        sim.advance(2)
        sim.cqi()
    truth = true_measurement(sim.model, sim.data, 0)
    Sensor(sim.model.control, 0).measure(truth, sim.step)
    Policy(sim.model, 1.0).decide(truth)
    sim.command_closing()


def warm_worker() -> None:
    """Load the numba kernels from the on-disk cache (compile them if absent) with a few
    steps of a small episode, so that a fresh worker's first sample is not slower."""
    try:
        from ..core.design import REFERENCE_DESIGNS
        from ..core.episode import CaptureSimulation
        from ..core.scenario import scenario_for

        sim = CaptureSimulation(scenario_for(REFERENCE_DESIGNS["time-min"], None, SimConfig()))
        sim.advance(2)
        sim.cqi()
    except Exception:  # noqa: BLE001 - warming is an optimisation; a task reports real errors
        pass
