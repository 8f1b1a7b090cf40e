"""What one Monte Carlo sample is: the task a worker runs and the result it returns.

Times in s, masses in kg; NaN where a value is undefined (a results-file record writes it
as null).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from optimizer.jsonio import json_clean

from ..core import metrics
from ..core.config import SimConfig
from ..core.design import Design
from ..core.noise import NoiseModel

#: Version of the results-file record layout.
RECORD_VERSION = 1
#: Trace series carried back from workers when traces are requested.
TRACE_FIELDS = ("time", "cqi", "locked_pairs")


def failure_category(reason: str, config: SimConfig | None = None, settled_cqi: float | None = None,
                     locked_pairs: int | None = None, closing_time: float | None = None) -> str:
    """:func:`tethernet_ros.core.metrics.failure_category` with the success thresholds of
    ``config`` (default: SimConfig()); '' when ``reason`` is empty."""
    cfg = config or SimConfig()
    return metrics.failure_category(reason, settled_cqi, locked_pairs, closing_time,
                                    cfg.success_cqi, cfg.success_locked_pairs)


@dataclass(frozen=True)
class EpisodeTask:
    """One sample to simulate: everything a worker needs (picklable, no open resources).

    index: sample index within its run; seed: noise seed; key: run key (see
    :func:`~tethernet_ros.montecarlo.keys.run_key`); attempt: 0 for the first try, 1 for
    the retry.
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
    launch_time: float = 0.0
    tug: dict | None = None
    #: the success criterion that judged ``success`` ('source' or 'held'; config.py); a
    #: results-file record holds it as the name of its ``criterion`` mapping, with the
    #: thresholds (``evaluate._extra``)
    criterion: str = "source"

    # fields that must agree bit for bit whichever backend ran the sample
    DETERMINISTIC = ("key", "seed", "success", "settled_cqi", "locked_pairs", "closing_time",
                     "completion_time", "mass", "failure_reason", "category", "steps",
                     "max_penetration", "trace", "launch_time", "tug", "criterion")

    def outcome(self) -> dict:
        """The deterministic part (no wall time, index or attempt count), for comparisons."""
        return {k: getattr(self, k) for k in self.DETERMINISTIC}

    def to_record(self) -> dict:
        """The results-file record: every field, strict JSON (NaN -> null), version ``v``."""
        d = asdict(self)
        d["v"] = RECORD_VERSION
        return json_clean(d)

    @classmethod
    def from_record(cls, rec: dict) -> SampleResult:
        names = {f for f in cls.__dataclass_fields__}
        d = {k: v for k, v in rec.items() if k in names}
        for k in ("settled_cqi", "closing_time", "completion_time", "mass", "max_penetration",
                  "wall_time", "cpu_time"):
            if d.get(k) is None:
                d[k] = math.nan
        if isinstance(d.get("criterion"), dict):
            d["criterion"] = d["criterion"].get("name", "source")
        if "launch_time" in d and d["launch_time"] is None:
            d["launch_time"] = math.nan     # (a record before launch policies has none: 0)
        return cls(**d)


def sample_result(task: EpisodeTask, episode, cpu_time: float = 0.0, trace: dict | None = None,
                  wall_time: float | None = None, steps: int | None = None,
                  max_penetration: float | None = None) -> SampleResult:
    """The :class:`SampleResult` of ``task`` from its episode's result (an
    :class:`~tethernet_ros.core.episode.EpisodeResult` or anything with its fields; a
    ``closing_time`` of None means never triggered).  ``wall_time``, ``steps`` and
    ``max_penetration`` default to the episode's own."""
    closing = math.nan if episode.closing_time is None else float(episode.closing_time)
    return SampleResult(
        key=task.key, index=task.index, seed=task.seed, success=bool(episode.success),
        settled_cqi=float(episode.settled_cqi), locked_pairs=int(episode.locked_pairs),
        closing_time=closing, completion_time=float(episode.completion_time),
        mass=float(episode.mass), failure_reason=episode.failure_reason,
        category=failure_category(episode.failure_reason, task.config, float(episode.settled_cqi),
                                  int(episode.locked_pairs), closing),
        steps=int(episode.steps if steps is None else steps),
        max_penetration=float(episode.max_penetration if max_penetration is None
                              else max_penetration),
        wall_time=float(episode.wall_time if wall_time is None else wall_time),
        cpu_time=cpu_time, attempts=task.attempt + 1, trace=trace,
        launch_time=float(getattr(episode, "launch_time", 0.0)),
        tug=getattr(episode, "tug", None),
        criterion=metrics.criterion_of(episode))


def worker_error_result(task: EpisodeTask, error: str) -> SampleResult:
    """A failed sample for a task whose worker raised or died on every try."""
    return SampleResult(
        key=task.key, index=task.index, seed=task.seed, success=False, settled_cqi=math.nan,
        locked_pairs=0, closing_time=math.nan, completion_time=math.nan,
        mass=task.design.mass(task.config.density), failure_reason=f"worker error: {error}",
        category="worker error", attempts=task.attempt + 1, criterion=task.config.criterion)


def error_text(exc: BaseException) -> str:
    """One line (at most 300 characters) naming an exception raised by a task."""
    text = f"{type(exc).__name__}: {exc}".strip()
    return text.splitlines()[0][:300] if text else type(exc).__name__
