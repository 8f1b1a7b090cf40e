"""The tumbling study's report: P*_s (with its Wilson interval) and mean T of each design
against the tumble rate about each axis, under the threshold and the adaptive policy; the
rate at which each design falls below 90 %; and the figure.

The cells are ``studies.cells.tumbling_cells``: 'rest <policy>' and '<axis> <rate>
<policy>'.  A cell without results yet (a study still running) is shown as '-'.
"""
from __future__ import annotations

import math
from pathlib import Path

from .cells import TUMBLE_AXES, TUMBLE_RATES

POLICIES = ("threshold", "adaptive")
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


def falls_below(stats: dict, design: str, axis: str, policy: str) -> str:
    """The lowest rate (deg/s) of the grid at which P*_s < FLOOR, '> 8' if none, '-' when
    a cell is missing before it."""
    for rate in (0.0,) + TUMBLE_RATES:
        c = _cell(stats, axis, rate, policy, design)
        if c is None or not c.n:
            return "-"
        if c.p < FLOOR:
            return f"{rate:g}"
    return f"> {TUMBLE_RATES[-1]:g}"


def tumbling_table(designs: list[str], stats: dict) -> str:
    """Markdown: per design, a row per (axis, rate) with both policies side by side, then
    the rate at which each design falls below 90 %."""
    out = []
    for d in designs:
        out.append(f"### {d}\n")
        out.append("| axis | rate (deg/s) | P*_s threshold % [95 %] | mean T (s) | "
                   "P*_s adaptive % [95 %] | mean T (s) |")
        out.append("|---|---|---|---|---|---|")
        rows = [(None, 0.0)] + [(a, r) for a in TUMBLE_AXES for r in TUMBLE_RATES]
        for axis, rate in rows:
            th = _cell(stats, axis, rate, "threshold", d)
            ad = _cell(stats, axis, rate, "adaptive", d)
            out.append(f"| {axis or 'at rest'} | {rate:g} | {_fmt(th)} | {_t(th)} | {_fmt(ad)} "
                       f"| {_t(ad)} |")
        out.append("")
    out.append(f"Lowest rate of the grid (deg/s) at which P*_s falls below {100 * FLOOR:.0f} %"
               " (threshold / adaptive):\n")
    out.append("| design | " + " | ".join(TUMBLE_AXES) + " |")
    out.append("|---|" + "---|" * len(TUMBLE_AXES))
    for d in designs:
        cells = [f"{falls_below(stats, d, a, 'threshold')} / {falls_below(stats, d, a, 'adaptive')}"
                 for a in TUMBLE_AXES]
        out.append(f"| {d} | " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def plot_tumbling(designs: list[str], stats: dict, path: Path, title: str) -> None:
    """P*_s against rate, one panel per axis, a colour per design, the threshold policy
    solid and the adaptive dashed, with Wilson intervals as bars."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(TUMBLE_AXES), figsize=(5 * len(TUMBLE_AXES), 4.2),
                             sharey=True)
    rates = (0.0,) + TUMBLE_RATES
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, axis in zip(axes, TUMBLE_AXES):
        for k, d in enumerate(designs):
            for policy, style in zip(POLICIES, ("-", "--")):
                xs, ys, lo, hi = [], [], [], []
                for r in rates:
                    c = _cell(stats, axis, r, policy, d)
                    if c is None or not c.n:
                        continue
                    xs.append(r)
                    ys.append(100 * c.p)
                    lo.append(100 * (c.p - c.lo))
                    hi.append(100 * (c.hi - c.p))
                if xs:
                    ax.errorbar(xs, ys, yerr=[lo, hi], fmt=style, marker="o", ms=3, capsize=2,
                                color=colours[k % len(colours)],
                                label=f"{Path(d).stem} {policy}")
        ax.axhline(100 * FLOOR, color="grey", lw=0.8, ls=":")
        ax.axhline(98.0, color="grey", lw=0.8, ls="-.")
        ax.set_xscale("symlog", linthresh=0.5)
        ax.set_xticks(rates)
        ax.set_xticklabels([f"{r:g}" for r in rates])
        ax.set_xlabel(f"tumble rate about the {axis} axis (deg/s)")
        ax.set_title(axis)
    axes[0].set_ylabel("P*_s (%)")
    axes[-1].legend(fontsize=6, loc="lower left")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
