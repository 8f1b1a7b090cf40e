"""Monte Carlo reliability of a design: N noise samples through the simulator.

One evaluator, :func:`evaluate` (and :func:`evaluate_many` for several designs or noise
models in one batch), over any :class:`EpisodeBackend`:

* :class:`InProcessBackend`  -- serial, in this process;
* :class:`ProcessPoolBackend` -- local worker processes (the default, all cores);
* :class:`DaskBackend`       -- a ``dask.distributed`` cluster, or a local one.

Common random numbers
    Sample ``i`` of a run with base seed ``b`` draws its noise with
    ``NoiseModel.sample(sample_seed(b, i))``, ``sample_seed(b, i) = b * 1_000_003 + i``.
    The draw depends on the seed only, never on the design or the noise scales, so every
    design (and every scale of a sensitivity study) sees the same underlying random
    numbers for the same sample.  The default base seed 0 gives seeds 0, 1, 2, ... (so
    ``tethernet capture --seed 17`` replays sample 17 of a default validation); seeds of
    different base seeds do not overlap while N < 1_000_003.

Results file (JSON lines)
    When ``results_path`` is given, each sample's result is appended as one JSON object per
    line as soon as it finishes (written, flushed and fsync'ed).  A record carries ``key``,
    a hash of everything that determines the episode (design, noise model, simulation
    config, seed mapping and the source of ``tethernet_ros/core``), and the ``seed``;
    re-running with the same file skips every (key, seed) already there, so a killed run
    resumes where it stopped and a larger run reuses a smaller one.  A partial last line
    (the process was killed while writing it) is cut off before appending.  One file may
    hold records of several designs; records with another key are kept and ignored.

Failures
    A sample whose worker raises or dies is retried once (a worker death is retried with
    nothing else in flight, so that an innocent sample that shared the dead pool is not
    blamed twice); if it fails again it is a failed sample with reason
    ``"worker error: ..."``.  Nothing is dropped: P*_s always divides by N.
"""
from __future__ import annotations

import abc
import hashlib
import json
import math
import os
import time
from collections import Counter, deque
from dataclasses import asdict, dataclass, field, replace
from functools import lru_cache
from pathlib import Path
from typing import Callable, Iterable, Iterator, Sequence

from .core.config import SimConfig
from .core.design import Design
from .core.metrics import clopper_pearson_interval, wilson_interval
from .core.noise import NoiseModel

#: Seed of sample i under base seed b: b * SEED_STRIDE + i.
SEED_STRIDE = 1_000_003
#: Version of the results-file record layout.
RECORD_VERSION = 1
#: Trace series carried back from workers when traces are requested.
TRACE_FIELDS = ("time", "cqi", "locked_pairs")
#: Environment variable of the test fault hook (see :func:`_fault_hook`).
FAULT_ENV = "TETHERNET_MC_FAULT"


def default_workers() -> int:
    """CPU cores this process may run on (the default pool size)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def sample_seed(base_seed: int, index: int) -> int:
    """Noise seed of sample ``index`` (0-based) under ``base_seed`` (both integers >= 0)."""
    if base_seed < 0 or index < 0:
        raise ValueError("base seed and sample index must be >= 0")
    return int(base_seed) * SEED_STRIDE + int(index)


# --------------------------------------------------------------------------------------
# failure categories
# --------------------------------------------------------------------------------------
def failure_category(reason: str, config: SimConfig | None = None, settled_cqi: float | None = None,
                     locked_pairs: int | None = None, closing_time: float | None = None) -> str:
    """Group a failed episode into a category for counting ('' when ``reason`` is empty).

    Categories: 'worker error', 'diverged', 'closing never triggered', 'settled CQI > 2',
    'locked pairs < 10', 'settled CQI > 2 and locked pairs < 10' (thresholds from the
    config), 'other'.  The numbers (settled CQI, n_L, closing time; NaN closing time = never
    triggered) decide where given; otherwise the reason text does.
    """
    if not reason:
        return ""
    cfg = config or SimConfig()
    r = reason.lower()
    if r.startswith("worker error"):
        return "worker error"
    if "diverged" in r:
        return "diverged"
    cqi_label = f"settled CQI > {cfg.success_cqi:g}"
    pairs_label = f"locked pairs < {cfg.success_locked_pairs}"
    if closing_time is not None or settled_cqi is not None:
        if closing_time is not None and not math.isfinite(closing_time):
            return "closing never triggered"
        bad_cqi = settled_cqi is not None and not (settled_cqi <= cfg.success_cqi)
        bad_pairs = locked_pairs is not None and locked_pairs < cfg.success_locked_pairs
    else:
        if "closing never triggered" in r:
            return "closing never triggered"
        bad_cqi = ("cqi" in r and ">" in r) or "not finite" in r
        bad_pairs = "locked pairs" in r
    if bad_cqi and bad_pairs:
        return f"{cqi_label} and {pairs_label}"
    if bad_cqi:
        return cqi_label
    if bad_pairs:
        return pairs_label
    return "other"


# --------------------------------------------------------------------------------------
# tasks and per-sample results
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class EpisodeTask:
    """One sample to simulate: everything a worker needs (picklable, no open resources).

    index: sample index within its run; seed: noise seed; key: run key (see
    :func:`run_key`); attempt: 0 for the first try, 1 for the retry.
    """

    key: str
    index: int
    seed: int
    design: Design
    noise_model: NoiseModel
    config: SimConfig
    record_trace: bool = False
    attempt: int = 0


@dataclass
class SampleResult:
    """Outcome of one Monte Carlo sample.  Times in s, mass in kg; NaN where undefined.

    category: failure category ('' on success, see :func:`failure_category`);
    trace: {'time', 'cqi', 'locked_pairs'} lists at the metric rate, when requested;
    attempts: tries it took (2 after a retry); wall_time, cpu_time: the episode's wall-clock
    and process CPU time in its worker (s).
    """

    key: str
    index: int
    seed: int
    success: bool
    settled_cqi: float
    locked_pairs: int
    closing_time: float
    completion_time: float
    mass: float
    failure_reason: str
    category: str
    steps: int = 0
    max_penetration: float = math.nan
    wall_time: float = 0.0
    cpu_time: float = 0.0
    attempts: int = 1
    trace: dict | None = None

    # fields that must agree bit for bit whichever backend ran the sample
    DETERMINISTIC = ("key", "seed", "success", "settled_cqi", "locked_pairs", "closing_time",
                     "completion_time", "mass", "failure_reason", "category", "steps",
                     "max_penetration", "trace")

    def outcome(self) -> dict:
        """The deterministic part (no wall time, index or attempt count), for comparisons."""
        return {k: getattr(self, k) for k in self.DETERMINISTIC}

    def to_record(self) -> dict:
        d = asdict(self)
        d["v"] = RECORD_VERSION
        for k, v in d.items():
            if isinstance(v, float) and not math.isfinite(v):
                d[k] = None
        return d

    @classmethod
    def from_record(cls, rec: dict) -> "SampleResult":
        names = {f for f in cls.__dataclass_fields__}
        d = {k: v for k, v in rec.items() if k in names}
        for k in ("settled_cqi", "closing_time", "completion_time", "mass", "max_penetration",
                  "wall_time", "cpu_time"):
            if d.get(k) is None:
                d[k] = math.nan
        return cls(**d)


def run_task(task: EpisodeTask) -> SampleResult:
    """Simulate one task (the function every backend's workers call)."""
    from .core.episode import run_episode

    _fault_hook(task)
    sample = task.noise_model.sample(task.seed)
    cpu0 = time.process_time()
    r = run_episode(task.design, sample, task.config, record_trace=task.record_trace)
    cpu = time.process_time() - cpu0
    trace = None
    if task.record_trace and r.trace is not None:
        trace = {f: list(getattr(r.trace, f)) for f in TRACE_FIELDS}
    return SampleResult(
        key=task.key, index=task.index, seed=task.seed, success=bool(r.success),
        settled_cqi=float(r.settled_cqi), locked_pairs=int(r.locked_pairs),
        closing_time=float(r.closing_time), completion_time=float(r.completion_time),
        mass=float(r.mass), failure_reason=r.failure_reason,
        category=failure_category(r.failure_reason, task.config, float(r.settled_cqi),
                                  int(r.locked_pairs), float(r.closing_time)),
        steps=int(r.steps),
        max_penetration=float(r.max_penetration), wall_time=float(r.wall_time), cpu_time=cpu,
        attempts=task.attempt + 1, trace=trace)


def worker_error_result(task: EpisodeTask, error: str) -> SampleResult:
    """A failed sample for a task whose worker raised or died on every try."""
    return SampleResult(
        key=task.key, index=task.index, seed=task.seed, success=False, settled_cqi=math.nan,
        locked_pairs=0, closing_time=math.nan, completion_time=math.nan,
        mass=task.design.mass(task.config.density), failure_reason=f"worker error: {error}",
        category="worker error", attempts=task.attempt + 1)


def _fault_hook(task: EpisodeTask) -> None:
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
        from .core.design import REFERENCE_DESIGNS
        from .core.episode import CaptureSimulation
        from .core.scenario import scenario_for

        sim = CaptureSimulation(scenario_for(REFERENCE_DESIGNS["time-min"], None, SimConfig()))
        sim.advance(2)
        sim.cqi()
    except Exception:  # noqa: BLE001 - warming is an optimisation; a task reports real errors
        pass


# --------------------------------------------------------------------------------------
# run keys
# --------------------------------------------------------------------------------------
@lru_cache(maxsize=1)
def model_version() -> str:
    """Hash of the simulator core's source (tethernet_ros/core/**/*.py), so that results of
    a changed model are never reused.  Computed once per process."""
    from . import core as core_pkg

    h = hashlib.sha256()
    core = Path(core_pkg.__file__).parent
    for p in sorted(core.rglob("*.py")):
        h.update(p.relative_to(core).as_posix().encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def run_key(design: Design, noise_model: NoiseModel, config: SimConfig) -> str:
    """Identity of the episodes a (design, noise model, config) produces for a seed."""
    ident = {"design": design.to_dict(), "noise": asdict(noise_model), "config": config.to_dict(),
             "seed_map": f"b*{SEED_STRIDE}+i", "model": model_version()}
    blob = json.dumps(ident, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:20]


# --------------------------------------------------------------------------------------
# backends
# --------------------------------------------------------------------------------------
@dataclass
class Outcome:
    """What a backend yields for one task: the result, or an error text; ``crashed`` marks
    a worker process that died (every task in flight on a broken pool gets one)."""

    task: EpisodeTask
    result: SampleResult | None = None
    error: str | None = None
    crashed: bool = False


def _error_text(exc: BaseException) -> str:
    text = f"{type(exc).__name__}: {exc}".strip()
    return text.splitlines()[0][:300] if text else type(exc).__name__


class EpisodeBackend(abc.ABC):
    """Runs :class:`EpisodeTask` s somewhere and yields :class:`Outcome` s as they finish.

    ``map`` never raises for a failing task: the outcome carries the error.  At most
    ``max_in_flight`` tasks run at once (None: the backend's choice).  Backends are
    reusable across calls (workers stay warm) and are context managers; ``close()``
    releases the workers.  ``workers`` is the parallelism (for reports).
    """

    name = "backend"
    workers = 1

    @abc.abstractmethod
    def map(self, tasks: Iterable[EpisodeTask], max_in_flight: int | None = None) -> Iterator[Outcome]:
        ...

    def close(self) -> None:
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
                yield Outcome(t, error=_error_text(exc))


class ProcessPoolBackend(EpisodeBackend):
    """Local worker processes (concurrent.futures, 'spawn' context by default: no forked
    numba/LLVM or ROS state).  Each worker loads the numba cache once at start
    (:func:`warm_worker`).  A pool broken by a dying worker is replaced."""

    name = "process pool"

    def __init__(self, workers: int | None = None, context: str = "spawn", warm: bool = True):
        self.workers = int(workers or default_workers())
        if self.workers < 1:
            raise ValueError("workers must be >= 1")
        self.context = context
        self.warm = warm
        self._pool = None

    def start(self) -> "ProcessPoolBackend":
        """Start the workers now and wait until all are warm (else they start lazily)."""
        pool = self._get_pool()
        if self.warm:
            futs = [pool.submit(_noop) for _ in range(self.workers * 2)]
            for f in futs:
                f.result()
        return self

    def _get_pool(self):
        if self._pool is None:
            import multiprocessing as mp
            from concurrent.futures import ProcessPoolExecutor

            self._pool = ProcessPoolExecutor(
                max_workers=self.workers, mp_context=mp.get_context(self.context),
                initializer=warm_worker if self.warm else None)
        return self._pool

    def _drop_pool(self):
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def map(self, tasks, max_in_flight=None):
        from concurrent.futures import FIRST_COMPLETED, wait
        from concurrent.futures.process import BrokenProcessPool

        limit = max(1, min(max_in_flight or self.workers, self.workers))
        pending = deque(tasks)
        inflight = {}
        try:
            while pending or inflight:
                broken = False
                while pending and len(inflight) < limit and not broken:
                    try:
                        fut = self._get_pool().submit(run_task, pending[0])
                    except BrokenProcessPool:
                        broken = True
                        break
                    inflight[fut] = pending.popleft()
                if not broken:
                    done, _ = wait(list(inflight), return_when=FIRST_COMPLETED)
                    broken = any(isinstance(f.exception(), BrokenProcessPool) for f in done)
                if broken:  # every future of a broken pool completes at once
                    done, _ = wait(list(inflight))
                for fut in done:
                    task = inflight.pop(fut)
                    exc = fut.exception()
                    if exc is None:
                        yield Outcome(task, fut.result())
                    elif isinstance(exc, KeyboardInterrupt):  # Ctrl-C reached the workers too
                        raise KeyboardInterrupt
                    elif isinstance(exc, BrokenProcessPool):
                        yield Outcome(task, error="worker process died (BrokenProcessPool)",
                                      crashed=True)
                    else:
                        yield Outcome(task, error=_error_text(exc))
                if broken:
                    self._drop_pool()
        finally:
            for fut in inflight:
                fut.cancel()

    def close(self):
        self._drop_pool()


def _noop():
    return None


class DaskBackend(EpisodeBackend):
    """A dask.distributed cluster: ``scheduler`` is an address ('tcp://host:8786') or
    None / 'local' for a LocalCluster of ``workers`` single-threaded worker processes
    (no dashboard).  Workers need tethernet_ros importable and are warmed with
    :func:`warm_worker`.  On the local cluster a dying worker fails its task at once
    (allowed-failures 0); on a remote scheduler its own setting applies first."""

    name = "dask"

    def __init__(self, scheduler: str | None = None, workers: int | None = None):
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

    def start(self) -> "DaskBackend":
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
        pending = deque(tasks)
        limit = max_in_flight or max(len(pending), 1)
        ac = as_completed()
        inflight = {}

        def submit_more():
            while pending and len(inflight) < limit:
                t = pending.popleft()
                fut = client.submit(run_task, t, pure=False, retries=0)
                inflight[fut.key] = (fut, t)
                ac.add(fut)

        submit_more()
        try:
            for fut in ac:
                _, task = inflight.pop(fut.key)
                if fut.status == "finished":
                    yield Outcome(task, fut.result())
                else:
                    try:
                        exc = fut.exception()
                    except BaseException as e:  # noqa: BLE001 - cancelled / lost futures
                        exc = e
                    crashed = type(exc).__name__ == "KilledWorker"
                    yield Outcome(task, error="worker process died (KilledWorker)" if crashed
                                  else _error_text(exc), crashed=crashed)
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


def make_backend(workers: int | None = None, scheduler: str | None = None) -> EpisodeBackend:
    """The backend a command line asks for: ``scheduler`` (address or 'local') -> Dask;
    ``workers`` 0 -> in-process; else a process pool of ``workers`` (default all cores)."""
    if scheduler:
        return DaskBackend(scheduler, workers)
    if workers == 0:
        return InProcessBackend()
    return ProcessPoolBackend(workers)


def run_tasks(backend: EpisodeBackend, tasks: Sequence[EpisodeTask], retries: int = 1) -> Iterator[SampleResult]:
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


# --------------------------------------------------------------------------------------
# results file
# --------------------------------------------------------------------------------------
class ResultsFile:
    """Append-only JSON-lines file of :class:`SampleResult` records (see module doc)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.skipped_lines = 0

    def load(self) -> dict[tuple[str, int], SampleResult]:
        """Records by (key, seed); a record with a trace wins over one without, else the
        later one.  A partial last line is cut off the file; unreadable lines are skipped."""
        out: dict[tuple[str, int], SampleResult] = {}
        if not self.path.exists():
            return out
        self._repair_tail()
        self.skipped_lines = 0
        with self.path.open("r", encoding="utf-8") as f:
            for line in f:
                line = line.strip()
                if not line:
                    continue
                try:
                    rec = json.loads(line)
                    r = SampleResult.from_record(rec)
                except (ValueError, TypeError, KeyError):
                    self.skipped_lines += 1
                    continue
                k = (r.key, r.seed)
                if k in out and out[k].trace is not None and r.trace is None:
                    continue
                out[k] = r
        return out

    def _repair_tail(self) -> None:
        with self.path.open("rb+") as f:
            f.seek(0, os.SEEK_END)
            size = f.tell()
            if size == 0:
                return
            f.seek(size - 1)
            if f.read(1) == b"\n":
                return
            # find the last newline; everything after it is a partial record
            pos = size
            block = 65536
            while pos > 0:
                start = max(0, pos - block)
                f.seek(start)
                chunk = f.read(pos - start)
                i = chunk.rfind(b"\n")
                if i >= 0:
                    f.truncate(start + i + 1)
                    return
                pos = start
            f.truncate(0)

    def append(self, result: SampleResult, extra: dict | None = None) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        rec = result.to_record()
        if extra:
            rec.update(extra)
        line = json.dumps(rec, separators=(",", ":"), allow_nan=False, default=_json_default)
        with self.path.open("a", encoding="utf-8") as f:
            f.write(line + "\n")
            f.flush()
            os.fsync(f.fileno())


def _json_default(o):
    import numpy as np

    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


# --------------------------------------------------------------------------------------
# the evaluator
# --------------------------------------------------------------------------------------
@dataclass
class MonteCarloResult:
    """Reliability of one design under one noise model.

    p_success = successes / n_samples (worker errors count as failures);
    ci_low, ci_high: Wilson 95 % interval; cp_low, cp_high: Clopper-Pearson 95 %;
    mean_completion_time: mean T (s) over samples with a finite T (every episode except
    worker errors; a 'closing never triggered' sample counts with T = horizon);
    mean_completion_time_success: mean T over the successes; mass: m_a (kg);
    failures_by_reason: failure category -> count (sums to the number of failures);
    samples: per-sample results ordered by index; reused: samples read from the results
    file instead of simulated; wall_time: s.
    """

    design: Design
    label: str
    key: str
    n_samples: int
    base_seed: int
    successes: int
    p_success: float
    ci_low: float
    ci_high: float
    cp_low: float
    cp_high: float
    mean_completion_time: float
    mean_completion_time_success: float
    mass: float
    failures_by_reason: dict
    samples: list
    reused: int = 0
    wall_time: float = 0.0
    backend: str = ""
    noise_scales: dict = field(default_factory=dict)

    @classmethod
    def from_samples(cls, design: Design, samples: Sequence[SampleResult], base_seed: int,
                     key: str, config: SimConfig, label: str = "", reused: int = 0,
                     wall_time: float = 0.0, backend: str = "",
                     noise_scales: dict | None = None) -> "MonteCarloResult":
        samples = sorted(samples, key=lambda r: r.index)
        n = len(samples)
        k = sum(1 for r in samples if r.success)
        lo, hi = wilson_interval(k, n)
        clo, chi = clopper_pearson_interval(k, n)
        ts = [r.completion_time for r in samples if math.isfinite(r.completion_time)]
        tss = [r.completion_time for r in samples if r.success and math.isfinite(r.completion_time)]
        fails = Counter(r.category or "other" for r in samples if not r.success)
        return cls(design=design, label=label, key=key, n_samples=n, base_seed=base_seed,
                   successes=k, p_success=k / n if n else math.nan, ci_low=lo, ci_high=hi,
                   cp_low=clo, cp_high=chi,
                   mean_completion_time=sum(ts) / len(ts) if ts else math.nan,
                   mean_completion_time_success=sum(tss) / len(tss) if tss else math.nan,
                   mass=design.mass(config.density),
                   failures_by_reason=dict(fails.most_common()), samples=list(samples),
                   reused=reused, wall_time=wall_time, backend=backend,
                   noise_scales=dict(noise_scales or {}))

    @property
    def failures(self) -> int:
        return self.n_samples - self.successes

    def to_dict(self, with_samples: bool = False) -> dict:
        d = {"design_name": self.label, "design": self.design.to_dict(), "mass": self.mass,
             "samples": self.n_samples, "base_seed": self.base_seed, "successes": self.successes,
             "p_success": self.p_success, "ci_low": self.ci_low, "ci_high": self.ci_high,
             "ci_method": "wilson", "cp_low": self.cp_low, "cp_high": self.cp_high,
             "mean_completion_time": self.mean_completion_time,
             "mean_completion_time_success": self.mean_completion_time_success,
             "failures": self.failures, "failures_by_reason": dict(self.failures_by_reason),
             "worker_errors": self.failures_by_reason.get("worker error", 0),
             "noise_scales": self.noise_scales, "key": self.key, "reused": self.reused,
             "wall_time": self.wall_time, "backend": self.backend}
        if with_samples:
            d["per_sample"] = [r.to_record() for r in self.samples]
        return d


@dataclass(frozen=True)
class RunSpec:
    """One (design, noise model, config) to evaluate in a batch; ``label`` names it."""

    design: Design
    noise_model: NoiseModel = field(default_factory=NoiseModel)
    config: SimConfig = field(default_factory=SimConfig)
    label: str = ""


ProgressFn = Callable[[int, int, SampleResult | None], None]


def evaluate(design: Design, n_samples: int, base_seed: int = 0,
             noise_model: NoiseModel | None = None, config: SimConfig | None = None,
             backend: EpisodeBackend | None = None, *, results_path: str | Path | None = None,
             record_trace: bool = False, label: str = "", resume: bool = True,
             progress: ProgressFn | None = None, retries: int = 1) -> MonteCarloResult:
    """P*_s, its intervals, mean T and failures of ``design`` over samples 0..n_samples-1
    of ``base_seed`` (seeds :func:`sample_seed`).

    backend: None -> a :class:`ProcessPoolBackend` on all cores, closed afterwards (pass
    one to keep workers warm across calls).  results_path: JSON-lines file to append to
    and resume from (None: no file).  record_trace: carry each sample's CQI / n_L series
    back (SampleResult.trace).  progress(done, total, result) is called once with
    result None and the count already done, then after each finished sample.
    """
    spec = RunSpec(design, noise_model or NoiseModel(), config or SimConfig(), label)
    return evaluate_many([spec], n_samples, base_seed, backend, results_path=results_path,
                         record_trace=record_trace, resume=resume, progress=progress,
                         retries=retries)[0]


def evaluate_many(specs: Sequence[RunSpec], n_samples: int, base_seed: int = 0,
                  backend: EpisodeBackend | None = None, *,
                  results_path: str | Path | None = None, record_trace: bool = False,
                  resume: bool = True, progress: ProgressFn | None = None,
                  retries: int = 1) -> list[MonteCarloResult]:
    """:func:`evaluate` for several specs in one batch (one task queue, so the workers stay
    busy); specs with identical keys are simulated once.  Results in the order of specs."""
    if isinstance(n_samples, bool) or int(n_samples) != n_samples or n_samples < 1:
        raise ValueError(f"samples: got {n_samples!r}; must be an integer >= 1")
    if isinstance(base_seed, bool) or int(base_seed) != base_seed or base_seed < 0:
        raise ValueError(f"seed: got {base_seed!r}; must be an integer >= 0")
    t0 = time.perf_counter()
    keys = [run_key(s.design, s.noise_model, s.config) for s in specs]
    seeds = [sample_seed(base_seed, i) for i in range(n_samples)]
    rfile = ResultsFile(results_path) if results_path is not None else None
    known = rfile.load() if (rfile is not None and resume) else {}

    done: dict[tuple[str, int], SampleResult] = {}
    tasks: list[EpisodeTask] = []
    queued = set()
    for spec, key in zip(specs, keys):
        for i, seed in enumerate(seeds):
            k = (key, seed)
            rec = known.get(k)
            if rec is not None and (rec.trace is not None or not record_trace):
                done[k] = replace(rec, index=i)
            elif k not in queued:
                queued.add(k)
                tasks.append(EpisodeTask(key, i, seed, spec.design, spec.noise_model, spec.config,
                                         record_trace))
    reused = {key: sum(1 for s in seeds if (key, s) in done) for key in set(keys)}
    total = len(done) + len(tasks)
    if progress is not None:
        progress(len(done), total, None)

    extras = {key: {"design": spec.design.to_dict(), "noise_scales": spec.noise_model.scales}
              for spec, key in zip(specs, keys)}
    own = backend is None and tasks
    be = backend or (ProcessPoolBackend() if tasks else InProcessBackend())
    try:
        for r in run_tasks(be, tasks, retries=retries):
            done[(r.key, r.seed)] = r
            if rfile is not None:
                rfile.append(r, extras.get(r.key))
            if progress is not None:
                progress(len(done), total, r)
    finally:
        if own:
            be.close()

    wall = time.perf_counter() - t0
    out = []
    for spec, key in zip(specs, keys):
        samples = [replace(done[(key, s)], index=i) for i, s in enumerate(seeds)]
        out.append(MonteCarloResult.from_samples(
            spec.design, samples, base_seed, key, spec.config, label=spec.label,
            reused=reused[key], wall_time=wall, backend=be.describe(),
            noise_scales={k: v for k, v in spec.noise_model.scales.items() if v != 1.0}))
    return out
