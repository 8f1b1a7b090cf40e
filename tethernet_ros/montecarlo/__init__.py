"""Monte Carlo reliability of a design: N noise samples through the simulator.

One evaluator, :func:`evaluate` (and :func:`evaluate_many` for several designs or noise
models in one batch), over any :class:`EpisodeBackend`:

* :class:`InProcessBackend`  -- serial, in this process;
* :class:`ProcessPoolBackend` -- local worker processes (the default, all cores);
* :class:`DaskBackend`       -- a ``dask.distributed`` cluster, or a local one.

A module per job, in reading order:

=================  ==========================================================================
seeds.py           common random numbers: sample i of base seed b draws seed b * 1_000_003 + i
keys.py            run keys: the identity of a (design, noise model, config) and the model
records.py         EpisodeTask, SampleResult (one sample), failure categories
worker.py          what a worker runs: run_group (a group of tasks on the batched kernel),
                   run_task, warm_worker, the fault hook of the tests
backends.py        the EpisodeBackend interface, Outcome, the in-process backend
process_pool.py    ProcessPoolBackend
dask_backend.py    DaskBackend
running.py         make_backend (command-line choice), run_tasks (retries, nothing dropped)
results_file.py    resumable JSON-lines results
summary.py         MonteCarloResult: P*_s, Wilson / Clopper-Pearson intervals, mean T
evaluate.py        evaluate, evaluate_many; sequential sampling with a stopping rule
=================  ==========================================================================

Everything public is importable from ``tethernet_ros.montecarlo`` itself.
"""
from .backends import (GROUP_SIZE, EpisodeBackend, InProcessBackend, Outcome, default_workers,
                       group_size_for)
from .dask_backend import DaskBackend
from .evaluate import ProgressFn, RunSpec, StopRule, evaluate, evaluate_many
from .keys import model_version, run_key
from .process_pool import ProcessPoolBackend
from .records import (RECORD_VERSION, TRACE_FIELDS, EpisodeTask, SampleResult, error_text,
                      failure_category, sample_result, worker_error_result)
from .results_file import ResultsFile
from .running import make_backend, run_tasks
from .seeds import SEED_STRIDE, sample_seed
from .summary import MonteCarloResult
from .worker import FAULT_ENV, run_group, run_task, warm_worker


__all__ = [
    "DaskBackend", "EpisodeBackend", "EpisodeTask", "FAULT_ENV", "GROUP_SIZE", "InProcessBackend",
    "MonteCarloResult", "Outcome", "ProcessPoolBackend", "ProgressFn", "RECORD_VERSION",
    "ResultsFile", "RunSpec", "SEED_STRIDE", "SampleResult", "StopRule", "TRACE_FIELDS",
    "default_workers", "error_text", "evaluate", "evaluate_many", "failure_category",
    "group_size_for",
    "make_backend", "model_version", "run_group", "run_key", "run_task", "run_tasks",
    "sample_result",
    "sample_seed", "warm_worker", "worker_error_result",
]
