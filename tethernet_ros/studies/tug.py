"""The source's verdict against the tug test's (issue 36, point 2; docs/model.md §17): over
one cell's samples, how often the settled CQI and locked pairs call a capture a success
that the tug finds lost (a false capture), and the reverse (a missed capture)."""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import asdict, dataclass

from ..core.episode import source_verdict
from ..core.metrics import criterion_of, wilson_interval

__all__ = ["Confusion", "confusion", "confusion_table", "criterion_text", "holding_shares",
           "share", "tested_successes"]


@dataclass
class Confusion:
    """One cell: n samples; by the source's criterion (``success``) against the tug's
    (``tug.held``): both success (``agree_held``), false captures (success, lost), missed
    captures (failure, held), both failures (``agree_lost``) and samples without a test
    (closing never triggered or the episode diverged before it); the share of the source's
    successes that hold with its Wilson 95 % interval; the tug's reasons for losing a
    success; mean and largest peak tether tension (N), the samples whose peak tension
    exceeded the tether's breaking load (``breaking``, N: the tether itself would have
    broken) and the median share slid off of held and of lost captures."""

    label: str
    n: int
    source_success: int
    held: int
    agree_held: int
    false_captures: int
    missed_captures: int
    agree_lost: int
    untested: int
    hold_share: float
    hold_lo: float
    hold_hi: float
    false_reasons: dict
    mean_peak_tension: float
    max_peak_tension: float
    over_breaking: int
    slid_median_held: float
    slid_median_lost: float

    def to_dict(self) -> dict:
        return asdict(self)


def median(xs) -> float:
    xs = sorted(xs)
    if not xs:
        return math.nan
    m = len(xs) // 2
    return xs[m] if len(xs) % 2 else 0.5 * (xs[m - 1] + xs[m])


def confusion(label: str, samples, breaking: float = math.inf) -> Confusion:
    """The confusion of one cell's samples (``SampleResult`` with ``tug``); ``breaking``:
    the tether's breaking load (N).  A sample judged by criterion 'held' is counted by its
    source verdict (``episode.source_verdict``)."""
    def source(s):
        return source_verdict(s)[0]
    tested = [s for s in samples if s.tug]
    ok = [s for s in tested if source(s)]
    held_ok = [s for s in ok if s.tug["held"]]
    lost_ok = [s for s in ok if not s.tug["held"]]
    fail = [s for s in tested if not source(s)]
    held_fail = [s for s in fail if s.tug["held"]]
    lo, hi = wilson_interval(len(held_ok), len(ok)) if ok else (math.nan, math.nan)
    peaks = [s.tug["peak_tension"] for s in tested if s.tug["peak_tension"] is not None]
    reasons = Counter(s.tug["reason"].split(":")[0] for s in lost_ok)
    return Confusion(
        label=label, n=len(samples), source_success=sum(1 for s in samples if source(s)),
        held=sum(1 for s in tested if s.tug["held"]), agree_held=len(held_ok),
        false_captures=len(lost_ok), missed_captures=len(held_fail),
        agree_lost=len(fail) - len(held_fail), untested=len(samples) - len(tested),
        hold_share=len(held_ok) / len(ok) if ok else math.nan, hold_lo=lo, hold_hi=hi,
        false_reasons=dict(reasons),
        mean_peak_tension=sum(peaks) / len(peaks) if peaks else math.nan,
        max_peak_tension=max(peaks) if peaks else math.nan,
        over_breaking=sum(1 for t in peaks if t > breaking),
        slid_median_held=median([s.tug["slid_share"] for s in tested if s.tug["held"]]),
        slid_median_lost=median([s.tug["slid_share"] for s in tested if not s.tug["held"]]))


def confusion_table(rows: list[Confusion]) -> str:
    """The markdown table of the cells."""
    def pct(x):
        return "n/a" if x != x else f"{100 * x:.1f}"
    lines = ["| cell | N | source success | tug held | both held | false captures | missed "
             "captures | both lost | not tested | successes that hold % [95 %] | peak tension "
             "mean / max (kN) | above breaking load | slid off, median held / lost |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in rows:
        lines.append(
            f"| {c.label} | {c.n} | {c.source_success} | {c.held} | {c.agree_held} | "
            f"**{c.false_captures}** | {c.missed_captures} | {c.agree_lost} | {c.untested} | "
            f"{pct(c.hold_share)} [{pct(c.hold_lo)}, {pct(c.hold_hi)}] | "
            f"{c.mean_peak_tension / 1e3:.1f} / {c.max_peak_tension / 1e3:.1f} | "
            f"{c.over_breaking} | {pct(c.slid_median_held)} / {pct(c.slid_median_lost)} % |")
    return "\n".join(lines)


def tested_successes(samples) -> list:
    """The samples the source's criterion calls a success and the tug tested (those a
    share held is taken over)."""
    return [s for s in samples if s.tug and source_verdict(s)[0]]


def share(k: int, n: int) -> dict:
    """k of n as a share with its Wilson 95 % interval (NaN when n is 0)."""
    lo, hi = wilson_interval(k, n) if n else (math.nan, math.nan)
    return {"k": k, "n": n, "share": k / n if n else math.nan, "lo": lo, "hi": hi}


def holding_shares(tugs) -> list[dict]:
    """The share of tug verdicts (dicts, ``tug.TugOutcome.to_dict``) that hold each pull of
    their ladders, the required pull first: a capture holds a pull when its holding force
    is at least it (docs/model.md §17)."""
    tugs = list(tugs)
    pulls = set()
    for t in tugs:
        pulls.add(t["peak_force"])
        pulls.update(lv["force"] for lv in t.get("ladder") or [])
    return [{"pull": f, **share(sum(1 for t in tugs
                                    if t.get("holding_force", 0.0) >= f * (1 - 1e-12)),
                                len(tugs))}
            for f in sorted(pulls)]


def criterion_text(label: str, samples) -> str:
    """One run's samples under criterion 'held' in a few lines: P*_s by the source's
    criterion and by 'held' (Wilson 95 %), and the share of the source's successes that
    hold each pull of the ladder; '' for a run judged by the source's criterion."""
    samples = list(samples)
    if not samples or all(criterion_of(s) == "source" for s in samples):
        return ""
    n = len(samples)
    src = share(sum(1 for s in samples if source_verdict(s)[0]), n)
    held = share(sum(1 for s in samples if s.success), n)
    tugs = [s.tug for s in tested_successes(samples)]

    def pct(d):
        return f"{100 * d['share']:.1f} % [{100 * d['lo']:.1f}, {100 * d['hi']:.1f}]"
    lines = [f"{label}: P*_s by criterion held {held['k']}/{n} = {pct(held)}; by the source's "
             f"criterion {src['k']}/{n} = {pct(src)}"]
    if tugs:
        lines.append("  the source's successes that hold each pull: " + ", ".join(
            f"{r['pull']:g} N {r['k']}/{r['n']} ({pct(r)})" for r in holding_shares(tugs)))
    return "\n".join(lines)
