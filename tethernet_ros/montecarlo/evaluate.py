"""The evaluator: P*_s, its intervals, mean T and failures of a design over N samples.

:func:`evaluate` (one design) and :func:`evaluate_many` (several designs or noise models in
one task queue, so the workers stay busy) run samples ``0..N-1`` of a base seed (common
random numbers, :mod:`~tethernet_ros.montecarlo.seeds`) on any
:class:`~tethernet_ros.montecarlo.backends.EpisodeBackend`, reusing and appending to a
results file (:mod:`~tethernet_ros.montecarlo.results_file`).

Sequential sampling (``evaluate(..., stop=rule)``): the samples are drawn in batches of
``batch_size`` (default: the backend's ``batch_size``, one sample per lane of every worker;
when the rule tells how many more samples its decision is expected to take,
``rule.expected_to_decide(successes)``, that many, up to the backend's
``max_batch_size``, which keeps the lanes refilled), in index order; after each batch
``stop`` sees the successes of the samples drawn so far, in index order, and either says
how many leading samples decide the estimate or asks for more.
The result then rests on exactly those leading samples, so it is the same whatever the
batch size, worker count or backend (samples drawn past the decision point only cost
time; they stay in the results file and are reused by a later run).
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from collections.abc import Callable, Sequence

from ..core.config import SimConfig
from ..core.design import Design
from ..core.noise import NoiseModel
from .backends import EpisodeBackend, InProcessBackend
from .keys import run_key
from .process_pool import ProcessPoolBackend
from .records import EpisodeTask, SampleResult
from .results_file import ResultsFile
from .running import run_tasks
from .seeds import sample_seed
from .summary import MonteCarloResult


@dataclass(frozen=True)
class RunSpec:
    """One (design, noise model, config) to evaluate in a batch; ``label`` names it."""

    design: Design
    noise_model: NoiseModel = field(default_factory=NoiseModel)
    config: SimConfig = field(default_factory=SimConfig)
    label: str = ""


ProgressFn = Callable[[int, int, SampleResult | None], None]
#: ``stop(successes)``: given the success of samples 0..n-1 (index order), the length of
#: the shortest prefix that decides the estimate, or None to draw more samples.
StopRule = Callable[[Sequence[bool]], "int | None"]


def evaluate(design: Design, n_samples: int, base_seed: int = 0,
             noise_model: NoiseModel | None = None, config: SimConfig | None = None,
             backend: EpisodeBackend | None = None, *, results_path: str | Path | None = None,
             record_trace: bool = False, label: str = "", resume: bool = True,
             progress: ProgressFn | None = None, retries: int = 1, stop: StopRule | None = None,
             batch_size: int | None = None) -> MonteCarloResult:
    """P*_s, its intervals, mean T and failures of ``design`` over samples 0..n_samples-1
    of ``base_seed`` (seeds :func:`~tethernet_ros.montecarlo.seeds.sample_seed`).

    backend: None -> a :class:`ProcessPoolBackend` on all cores, closed afterwards (pass
    one to keep workers warm across calls).  results_path: JSON-lines file to append to
    and resume from (None: no file).  record_trace: carry each sample's CQI / n_L series
    back (SampleResult.trace).  progress(done, total, result) is called with result None
    and the count already done, then after each finished sample.  stop: sequential
    sampling (module docstring); the result then holds the deciding samples only
    (``n_samples`` of the result <= ``n_samples`` asked); batch_size: samples per batch
    (default: the backend's workers).
    """
    spec = RunSpec(design, noise_model or NoiseModel(), config or SimConfig(), label)
    if stop is not None:
        return _evaluate_sequential(spec, n_samples, base_seed, backend, stop, batch_size,
                                    results_path=results_path, record_trace=record_trace,
                                    resume=resume, progress=progress, retries=retries)
    return evaluate_many([spec], n_samples, base_seed, backend, results_path=results_path,
                         record_trace=record_trace, resume=resume, progress=progress,
                         retries=retries)[0]


def _check_counts(n_samples, base_seed) -> None:
    if isinstance(n_samples, bool) or int(n_samples) != n_samples or n_samples < 1:
        raise ValueError(f"samples: got {n_samples!r}; must be an integer >= 1")
    if isinstance(base_seed, bool) or int(base_seed) != base_seed or base_seed < 0:
        raise ValueError(f"seed: got {base_seed!r}; must be an integer >= 0")


def _load(rfile: ResultsFile, keys: set) -> dict:
    """The file's records; one line on stderr if the samples of ``keys`` in it were made
    on another machine (:meth:`ResultsFile.machine_summary`)."""
    known = rfile.load()
    line = rfile.machine_summary(keys)
    if line:
        print(f"resuming: {line}", file=sys.stderr)
    return known


def _usable(rec: SampleResult | None, record_trace: bool) -> bool:
    """A stored record stands for a new run of its sample (it has a trace if one is asked)."""
    return rec is not None and (rec.trace is not None or not record_trace)


def _extra(spec: RunSpec) -> dict:
    """What a results-file record adds to say which run it belongs to (and, for a target
    other than the default Zenit-2, which: its name, file, SHA-256 and units), and the
    criterion that judged its success: its name ('source' or 'held', docs/model.md §17),
    the settled CQI's bound and the locked pairs needed (§7), and under 'held' the pull's
    towing acceleration and the thrust given directly (0: none)."""
    cfg = spec.config
    criterion = {"name": cfg.criterion, "success_cqi": cfg.success_cqi,
                 "success_locked_pairs": cfg.success_locked_pairs}
    if cfg.criterion == "held":
        criterion.update(tow_acceleration=cfg.tug.tow_acceleration,
                         peak_tension=cfg.tug.peak_tension)
    extra = {"design": spec.design.to_dict(), "noise_scales": spec.noise_model.scales,
             "criterion": criterion}
    if cfg.target.kind != "revolution":
        extra["target"] = cfg.target.identity()
    return extra


def _changed_scales(spec: RunSpec) -> dict:
    return {k: v for k, v in spec.noise_model.scales.items() if v != 1.0}


def _simulate(be: EpisodeBackend, tasks: Sequence[EpisodeTask], retries: int,
              rfile: ResultsFile | None, extras: dict):
    """Run ``tasks``; append each result to the results file as it finishes; yield it."""
    for r in run_tasks(be, tasks, retries=retries):
        if rfile is not None:
            rfile.append(r, extras.get(r.key))
        yield r


def evaluate_many(specs: Sequence[RunSpec], n_samples: int, base_seed: int = 0,
                  backend: EpisodeBackend | None = None, *,
                  results_path: str | Path | None = None, record_trace: bool = False,
                  resume: bool = True, progress: ProgressFn | None = None,
                  retries: int = 1) -> list[MonteCarloResult]:
    """:func:`evaluate` for several specs in one batch (one task queue, so the workers stay
    busy); specs with identical keys are simulated once.  Results in the order of specs."""
    _check_counts(n_samples, base_seed)
    t0 = time.perf_counter()
    source = getattr(backend, "episode_source", None)
    keys = [run_key(s.design, s.noise_model, s.config, episode_source=source) for s in specs]
    seeds = [sample_seed(base_seed, i) for i in range(n_samples)]
    rfile = ResultsFile(results_path) if results_path is not None else None
    known = _load(rfile, set(keys)) if (rfile is not None and resume) else {}

    done: dict[tuple[str, int], SampleResult] = {}
    tasks: list[EpisodeTask] = []
    queued = set()
    for spec, key in zip(specs, keys):
        for i, seed in enumerate(seeds):
            k = (key, seed)
            rec = known.get(k)
            if _usable(rec, record_trace):
                done[k] = replace(rec, index=i)
            elif k not in queued:
                queued.add(k)
                tasks.append(EpisodeTask(key, i, seed, spec.design, spec.noise_model, spec.config,
                                         record_trace))
    reused = {key: sum(1 for s in seeds if (key, s) in done) for key in set(keys)}
    total = len(done) + len(tasks)
    if progress is not None:
        progress(len(done), total, None)

    extras = {key: _extra(spec) for spec, key in zip(specs, keys)}
    own = backend is None and tasks
    be = backend or (ProcessPoolBackend() if tasks else InProcessBackend())
    try:
        for r in _simulate(be, tasks, retries, rfile, extras):
            done[(r.key, r.seed)] = r
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
            noise_scales=_changed_scales(spec)))
    return out


def _batch_for(backend: EpisodeBackend, stop: StopRule, successes: list) -> int:
    """Samples to draw next (module docstring): the backend's batch_size, or as many as
    the rule expects its decision to take, up to the backend's max_batch_size."""
    least = int(backend.batch_size)
    expected = getattr(stop, "expected_to_decide", None)
    if expected is None:
        return least
    most = max(least, int(backend.max_batch_size))
    return max(least, min(most, math.ceil(expected(successes))))


def _evaluate_sequential(spec: RunSpec, n_samples: int, base_seed: int,
                         backend: EpisodeBackend | None, stop: StopRule,
                         batch_size: int | None, *, results_path, record_trace: bool,
                         resume: bool, progress: ProgressFn | None,
                         retries: int) -> MonteCarloResult:
    """:func:`evaluate` with a stopping rule (see the module docstring)."""
    _check_counts(n_samples, base_seed)
    if batch_size is not None and (isinstance(batch_size, bool) or int(batch_size) < 1):
        raise ValueError(f"batch_size: got {batch_size!r}; must be an integer >= 1")
    t0 = time.perf_counter()
    key = run_key(spec.design, spec.noise_model, spec.config,
                  episode_source=getattr(backend, "episode_source", None))
    rfile = ResultsFile(results_path) if results_path is not None else None
    known = _load(rfile, {key}) if (rfile is not None and resume) else {}
    extras = {key: _extra(spec)}
    samples: list[SampleResult] = []   # samples 0..len-1, in index order
    from_file: set[int] = set()
    # a pool of our own starts with its first map (none if the file holds every sample)
    be, own = (backend, False) if backend is not None else (ProcessPoolBackend(), True)
    simulated = False
    decided = None
    try:
        while decided is None and len(samples) < n_samples:
            start = len(samples)
            size = int(batch_size or _batch_for(be, stop, [r.success for r in samples]))
            batch: dict[int, SampleResult] = {}
            tasks = []
            for i in range(start, min(start + size, n_samples)):
                seed = sample_seed(base_seed, i)
                rec = known.get((key, seed))
                if _usable(rec, record_trace):
                    batch[i] = replace(rec, index=i)
                    from_file.add(i)
                else:
                    tasks.append(EpisodeTask(key, i, seed, spec.design, spec.noise_model,
                                             spec.config, record_trace))
            if progress is not None:
                progress(start + len(batch), n_samples, None)
            simulated = simulated or bool(tasks)
            for r in _simulate(be, tasks, retries, rfile, extras):
                batch[r.index] = r
                if progress is not None:
                    progress(start + len(batch), n_samples, r)
            samples.extend(batch[i] for i in sorted(batch))
            decided = stop([r.success for r in samples])
    finally:
        if own:
            be.close()
    used = samples[:decided] if decided is not None else samples
    return MonteCarloResult.from_samples(
        spec.design, used, base_seed, key, spec.config, label=spec.label,
        reused=sum(1 for r in used if r.index in from_file), wall_time=time.perf_counter() - t0,
        backend=(be if (simulated or not own) else InProcessBackend()).describe(),
        noise_scales=_changed_scales(spec))
