"""The tumbling study's report: P*_s (with its Wilson interval) and mean T of each design
against the tumble rate about each axis, under the threshold and the adaptive policy; the
rate at which each design falls below 90 %; what the adaptive policy buys over the
threshold, and what each tumble changes against the target at rest, on the same samples;
and the figure.

The cells are ``studies.cells.tumbling_cells``: 'rest <policy>' and '<axis> <rate>
<policy>'.  A cell without results yet (a study still running) is shown as '-'; rates
and axes that no design has results for (a study run on some cells, ``--cells``) are left
out of the tables and the figure.
"""
from __future__ import annotations

import math
from pathlib import Path

from ..montecarlo.attitude import (ATTITUDE_BINS, attitude_counts, attitude_heads,
                                   closing_attitude_counts)
from .cells import CLOSING_POLICIES, TUMBLE_AXES, TUMBLE_RATES
from .paired import paired_cells
from .report import error_bars

POLICIES = CLOSING_POLICIES
#: the reliability below which a design is said to fail under a tumble
FLOOR = 0.90


def _label(axis: str | None, rate: float, policy: str) -> str:
    return f"rest {policy}" if axis is None or rate == 0 else f"{axis} {rate:g} {policy}"


def _cell(stats: dict, axis, rate, policy, design):
    return stats.get((_label(axis, rate, policy), design))


def _fmt(c) -> str:
    if c is None or not c.n:
        return "-"
    return f"{100 * c.p:.1f} [{100 * c.lo:.1f}, {100 * c.hi:.1f}]"


def _t(c) -> str:
    return "-" if c is None or not c.n or not math.isfinite(c.mean_t) else f"{c.mean_t:.2f}"


def _measured(stats: dict, axis, rate) -> bool:
    """Whether any design has results at (axis, rate) under either policy."""
    return any(n.n for (label, _d), n in stats.items()
               if label in (_label(axis, rate, p) for p in POLICIES))


def measured_rates(stats: dict, axis: str) -> list[float]:
    """0 (at rest) and the rates about ``axis`` that any design has results for."""
    return [r for r in (0.0,) + TUMBLE_RATES if _measured(stats, None if r == 0 else axis, r)]


def falls_below(stats: dict, design: str, axis: str, policy: str) -> str:
    """The lowest measured rate (deg/s) at which P*_s < FLOOR, '> R' (R the highest
    measured) if none, '-' when a measured cell of this design is missing before it."""
    rates = measured_rates(stats, axis)
    for rate in rates:
        c = _cell(stats, axis, rate, policy, design)
        if c is None or not c.n:
            return "-"
        if c.p < FLOOR:
            return f"{rate:g}"
    return f"> {rates[-1]:g}" if rates else "-"


def _measured_axes(stats: dict) -> list[str]:
    """The axes with results at some rate (all of them when none has any)."""
    axes = [a for a in TUMBLE_AXES if any(_measured(stats, a, r) for r in TUMBLE_RATES)]
    return axes or list(TUMBLE_AXES)


def tumbling_table(designs: list[str], stats: dict) -> str:
    """Markdown: per design, a row per (axis, rate) with both policies side by side, then
    the rate at which each design falls below 90 %."""
    out = []
    for d in designs:
        out.append(f"### {d}\n")
        out.append("| axis | rate (deg/s) | P*_s threshold % [95 %] | mean T (s) | "
                   "P*_s adaptive % [95 %] | mean T (s) |")
        out.append("|---|---|---|---|---|---|")
        rows = [(None, 0.0)] + [(a, r) for a in TUMBLE_AXES for r in TUMBLE_RATES
                                if _measured(stats, a, r)]
        for axis, rate in rows:
            th = _cell(stats, axis, rate, "threshold", d)
            ad = _cell(stats, axis, rate, "adaptive", d)
            out.append(f"| {axis or 'at rest'} | {rate:g} | {_fmt(th)} | {_t(th)} | {_fmt(ad)} "
                       f"| {_t(ad)} |")
        out.append("")
    axes = _measured_axes(stats)
    out.append(f"Lowest measured rate (deg/s) at which P*_s falls below {100 * FLOOR:.0f} %"
               " (threshold / adaptive):\n")
    out.append("| design | " + " | ".join(axes) + " |")
    out.append("|---|" + "---|" * len(axes))
    for d in designs:
        cells = [f"{falls_below(stats, d, a, 'threshold')} / {falls_below(stats, d, a, 'adaptive')}"
                 for a in axes]
        out.append(f"| {d} | " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def plot_tumbling(designs: list[str], stats: dict, path: Path, title: str) -> None:
    """P*_s (top row, Wilson intervals as bars) and mean T (bottom row) against rate, one
    column per axis, a colour per design, the threshold policy solid and the adaptive
    dashed; one legend beside the panels."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = _measured_axes(stats)
    fig, axes = plt.subplots(2, len(panels), figsize=(4.6 * len(panels) + 2.6, 7.4),
                             sharey="row", sharex="col", squeeze=False)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for col, axis in enumerate(panels):
        top, bottom = axes[0][col], axes[1][col]
        rates = measured_rates(stats, axis)
        for k, d in enumerate(designs):
            for policy, style in zip(POLICIES, ("-", "--")):
                got = [(r, c) for r in rates
                       if (c := _cell(stats, axis, r, policy, d)) is not None and c.n]
                if got:
                    xs = [r for r, _c in got]
                    p, lo, hi = ([getattr(c, f) for _r, c in got] for f in ("p", "lo", "hi"))
                    colour = colours[k % len(colours)]
                    top.errorbar(xs, [100 * v for v in p], yerr=error_bars(p, lo, hi), fmt=style,
                                 marker="o", ms=3, capsize=2, color=colour,
                                 label=f"{Path(d).stem} {policy}")
                    bottom.plot(xs, [c.mean_t for _r, c in got], style, marker="o", ms=3,
                                color=colour)
        top.axhline(100 * FLOOR, color="grey", lw=0.8, ls=":")
        top.axhline(98.0, color="grey", lw=0.8, ls="-.")
        top.set_title(axis)
        for ax in (top, bottom):
            ax.set_xscale("symlog", linthresh=0.5)
            ax.set_xticks(rates)
            ax.set_xticklabels([f"{r:g}" for r in rates])
        bottom.set_xlabel(f"tumble rate about the {axis} axis (deg/s)")
    axes[0][0].set_ylabel("P*_s (%)")
    axes[1][0].set_ylabel("mean T (s)")
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, loc="center right")
    fig.suptitle(title)
    fig.tight_layout(rect=(0, 0, 1 - 2.4 / (4.6 * len(panels) + 2.6), 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)


#: what each attitude table splits by, and its caption
_AT = {
    "launch": ("Successes by the stage's attitude at launch, threshold / adaptive: a_z = |cos| "
               "of the angle between its long axis and the line of sight (0: lying across it, "
               "1: end-on), from each sample's orientation noise and tumble phase."),
    "closing": ("Successes by the stage's attitude at closing, threshold / adaptive: a_z as "
                "above, at the sample's closing time, the stage turned free of torque from "
                "launch (the net's touch before closing not counted; the adaptive policy "
                "chooses that time from the attitude it senses), and the samples whose "
                "closing never started."),
}


def attitude_table(designs: list[str], cells: list, records: dict, design_of: dict,
                   at: str = "launch") -> str:
    """Markdown: for each tumbling cell (axis, rate) whose samples do not all lie across the
    line of sight, each design's successes per bin of |a_z| ``at`` launch or at closing,
    threshold / adaptive (``records``: (cell label, design) -> CellRecord with verdicts in
    sample order, and closing times for ``at="closing"``; a policy without them is '-')."""
    if at not in _AT:
        raise ValueError(f"at={at!r}: must be one of {sorted(_AT)}")
    by_label = {c.label: c for c in cells}
    edges = ATTITUDE_BINS
    heads = attitude_heads() + (["closing never started"] if at == "closing" else [])
    rows = []
    for axis in TUMBLE_AXES:
        for rate in TUMBLE_RATES:
            cell = by_label.get(_label(axis, rate, "threshold"))
            if cell is None:
                continue
            for d in designs:
                counts = {}
                bin_of = {}          # the policies share the cell's attitudes at launch
                for policy in POLICIES:
                    rec = records.get((_label(axis, rate, policy), d))
                    if rec is None or not rec.verdicts:
                        continue
                    if at == "launch":
                        counts[policy] = attitude_counts(
                            design_of[d], cell.config, cell.noise,
                            ((v.seed, v.success) for v in rec.verdicts), bin_of)
                    elif rec.closing_times is not None:
                        counts[policy] = closing_attitude_counts(
                            design_of[d], cell.config, cell.noise,
                            ((v.seed, v.success, t)
                             for v, t in zip(rec.verdicts, rec.closing_times)))
                if not counts or all(sum(n[1:len(edges) - 1]) == 0 for _ok, n in counts.values()):
                    continue
                parts = []
                for k in range(len(heads)):
                    got = [f"{counts[p][0][k]}/{counts[p][1][k]}" if p in counts else "-"
                           for p in POLICIES]
                    parts.append(" / ".join(got))
                rows.append(f"| {axis} | {rate:g} | {d} | " + " | ".join(parts) + " |")
    if not rows:
        return ""
    return (_AT[at] + "  Cells whose samples all lie across the line of sight (a_z < "
            f"{edges[1]:g}) are left out.\n\n"
            "| axis | rate (deg/s) | design | " + " | ".join(heads) + " |\n"
            "|---|---|---|" + "---|" * len(heads) + "\n" + "\n".join(rows) + "\n")


def policy_pairs(designs: list[str], records: dict) -> dict:
    """(axis, rate, design) -> PairedStats of the adaptive cell (b) against the threshold
    cell (a) over the same samples, for each (axis, rate) where both are complete (axis
    None: at rest).  ``records``: (cell label, design) -> CellRecord."""
    out = {}
    for axis, rate in [(None, 0.0)] + [(a, r) for a in TUMBLE_AXES for r in TUMBLE_RATES]:
        for d in designs:
            got = paired_cells(records.get((_label(axis, rate, "threshold"), d)),
                          records.get((_label(axis, rate, "adaptive"), d)))
            if got is not None:
                out[(axis, rate, d)] = got
    return out


def rest_pairs(designs: list[str], records: dict) -> dict:
    """(axis, rate, policy, design) -> PairedStats of the tumbling cell (b) against the
    target at rest (a) under the same policy, over the same samples, for each cell where
    both are complete.  ``records``: (cell label, design) -> CellRecord."""
    out = {}
    for axis in TUMBLE_AXES:
        for rate in TUMBLE_RATES:
            for policy in POLICIES:
                for d in designs:
                    got = paired_cells(records.get((_label(None, 0.0, policy), d)),
                                  records.get((_label(axis, rate, policy), d)))
                    if got is not None:
                        out[(axis, rate, policy, d)] = got
    return out


def rest_table(pairs: dict) -> str:
    """Markdown: what each tumble changes against the target at rest, over the same
    samples, threshold / adaptive: the change of P*_s (points), the samples captured only
    under the tumble / only at rest, and McNemar's exact p on them.  A design whose
    verdicts a slow spin re-draws (many samples on both sides, P*_s unchanged) is one
    whose outcome the sample does not settle."""
    if not pairs:
        return ""
    rows = []
    for axis in TUMBLE_AXES:
        for rate in TUMBLE_RATES:
            for d in dict.fromkeys(k[3] for k in pairs):
                got = {pol: pairs.get((axis, rate, pol, d)) for pol in POLICIES}
                if not any(got.values()):
                    continue
                cols = []
                for fmt in (lambda q: f"{100 * q.p_diff:+.1f}",
                            lambda q: f"{q.b_only}/{q.a_only}",
                            lambda q: f"{q.mcnemar_p:.2g}"):
                    cols.append(" / ".join("-" if got[pol] is None else fmt(got[pol])
                                           for pol in POLICIES))
                rows.append(f"| {axis} | {rate:g} | {d} | " + " | ".join(cols) + " |")
    return ("What each tumble changes against the target at rest, on the same samples and "
            "under the same policy (threshold / adaptive): the change of P*_s, the samples "
            "captured only under the tumble / only at rest, and McNemar's exact two-sided p "
            "on those.\n\n"
            "| axis | rate (deg/s) | design | P*_s change (points) | captured only spun / "
            "only at rest | McNemar p |\n|---|---|---|---|---|---|\n" + "\n".join(rows) + "\n")


def policy_table(pairs: dict) -> str:
    """Markdown: what the adaptive policy buys over the threshold policy in each cell,
    over the same samples: the difference of P*_s (points), the samples only one policy
    captures (adaptive only / threshold only) with McNemar's exact p on them, and the
    difference of mean T (s)."""
    if not pairs:
        return ""
    rows = []
    for (axis, rate, d), p in pairs.items():
        dt = p.t_diff
        rows.append(f"| {axis or 'at rest'} | {rate:g} | {d} | {100 * p.p_diff:+.1f} | "
                    f"{p.b_only} / {p.a_only} | {p.mcnemar_p:.2g} | "
                    + ("-" if not math.isfinite(dt) else f"{dt:+.2f}") + " |")
    return ("What the adaptive policy buys over the threshold policy on the same samples: "
            "the change of P*_s, the samples only one of them captures (McNemar's exact "
            "two-sided p on those), and the change of mean T.\n\n"
            "| axis | rate (deg/s) | design | P*_s change (points) | captured by adaptive "
            "only / threshold only | McNemar p | mean T change (s) |\n"
            "|---|---|---|---|---|---|---|\n" + "\n".join(rows) + "\n")
