"""The design a finished optimisation run would validate next, for a run whose directory is
gone or whose chosen design failed a later check (a second validation).  It replays
``optimizer.finish.choose_design`` itself on the run's checkpoint, with the race's and the
validations' recorded counts in place of simulation: the ranking, the race (its dropped
designs removed), then the validations in turn, each failed one added to the constraint
GP's data and the ranking redone.  The first design with no recorded validation is the
next one.  It stops with an error if the replay raced or validated other designs than the
records name, so a reader sees that it gives back the run's own order.

    .venv/bin/python scripts/next_candidate.py CHECKPOINT.json --case mass \
        --race 153:94:100:dropped,144:982:1000:undecided \
        --failed 144:372:384,87:308:320 [--min-probability 0.5] [--racing-candidates 5]

``--race``: EVALUATION:SUCCESSES:SAMPLES:STATUS per raced design, in the ranking's order;
``--failed``: EVALUATION:SUCCESSES:SAMPLES per validation that counts as failed, in the
order validated (a design that passed one validation and failed a second one is given
with both validations' samples).  Evaluations are numbered from 1 as in history.csv.
Runs whose race cleared a design, or with the selection level "pass", are not handled.
"""
from __future__ import annotations

import argparse
import json
import sys
from types import SimpleNamespace

import numpy as np

from optimizer.bayesopt import ConstrainedBayesOpt
from optimizer.cases import get_case
from optimizer.checkpoint import load_checkpoint
from optimizer.finish import choose_design
from optimizer.racing import RaceEntry, RaceResult


class NextDesign(Exception):
    """Raised by the replayed validator at the first design with no recorded validation."""

    def __init__(self, evaluation: int):
        super().__init__(evaluation)
        self.evaluation = evaluation


def _entries(text: str, fields: int, what: str) -> list[tuple]:
    out = []
    for item in filter(None, (text or "").split(",")):
        parts = item.split(":")
        if len(parts) != fields:
            raise SystemExit(f"--{what} {item!r}: expected {fields} fields separated by ':'")
        out.append((int(parts[0]), int(parts[1]), int(parts[2]), *parts[3:]))
    return out


class RecordedValidator:
    """Stands for :class:`optimizer.finish.Validator`: answers with the recorded counts,
    every one a failure, and raises :class:`NextDesign` at a design it has none for."""

    samples = 1000
    rule = "wilson"

    def __init__(self, number, failed):
        self.number, self.failed, self.order = number, {e: (k, n) for e, k, n in failed}, []

    def __call__(self, x, label):
        e = self.number(x)
        if e not in self.failed:
            raise NextDesign(e)
        self.order.append(e)
        k, n = self.failed[e]
        # a failure by either rule (optimizer.finish.meets_requirement); the constraint
        # GP's evidence reads only the counts
        return SimpleNamespace(successes=k, n_samples=n, p_success=-1.0, ci_low=-1.0)

    def meets(self, result) -> bool:
        return False

    def as_dict(self, result):
        return None


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("checkpoint")
    p.add_argument("--case", default="mass")
    p.add_argument("--race", default="")
    p.add_argument("--failed", default="")
    p.add_argument("--min-probability", type=float, default=0.5)
    p.add_argument("--racing-candidates", type=int, default=None,
                   help="candidates raced (default: as many as --race names)")
    args = p.parse_args(argv)
    opt = ConstrainedBayesOpt.from_state_dict(load_checkpoint(args.checkpoint)["optimizer"],
                                              None)
    history = opt.history
    race = _entries(args.race, 4, "race")
    failed = _entries(args.failed, 3, "failed")

    def number(x) -> int:
        return next(i + 1 for i, o in enumerate(history) if np.array_equal(o.x, x))

    def racer(candidates):
        raced = [number(o.x) for o in candidates]
        if raced != [e for e, *_ in race]:
            raise SystemExit(f"the replay races evaluations {raced}; the records name "
                             f"{[e for e, *_ in race]}")
        return RaceResult(entries=[RaceEntry(o, k, n, status) for o, (_, k, n, status)
                                   in zip(candidates, race)],
                          rounds=0, episodes=sum(n for _, _, n, _ in race),
                          stopped_by="recorded")

    settings = SimpleNamespace(
        racing_candidates=args.racing_candidates if args.racing_candidates is not None
        else len(race),
        validation_candidates=len(history), min_probability=args.min_probability,
        selection_level="requirement", validation_samples=RecordedValidator.samples,
        validation_rule=RecordedValidator.rule)
    validator = RecordedValidator(number, failed)
    try:
        choose_design(get_case(args.case), opt, False, settings, validator,
                      racer if race else None)
    except NextDesign as nxt:
        if validator.order != [e for e, *_ in failed]:
            raise SystemExit(f"the replay validates evaluations {validator.order} before "
                             f"{nxt.evaluation}; the records name {[e for e, *_ in failed]}") from None
        obs = history[nxt.evaluation - 1]
        print(f"raced (as recorded): {[e for e, *_ in race]}; validated and failed (as "
              f"recorded): {validator.order}")
        print(json.dumps({"evaluation": nxt.evaluation, "objective": obs.objective,
                          "x": [float(v) for v in obs.x],
                          "successes": obs.info.get("successes"),
                          "samples": obs.info.get("samples")}))
        return 0
    print("no design left to validate", file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main())
