"""Racing: the first ranked designs told apart on fresh samples before any validation.

The designs a run ranks first sit on the constraint's edge, often near-copies whose
optimisation estimates (100 samples, common random numbers) cannot tell 97 % from 98 %.
Validating them in turn spends a 1000-sample validation on each until one passes.
Racing (a ranking-and-selection procedure of simulation optimisation: a fully sequential
feasibility check) spends fewer samples first:

* the first ``candidates`` ranked designs (lowest objective first) are sampled in rounds,
  ``round_samples`` more samples each per round, on samples of their own base seed
  (``racing_seed``: fresh with respect to the optimisation and the validation, the same
  samples for every candidate);
* after each round a candidate is **dropped** once the upper end of the Wilson 95 %
  interval of its racing samples falls below C_P, and **cleared** once the lower end
  reaches C_P; a cleared candidate is sampled no further, nor is any candidate with a
  higher objective than a cleared one (it could not win: **released**), nor one that
  reached ``max_samples`` undecided (**undecided**: its true P*_s is close to C_P, where
  a validation would hardly tell either);
* the race ends when the lowest-objective candidate not dropped is cleared, when no
  candidate is left racing, or when the next round would pass ``budget`` samples in all.

The **winner** is the lowest-objective cleared candidate.  The validations then take the
designs in the ranking's order with the dropped ones removed and the winner first (before
any lighter candidate left undecided: that one's validation would most likely fail);
every raced design's racing samples join the constraint GP's data (as a failed
validation's do), so that the ranking of the rest learns from them.
The racing samples are counted in the run's episodes.  The intervals are recomputed at
every round, so a candidate may be dropped or cleared by a lucky streak more often than
the 95 % suggests; the validation, on samples of its own, is the test that decides.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from .cases import P_SUCCESS
from .observation import Observation, wilson_interval
from .selection import validation_evidence

__all__ = ["RaceEntry", "RaceResult", "race"]


@dataclass
class RaceEntry:
    """One raced design: ``candidate`` (its observation), ``successes`` of ``samples``
    racing samples, ``status`` ("racing", "dropped", "cleared", "released" or
    "undecided") and the round it was dropped or cleared in (0: neither)."""

    candidate: Observation
    successes: int = 0
    samples: int = 0
    status: str = "racing"
    decided_in_round: int = 0

    @property
    def interval(self) -> tuple[float, float]:
        """Wilson 95 % interval of the racing samples."""
        return wilson_interval(self.successes, self.samples)


@dataclass
class RaceResult:
    """How a race went: ``entries`` (objective order), ``rounds``, ``episodes`` (racing
    samples drawn), ``winner`` (the lowest-objective cleared entry, or None) and
    ``stopped_by`` ("cleared": the lowest-objective candidate left was cleared;
    "decided": none left racing; "budget"; "no candidates")."""

    entries: list[RaceEntry] = field(default_factory=list)
    rounds: int = 0
    episodes: int = 0
    winner: RaceEntry | None = None
    stopped_by: str = "no candidates"

    def dropped(self, obs: Observation) -> bool:
        return any(e.candidate is obs and e.status == "dropped" for e in self.entries)

    def evidence(self) -> list[Observation]:
        """The racing samples of every raced design, as observations for the constraint
        GP (:func:`~optimizer.selection.validation_evidence`)."""
        return [validation_evidence(e.candidate, e.successes, e.samples, P_SUCCESS)
                for e in self.entries if e.samples]

    def order(self, ranked: Sequence[Observation]) -> list[Observation]:
        """``ranked`` with the dropped designs removed and the winner first."""
        out = [o for o in ranked if not self.dropped(o)]
        if self.winner is not None:
            out = [self.winner.candidate] + [o for o in out if o is not self.winner.candidate]
        return out

    def to_dict(self, evaluation_of: Callable[[Observation], int]) -> dict:
        """JSON-ready: the race for the summary (``evaluation_of``: an observation's
        evaluation number)."""
        return {
            "rounds": self.rounds, "episodes": self.episodes, "stopped_by": self.stopped_by,
            "winner": evaluation_of(self.winner.candidate) if self.winner else None,
            "entries": [{"evaluation": evaluation_of(e.candidate),
                         "objective": e.candidate.objective, "successes": e.successes,
                         "samples": e.samples, "wilson": list(e.interval),
                         "status": e.status, "decided_in_round": e.decided_in_round}
                        for e in self.entries],
        }


def race(candidates: Sequence[Observation], sample: Callable[[Observation, int], object],
         threshold: float, round_samples: int, budget: int,
         max_samples: int | None = None, clear_level: float | None = None) -> RaceResult:
    """Race ``candidates`` (lowest objective first; module docstring).

    Args:
        candidates: the designs, in the order of the ranking.
        sample: ``sample(candidate, n)`` -> the candidate's estimate over racing samples
            ``0..n-1`` (with ``successes`` and ``n_samples``); called with growing ``n``
            for the same candidate, it may reuse the samples already drawn.
        threshold: C_P.
        round_samples: samples per candidate and round.
        budget: the most racing samples in all.
        max_samples: the most racing samples per candidate (None: no limit).
        clear_level: the lower end of the Wilson interval that clears a candidate
            (None: ``threshold``; the selection level of docs/optimizer.md §5).
    """
    clear_at = threshold if clear_level is None else clear_level
    result = RaceResult(entries=[RaceEntry(c) for c in candidates])
    if not result.entries:
        return result
    while True:
        live = [e for e in result.entries if e.status == "racing"]
        if not live:
            result.stopped_by = "decided"
            break
        step = {id(e): round_samples if max_samples is None
                else min(round_samples, max_samples - e.samples) for e in live}
        if result.episodes + sum(step.values()) > budget:
            result.stopped_by = "budget"
            break
        result.rounds += 1
        for e in live:
            r = sample(e.candidate, e.samples + step[id(e)])
            result.episodes += int(r.n_samples) - e.samples
            e.successes, e.samples = int(r.successes), int(r.n_samples)
            low, high = e.interval
            if high < threshold:
                e.status, e.decided_in_round = "dropped", result.rounds
            elif low >= clear_at:
                e.status, e.decided_in_round = "cleared", result.rounds
            elif max_samples is not None and e.samples >= max_samples:
                e.status = "undecided"
        standing = [e for e in result.entries if e.status != "dropped"]
        first_cleared = next((i for i, e in enumerate(standing) if e.status == "cleared"),
                             None)
        if first_cleared is not None:
            for e in standing[first_cleared + 1:]:
                if e.status == "racing":
                    e.status = "released"
        if standing and standing[0].status == "cleared":
            result.stopped_by = "cleared"
            break
    result.winner = next((e for e in result.entries if e.status == "cleared"), None)
    return result
