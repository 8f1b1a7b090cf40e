"""What a worker process does: simulate one task (:func:`run_task`), warm its numba
kernels (:func:`warm_worker`), and the test hook that makes it fail on purpose."""
from __future__ import annotations

import os
import time

from ..core.config import SimConfig
from .records import TRACE_FIELDS, EpisodeTask, SampleResult, sample_result

#: Environment variable of the test fault hook (see :func:`fault_hook`).
FAULT_ENV = "TETHERNET_MC_FAULT"


def run_task(task: EpisodeTask) -> SampleResult:
    """Simulate one task (the function every backend's workers call)."""
    from ..core.episode import run_episode

    fault_hook(task)
    sample = task.noise_model.sample(task.seed)
    cpu0 = time.process_time()
    r = run_episode(task.design, sample, task.config, record_trace=task.record_trace)
    cpu = time.process_time() - cpu0
    trace = None
    if task.record_trace and r.trace is not None:
        trace = {f: list(getattr(r.trace, f)) for f in TRACE_FIELDS}
    return sample_result(task, r, cpu_time=cpu, trace=trace)


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
