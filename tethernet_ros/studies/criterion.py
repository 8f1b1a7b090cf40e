"""How well a success criterion separates the captures that hold from those that let go
(issue 36, point 3; docs/studies/criterion.md): over samples that ran the tug test
(docs/model.md §17), the ranking power of the settled CQI and of the locked pairs (the
area under the ROC curve), the source's rule (CQI <= 2.0 and at least 10 locked pairs)
as a classifier of the tug's verdict, and the thresholds of the same form that separate
best on a selection set, checked on an independent one.  Reports only: no simulation."""
from __future__ import annotations

import bisect
import math
from dataclasses import asdict, dataclass

from ..core.config import _LIMITS as CONFIG_LIMITS, SimConfig
from ..core.metrics import cqi_fails, pairs_fail, wilson_interval
from .tug import median

__all__ = ["Rule", "RuleScore", "SOURCE_RULE", "auc", "score", "fit_rule", "Separation",
           "separation", "separation_table", "within_cells_table"]


@dataclass(frozen=True)
class Rule:
    """A capture is called a success when its settled CQI is at most ``max_cqi`` and at
    least ``min_pairs`` drawstring pairs are locked (the source's form, docs/model.md §7)."""

    max_cqi: float
    min_pairs: int

    def __call__(self, s) -> bool:
        return not (cqi_fails(s.settled_cqi, self.max_cqi)
                    or pairs_fail(s.locked_pairs, self.min_pairs))

    def text(self) -> str:
        return f"CQI <= {self.max_cqi:.3g}, pairs >= {self.min_pairs}"


#: the source's criterion (docs/model.md §7): SimConfig's default thresholds
SOURCE_RULE = Rule(SimConfig().success_cqi, SimConfig().success_locked_pairs)
#: the pair bounds a fitted rule may take (SimConfig.success_locked_pairs's range)
PAIR_BOUNDS = range(CONFIG_LIMITS["success_locked_pairs"][0], CONFIG_LIMITS["success_locked_pairs"][1] + 1)


@dataclass(frozen=True)
class RuleScore:
    """A rule against the tug's verdict over n tested samples: held, the successes it
    calls, the false captures (called, lost) and missed captures (not called, held), the
    true positive rate (held ones called), true negative rate (lost ones not called) and
    balanced accuracy (their mean; 0.5 is chance, 1 perfect), the precision (called ones
    that hold) with its Wilson 95 % interval."""

    n: int
    held: int
    called: int
    false_captures: int
    missed_captures: int
    tpr: float
    tnr: float
    balanced_accuracy: float
    precision: float
    precision_lo: float
    precision_hi: float


def _tested(samples) -> list:
    """Samples whose tug test ran, with a finite settled CQI."""
    return [s for s in samples if s.tug and s.settled_cqi == s.settled_cqi]


def score(rule: Rule, samples) -> RuleScore:
    tested = _tested(samples)
    n_held = sum(1 for s in tested if s.tug["held"])
    n_lost = len(tested) - n_held
    called = [s for s in tested if rule(s)]
    tp = sum(1 for s in called if s.tug["held"])
    tpr = tp / n_held if n_held else math.nan
    tnr = (n_lost - (len(called) - tp)) / n_lost if n_lost else math.nan
    lo, hi = wilson_interval(tp, len(called)) if called else (math.nan, math.nan)
    return RuleScore(n=len(tested), held=n_held, called=len(called),
                     false_captures=len(called) - tp, missed_captures=n_held - tp,
                     tpr=tpr, tnr=tnr, balanced_accuracy=0.5 * (tpr + tnr),
                     precision=tp / len(called) if called else math.nan,
                     precision_lo=lo, precision_hi=hi)


def auc(scores_held: list[float], scores_lost: list[float]) -> float:
    """The probability that a held capture scores higher than a lost one (ties count a
    half): the area under the ROC curve (Mann-Whitney); NaN without both kinds."""
    if not scores_held or not scores_lost:
        return math.nan
    lost = sorted(scores_lost)
    total = 0.0
    for x in scores_held:
        below = bisect.bisect_left(lost, x)
        ties = bisect.bisect_right(lost, x) - below
        total += below + 0.5 * ties
    return total / (len(scores_held) * len(lost))


def fit_rule(samples) -> Rule:
    """The rule of the source's form with the highest balanced accuracy on ``samples``
    (ties: the one that calls fewer captures, then the lower bounds): CQI bounds at the
    tested samples' settled CQIs (a bound between two of them calls the same ones), pair
    bounds :data:`PAIR_BOUNDS`."""
    tested = _tested(samples)
    n_held = sum(1 for s in tested if s.tug["held"])
    n_lost = len(tested) - n_held
    if not n_held or not n_lost:
        return SOURCE_RULE
    best, best_key = SOURCE_RULE, None
    for p in PAIR_BOUNDS:
        eligible = sorted((s.settled_cqi, bool(s.tug["held"])) for s in tested
                          if s.locked_pairs >= p)
        tp = called = 0
        for k, (c, held) in enumerate(eligible):
            called += 1
            tp += held
            if k + 1 < len(eligible) and eligible[k + 1][0] == c:
                continue                         # the bound takes every sample at c
            ba = 0.5 * (tp / n_held + (n_lost - (called - tp)) / n_lost)
            key = (ba, -called, -p, -c)
            if best_key is None or key > best_key:
                best, best_key = Rule(float(c), p), key
    return best


@dataclass
class Separation:
    """One target: the tested samples, held, the AUCs of the settled CQI (lower = held)
    and of the locked pairs (more = held) over all of them; the source's rule on the
    check set; the rule fitted on the selection set and its score on the check set."""

    label: str
    n: int
    held: int
    auc_cqi: float
    auc_pairs: float
    source_selection: RuleScore
    source_check: RuleScore
    fitted: Rule
    fitted_selection: RuleScore
    fitted_check: RuleScore

    def to_dict(self) -> dict:
        return asdict(self)


def _aucs(samples) -> tuple[float, float]:
    """(AUC of the settled CQI, AUC of the locked pairs) of held against lost among the
    tested ``samples``: a lower CQI, or more pairs, counts as ranking higher."""
    tested = _tested(samples)
    held = [s for s in tested if s.tug["held"]]
    lost = [s for s in tested if not s.tug["held"]]
    return (auc([-s.settled_cqi for s in held], [-s.settled_cqi for s in lost]),
            auc([float(s.locked_pairs) for s in held], [float(s.locked_pairs) for s in lost]))


def separation(label: str, samples, is_selection) -> Separation:
    """``samples``: SampleResults with the tug's verdict; ``is_selection(sample)`` puts a
    sample in the selection set (the rest is the check set)."""
    tested = _tested(samples)
    sel = [s for s in tested if is_selection(s)]
    chk = [s for s in tested if not is_selection(s)]
    fitted = fit_rule(sel)
    auc_cqi, auc_pairs = _aucs(tested)
    return Separation(
        label=label, n=len(tested), held=sum(1 for s in tested if s.tug["held"]),
        auc_cqi=auc_cqi, auc_pairs=auc_pairs,
        source_selection=score(SOURCE_RULE, sel), source_check=score(SOURCE_RULE, chk),
        fitted=fitted, fitted_selection=score(fitted, sel), fitted_check=score(fitted, chk))


def _pct(x: float) -> str:
    return "n/a" if x != x else f"{100 * x:.1f}"


def _f3(x: float) -> str:
    return "n/a" if x != x else f"{x:.3f}"


def separation_table(rows: list[Separation]) -> str:
    """The markdown table of the targets."""
    def rs(sc: RuleScore) -> str:
        return (f"{_pct(sc.balanced_accuracy)} ({sc.false_captures} false, "
                f"{sc.missed_captures} missed of {sc.n}; {_pct(sc.precision)} "
                f"[{_pct(sc.precision_lo)}, {_pct(sc.precision_hi)}] hold)")

    lines = ["| target | tested | held | AUC of CQI | AUC of pairs | source's rule on the check "
             "set: balanced accuracy % | fitted on the selection set | fitted, on the check set |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r.label} | {r.n} | {r.held} | {_f3(r.auc_cqi)} | {_f3(r.auc_pairs)} | "
                     f"{rs(r.source_check)} | {r.fitted.text()} | {rs(r.fitted_check)} |")
    return "\n".join(lines)


def within_cells_table(cells: dict) -> str:
    """The markdown table of the ranking power inside each cell (label -> samples: one
    design and attitude), over the source's successes only: does a lower settled CQI, or
    more locked pairs, go with a capture that holds?  (AUC 0.5: no better than chance;
    below 0.5: the other way round.)"""
    lines = ["| cell | successes | held | AUC of CQI | AUC of pairs | median CQI, held / lost |",
             "|---|---|---|---|---|---|"]
    for label, samples in cells.items():
        ok = [s for s in _tested(samples) if s.success]
        held = [s for s in ok if s.tug["held"]]
        lost = [s for s in ok if not s.tug["held"]]
        auc_cqi, auc_pairs = _aucs(ok)
        lines.append(f"| {label} | {len(ok)} | {len(held)} | {_f3(auc_cqi)} | {_f3(auc_pairs)} | "
                     f"{_f3(median([s.settled_cqi for s in held]))} / "
                     f"{_f3(median([s.settled_cqi for s in lost]))} |")
    return "\n".join(lines)
