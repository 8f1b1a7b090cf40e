"""The design a finished optimisation run would validate next, rebuilt from its checkpoint
and the counts of its race and validations, for a run whose directory is gone or whose
chosen design failed a later check (a second validation).  It replays the order of
``optimizer.finish.choose_design``: the ranking of ``optimizer.selection.rank_candidates``,
the race's dropped designs removed, then each failed validation added to the constraint
GP's data and the ranking redone.  It prints the order it rebuilds, so that a reader checks
it against the run's recorded one, and the next design with its variables.

    .venv/bin/python scripts/next_candidate.py CHECKPOINT.json \
        --race 153:94:100:dropped,144:982:1000:undecided \
        --failed 144:372:384,87:308:320 [--min-probability 0.5]

``--race``: EVALUATION:SUCCESSES:SAMPLES:STATUS per raced design; ``--failed``:
EVALUATION:SUCCESSES:SAMPLES per failed validation, in the order they were validated.
Evaluations are numbered from 1 as in history.csv.  The run's selection level must be
"requirement" (the default); a run's cleared race winner is not handled (none is needed
when the race cleared nobody).
"""
from __future__ import annotations

import argparse
import json
import sys

from optimizer.bayesopt import ConstrainedBayesOpt
from optimizer.cases import P_SUCCESS
from optimizer.checkpoint import load_checkpoint
from optimizer.selection import rank_candidates, validation_evidence


def _entries(text: str, fields: int) -> list[list[str]]:
    out = []
    for item in filter(None, (text or "").split(",")):
        parts = item.split(":")
        if len(parts) != fields:
            raise SystemExit(f"{item!r}: expected {fields} fields separated by ':'")
        out.append(parts)
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("checkpoint")
    p.add_argument("--race", default="")
    p.add_argument("--failed", default="")
    p.add_argument("--min-probability", type=float, default=0.5)
    args = p.parse_args(argv)
    state = load_checkpoint(args.checkpoint)["optimizer"]
    opt = ConstrainedBayesOpt.from_state_dict(state, None)
    history = opt.history

    def number(obs) -> int:
        return next(i + 1 for i, o in enumerate(history) if o is obs)

    def show(ranked, n=6):
        return ", ".join(f"{number(o)} ({o.objective:.4f})" for o in ranked[:n])

    ranked, rule = rank_candidates(opt, args.min_probability)
    print(f"ranking ({rule}): {show(ranked)}")
    race = _entries(args.race, 4)
    evidence = [validation_evidence(history[int(e) - 1], int(k), int(n), P_SUCCESS)
                for e, k, n, _ in race]
    dropped = {int(e) for e, _, _, status in race if status == "dropped"}

    def reorder(r):
        return [o for o in r if number(o) not in dropped]

    if race:
        ranked = reorder(rank_candidates(opt, args.min_probability, evidence)[0]) or reorder(ranked)
        print(f"after the race ({len(race)} raced, {len(dropped)} dropped): {show(ranked)}")
    tried: set[int] = set()
    for e, k, n in _entries(args.failed, 3):
        nxt = next((o for o in ranked if number(o) not in tried), None)
        rebuilt = number(nxt) if nxt is not None else None
        print(f"validate next: {rebuilt}; recorded: {e} ({k}/{n}, failed)"
              + ("" if rebuilt == int(e) else "  <- differs from the run's order"))
        tried.add(int(e))
        evidence.append(validation_evidence(history[int(e) - 1], int(k), int(n), P_SUCCESS))
        ranked = reorder(rank_candidates(opt, args.min_probability, evidence)[0])
    left = [o for o in ranked if number(o) not in tried]
    print(f"ranking now: {show(left)}")
    if not left:
        print("no design left to validate", file=sys.stderr)
        return 1
    nxt = left[0]
    print(json.dumps({"evaluation": number(nxt), "objective": nxt.objective,
                      "x": [float(v) for v in nxt.x], "info": {
                          k: nxt.info.get(k) for k in ("successes", "samples")}}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
