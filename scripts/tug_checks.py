"""The tug test's own checks (issue 53, point 1; docs/studies/tug-checks.md): the held
verdict at the required pull over settings of the step, the method and the protocol,
each cell against its design's reference cell on the same samples (common random
numbers: the same seeds), and the holding force's share held at each pull.

Each results file ``<dir>/<design>__<setting>.jsonl`` is one cell (written by ``tethernet
validate --criterion held ...``); ``<design>__ref.jsonl`` is the design's reference cell
(the default implicit 1 ms step and protocol).  Per cell: the source's successes that the
tug tested, the share held with its Wilson 95 % interval, the flips against the
reference on the samples both tested (held there and lost here, and the reverse), the
paired difference of the shares with its 95 % interval, and the peak tether tension.  The
reference cells are also judged again at other thresholds of the share slid off (the
verdict's one threshold, recomputed from the records: the measures are recorded), and
their holding forces give the share held at each pull of the ladder.

    .venv/bin/python scripts/tug_checks.py DIR --out docs/studies/tug-checks
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from tethernet_ros.studies.files import samples_by_seed
from tethernet_ros.studies.tug import holding_shares, share, tested_successes

#: thresholds of the share slid off at which the reference cells are judged again
SLID_THRESHOLDS = (0.3, 0.4, 0.5, 0.6, 0.7)
#: the reasons the verdict checks before the share slid off (a capture lost by one of
#: them is lost whatever the threshold)
SLID_REASON = "the net slid off"


def tested(samples: dict) -> dict:
    """seed -> tug verdict of the samples the source called a success and the tug tested."""
    return {s.seed: s.tug for s in tested_successes(samples.values())}


def paired(ref: dict, other: dict) -> dict:
    """Flips between two cells on the samples both tested: held in ``ref`` and lost in
    ``other`` (b), the reverse (c); the paired difference of the held shares (other minus
    ref) with its 95 % interval (normal, Newcombe-free: (c - b) / n, its standard error
    sqrt(b + c - (c - b)^2 / n) / n)."""
    both = sorted(set(ref) & set(other))
    b = sum(1 for s in both if ref[s]["held"] and not other[s]["held"])
    c = sum(1 for s in both if not ref[s]["held"] and other[s]["held"])
    n = len(both)
    diff = (c - b) / n if n else math.nan
    se = math.sqrt(max(b + c - (c - b) ** 2 / n, 0.0)) / n if n else math.nan
    return {"both": n, "held_to_lost": b, "lost_to_held": c, "diff": diff,
            "diff_lo": diff - 1.96 * se, "diff_hi": diff + 1.96 * se}


def rejudged(tugs: dict, threshold: float) -> int:
    """How many verdicts hold at another threshold of the share slid off."""
    n = 0
    for t in tugs.values():
        reason = t["reason"] or ""
        if reason and not reason.startswith(SLID_REASON):
            continue                     # lost before the share slid off was looked at
        n += t["slid_share"] <= threshold
    return n


def peak_stats(tugs: dict) -> dict:
    peaks = sorted(t["peak_tension"] for t in tugs.values() if t["peak_tension"] is not None)
    if not peaks:
        return {"mean": math.nan, "median": math.nan, "max": math.nan}
    m = len(peaks) // 2
    med = peaks[m] if len(peaks) % 2 else 0.5 * (peaks[m - 1] + peaks[m])
    return {"mean": sum(peaks) / len(peaks), "median": med, "max": peaks[-1]}


def cells(directory: Path) -> dict:
    out = {}
    for path in sorted(directory.glob("*__*.jsonl")):
        design, setting = path.stem.split("__", 1)
        samples = samples_by_seed(path)
        cpu = [s.cpu_time for s in samples.values()]
        out[(design, setting)] = {"n": len(samples), "tugs": tested(samples),
                                  "cpu": sum(cpu) / len(cpu) if cpu else math.nan}
    return out


def report(directory: Path) -> tuple[str, dict]:
    found = cells(directory)
    rows, data = [], {"cells": [], "slid": [], "holding": []}
    lines = ["| design | setting | N | tested | held | held % [95 %] | flips held->lost / "
             "lost->held (of both) | paired diff % [95 %] | peak tension mean / median / max "
             "(kN) | CPU-s per episode |", "|---|---|---|---|---|---|---|---|---|---|"]
    for (design, setting), cell in sorted(found.items(), key=lambda kv: (kv[0][0],
                                                                          kv[0][1] != "ref",
                                                                          kv[0][1])):
        tugs = cell["tugs"]
        held = sum(1 for t in tugs.values() if t["held"])
        sh = share(held, len(tugs))
        ref = found.get((design, "ref"))
        pair = paired(ref["tugs"], tugs) if ref and setting != "ref" else None
        peaks = peak_stats(tugs)
        flips = ("" if pair is None else
                 f"{pair['held_to_lost']} / {pair['lost_to_held']} (of {pair['both']})")
        diff = ("" if pair is None else
                f"{100 * pair['diff']:+.1f} [{100 * pair['diff_lo']:+.1f}, "
                f"{100 * pair['diff_hi']:+.1f}]")
        lines.append(f"| {design} | {setting} | {cell['n']} | {len(tugs)} | {held} | "
                     f"{100 * sh['share']:.1f} [{100 * sh['lo']:.1f}, {100 * sh['hi']:.1f}] | "
                     f"{flips} | {diff} | {peaks['mean'] / 1e3:.2f} / {peaks['median'] / 1e3:.2f} "
                     f"/ {peaks['max'] / 1e3:.2f} | {cell['cpu']:.2f} |")
        data["cells"].append({"design": design, "setting": setting, "n": cell["n"],
                              "held": sh, "paired": pair, "peak_tension": peaks,
                              "cpu_per_episode": cell["cpu"]})
        rows.append((design, setting))
    lines += ["", "The reference cells judged again at other thresholds of the share slid off "
              "(the default 0.5):", "",
              "| design | " + " | ".join(f"{t:g}" for t in SLID_THRESHOLDS) + " |",
              "|---|" + "---|" * len(SLID_THRESHOLDS)]
    for (design, setting), cell in sorted(found.items()):
        if setting != "ref":
            continue
        tugs = cell["tugs"]
        got = [share(rejudged(tugs, t), len(tugs)) for t in SLID_THRESHOLDS]
        lines.append(f"| {design} | " + " | ".join(
            f"{g['k']}/{g['n']} ({100 * g['share']:.1f} %)" for g in got) + " |")
        data["slid"].append({"design": design, "thresholds": list(SLID_THRESHOLDS),
                             "held": got})
        data["holding"].append({"design": design, "shares": holding_shares(tugs.values())})
    lines += ["", "Share of the tested captures that hold each pull (the ladder of the "
              "reference cells; Wilson 95 %):", "", "| design | pull (N) | held % [95 %] |",
              "|---|---|---|"]
    for h in data["holding"]:
        for r in h["shares"]:
            lines.append(f"| {h['design']} | {r['pull']:g} | {100 * r['share']:.1f} "
                         f"[{100 * r['lo']:.1f}, {100 * r['hi']:.1f}] ({r['k']}/{r['n']}) |")
    return "\n".join(lines), data


def plot(data: dict, png: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for h in data["holding"]:
        xs = [r["pull"] for r in h["shares"]]
        ys = [100 * r["share"] for r in h["shares"]]
        err = [[max(0.0, 100 * (r["share"] - r["lo"])) for r in h["shares"]],
               [max(0.0, 100 * (r["hi"] - r["share"])) for r in h["shares"]]]
        ax.errorbar(xs, ys, yerr=err, marker="o", capsize=3, label=h["design"])
    ax.set_xscale("log")
    ax.set_xlabel("pull (N)")
    ax.set_ylabel("tested captures that hold it (%)")
    ax.set_ylim(0, 102)
    ax.set_title("Holding force: share held at each pull (Wilson 95 %)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("dir")
    p.add_argument("--out", default=None, metavar="PATH (no suffix)",
                   help="write PATH.md (the tables), PATH.json and PATH.png (the holding force)")
    args = p.parse_args(argv)
    table, data = report(Path(args.dir))
    print(table)
    if args.out:
        out = Path(args.out)
        out.with_suffix(".md").write_text(table + "\n")
        out.with_suffix(".json").write_text(json.dumps(data, indent=1, default=str) + "\n")
        if data["holding"]:
            plot(data, out.with_suffix(".png"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
