"""A study's results as a Markdown table and a figure (one bar per cell per design)."""
from __future__ import annotations

import math
from pathlib import Path

from ..core.design import PUBLISHED_OUTCOMES
from .paired import CellStats, PairedStats


def write_report(out: str | Path, rows: list, table: str) -> None:
    """A report's two files: ``<out>.json`` (each row's ``to_dict()``) and
    ``<out>-table.md`` (the markdown table); ``out`` without a suffix."""
    import json

    Path(out).with_suffix(".json").write_text(
        json.dumps([r.to_dict() for r in rows], indent=1, default=str) + "\n")
    Path(f"{out}-table.md").write_text(table + "\n")


def _pct(p: float) -> str:
    return "-" if p is None or not math.isfinite(p) else f"{100 * p:.1f}"


def cell_text(c: CellStats) -> str:
    return f"{_pct(c.p)} [{_pct(c.lo)}, {_pct(c.hi)}] · {c.mean_t:.1f} s"


def study_table(designs: list[str], cells: list, stats: dict, paired: dict) -> str:
    """Markdown: a row per cell, a column per design with P*_s % [Wilson 95 %] · mean T and,
    for every cell but the first, the change against the first and its flipped verdicts."""
    head = "| cell | " + " | ".join(designs) + " |"
    lines = [head, "|" + "---|" * (len(designs) + 1)]
    src = []
    for d in designs:
        po = PUBLISHED_OUTCOMES.get(d)
        src.append("-" if po is None else f"{_pct(po.p_success_validated)} · {po.mean_completion_time:.1f} s")
    lines.append("| source (Table 4, N = 1000) | " + " | ".join(src) + " |")
    for k, cell in enumerate(cells):
        row = []
        for d in designs:
            c = stats.get((cell.label, d))
            if c is None:
                row.append("-")
                continue
            txt = cell_text(c)
            if k > 0 and (cell.label, d) in paired:
                ps: PairedStats = paired[(cell.label, d)]
                mark = "within" if ps.within_half_width else "outside"
                txt += (f"<br>{100 * ps.p_diff:+.1f} pts ({mark} ±{100 * min(ps.a.half_width, ps.b.half_width):.1f}), "
                        f"{ps.flips} flips ({100 * ps.flip_share:.1f} %), T {100 * ps.t_rel_diff:+.1f} %")
            row.append(txt)
        lines.append(f"| {cell.label} | " + " | ".join(row) + " |")
    return "\n".join(lines)


def comparison_table(designs: list[str], paired: dict, label_b: str) -> str:
    """Markdown for a two-cell study (convergence, agreement): per design both P*_s with
    their intervals, the difference against the smaller half-width, the flipped verdicts
    (McNemar's exact p) and both mean T; a design whose cells are not both finished yet
    (a study under way) is left out."""
    lines = ["| design | N | P*_s a % [95 %] | P*_s b % [95 %] | b - a (pts) | smaller half-width (pts) "
             "| within | flips (share) | McNemar p | mean T a (s) | mean T b (s) | T b / a - 1 |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for d in designs:
        ps: PairedStats | None = paired.get((label_b, d))
        if ps is None:
            continue
        a, b = ps.a, ps.b
        lines.append(
            f"| {d} | {a.n} | {_pct(a.p)} [{_pct(a.lo)}, {_pct(a.hi)}] | {_pct(b.p)} [{_pct(b.lo)}, "
            f"{_pct(b.hi)}] | {100 * ps.p_diff:+.1f} | {100 * min(a.half_width, b.half_width):.1f} | "
            f"{'yes' if ps.within_half_width else 'no'} | {ps.flips} ({100 * ps.flip_share:.1f} %) | "
            f"{ps.mcnemar_p:.2g} | {a.mean_t:.2f} | {b.mean_t:.2f} | {100 * ps.t_rel_diff:+.2f} % |")
    return "\n".join(lines)


def error_bars(p, lo, hi):
    """(below, above) error bars in percent of P*_s with its interval [lo, hi], arrays or
    numbers: never negative (``core.metrics.wilson_interval`` may leave a bound on the
    wrong side of p by round-off at 0 or n successes, which matplotlib refuses)."""
    import numpy as np

    p, lo, hi = (np.asarray(v, dtype=float) for v in (p, lo, hi))
    return np.maximum(0.0, 100 * (p - lo)), np.maximum(0.0, 100 * (hi - p))


def plot_study(designs: list[str], cells: list, stats: dict, path: str | Path, title: str = "") -> Path:
    """Two panels: P*_s with Wilson 95 % error bars and mean T, one bar per cell per
    design; the source's published values as dashed lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    n_c = len(cells)
    width = 0.8 / n_c
    fig, axes = plt.subplots(2, 1, figsize=(max(8, 1.6 * len(designs) + 0.35 * n_c * len(designs)), 8),
                             sharex=True)
    cmap = plt.get_cmap("tab20")
    x = np.arange(len(designs))
    for k, cell in enumerate(cells):
        got = [stats.get((cell.label, d)) for d in designs]   # None: no samples yet
        p = np.array([c.p if c else np.nan for c in got])
        lo = np.array([c.lo if c else np.nan for c in got])
        hi = np.array([c.hi if c else np.nan for c in got])
        t = np.array([c.mean_t if c else np.nan for c in got])
        xs = x - 0.4 + width * (k + 0.5)
        axes[0].bar(xs, 100 * p, width, yerr=error_bars(p, lo, hi), capsize=2,
                    color=cmap(k % 20), label=cell.label)
        axes[1].bar(xs, t, width, color=cmap(k % 20))
    for j, d in enumerate(designs):
        po = PUBLISHED_OUTCOMES.get(d)
        if po is not None:
            axes[0].hlines(100 * po.p_success_validated, j - 0.45, j + 0.45, colors="k", linestyles="--")
            axes[1].hlines(po.mean_completion_time, j - 0.45, j + 0.45, colors="k", linestyles="--")
    axes[0].set_ylabel("P*_s (%), Wilson 95 %")
    axes[0].set_ylim(0, 105)
    axes[1].set_ylabel("mean T (s)")
    axes[1].set_xticks(x, designs)
    axes[0].legend(fontsize=7, ncol=1, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    axes[0].set_title(title + "  (dashed: the source's published values)")
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
