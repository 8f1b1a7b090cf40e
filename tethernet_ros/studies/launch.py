"""The launch study's report: for each design, spin and closing policy, P*_s and mean T
with the immediate launch beside the predictive one, the predictive launch's mean wait, and
the paired change (flips each way, McNemar's exact p) over the same samples.

The cells are ``studies.cells.launch_cells``: '<axis> <rate> <closing> <launch>'.  A cell
without results yet is shown as '-'.
"""
from __future__ import annotations

import math

from .cells import LAUNCHES
from .paired import paired_cells


def _parts(label: str):
    """(axis, rate (str), closing, launch) of a cell label."""
    axis, rate, closing, launch = label.split(" ")
    return axis, rate, closing, launch


def _split(label: str):
    """(spin, closing, launch) of a cell label, spin being '<axis> <rate>'."""
    axis, rate, closing, launch = _parts(label)
    return f"{axis} {rate}", closing, launch


def _row_order(cell):
    """Rows by axis (in the study's order), rate, then closing policy as the cells have
    them."""
    axis, rate, closing, _launch = _parts(cell.label)
    return (axis != "flat", float(rate), closing != "threshold")


def _p(c) -> str:
    if c is None or not c.stats.n:
        return "-"
    s = c.stats
    return f"{100 * s.p:.1f} [{100 * s.lo:.1f}, {100 * s.hi:.1f}]"


def _num(x, fmt="{:.2f}") -> str:
    return "-" if x is None or not math.isfinite(x) else fmt.format(x)


def launch_pairs(designs: list[str], cells: list, records: dict) -> dict:
    """(spin, closing, design) -> PairedStats of the predictive launch (b) against the
    immediate one (a) over the same samples, where both cells are complete."""
    out = {}
    for c in cells:
        spin, closing, launch = _split(c.label)
        if launch != LAUNCHES[0]:
            continue
        for d in designs:
            got = paired_cells(records.get((c.label, d)),
                          records.get((f"{spin} {closing} {LAUNCHES[1]}", d)))
            if got is not None:
                out[(spin, closing, d)] = got
    return out


def launch_table(designs: list[str], cells: list, records: dict) -> str:
    """Markdown: per design, a row per (spin, closing policy)."""
    pairs = launch_pairs(designs, cells, records)
    out = []
    for d in designs:
        out.append(f"### {d}\n")
        out.append("| spin (deg/s) | closing | P*_s immediate % [95 %] | mean T (s) | "
                   "P*_s predictive % [95 %] | mean wait (s) | mean T (s) | "
                   "flips imm / pred | McNemar p |")
        out.append("|---|---|---|---|---|---|---|---|---|")
        for c in sorted(cells, key=_row_order):
            spin, closing, launch = _split(c.label)
            if launch != LAUNCHES[0]:
                continue
            a = records.get((c.label, d))
            b = records.get((f"{spin} {closing} {LAUNCHES[1]}", d))
            p = pairs.get((spin, closing, d))
            flips = "-" if p is None else f"{p.a_only} / {p.b_only}"
            mp = "-" if p is None else f"{p.mcnemar_p:.2g}"
            out.append(f"| {spin} | {closing} | {_p(a)} | "
                       f"{_num(a.stats.mean_t) if a else '-'} | {_p(b)} | "
                       f"{_num(b.stats.mean_wait, '{:.1f}') if b else '-'} | "
                       f"{_num(b.stats.mean_t) if b else '-'} | {flips} | {mp} |")
        out.append("")
    return "\n".join(out) + "\n"


def launch_summary(pairs: dict) -> list[dict]:
    """The paired changes for the study's summary file."""
    return [{"spin": spin, "closing": closing, "design": d, "p_immediate": p.a.p,
             "p_predictive": p.b.p, "immediate_only": p.a_only, "predictive_only": p.b_only,
             "mcnemar_p": p.mcnemar_p, "mean_wait": p.b.mean_wait, "t_diff": p.t_diff}
            for (spin, closing, d), p in pairs.items()]


def plot_launch(designs: list[str], cells: list, stats: dict, path, title: str) -> None:
    """P*_s (top, Wilson intervals as bars) and mean wait (bottom) against the flat-spin
    rate, a colour per design, the immediate launch dashed and the predictive solid, one
    line style per closing policy's marker; rates without results are left out."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8.5, 7.5), sharex=True)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    markers = {"threshold": "o", "adaptive": "s"}
    for k, d in enumerate(designs):
        for closing, marker in markers.items():
            for launch in LAUNCHES:
                pts = []
                for c in cells:
                    axis, rate, cl, la = _parts(c.label)
                    s = stats.get((c.label, d))
                    if axis == "flat" and cl == closing and la == launch and s is not None \
                            and s.n:
                        pts.append((float(rate), s))
                if not pts:
                    continue
                pts.sort(key=lambda p: p[0])
                x = [p[0] for p in pts]
                p = [100 * s.p for _, s in pts]
                err = [[100 * (s.p - s.lo) for _, s in pts], [100 * (s.hi - s.p) for _, s in pts]]
                style = "-" if launch == "predictive" else "--"
                top.errorbar(x, p, yerr=err, color=colours[k % len(colours)], ls=style,
                             marker=marker, capsize=3,
                             label=f"{d.rsplit('/', 1)[-1]}, {closing}, {launch}")
                if launch == "predictive":
                    bottom.plot(x, [s.mean_wait for _, s in pts], color=colours[k % len(colours)],
                                ls=style, marker=marker)
    top.axhline(98.0, color="grey", lw=0.8, ls=":")
    top.set_ylabel("P*_s (%), Wilson 95 %")
    top.set_title(title)
    top.legend(fontsize=7, loc="center left", bbox_to_anchor=(0.01, 0.55), ncol=2)
    bottom.set_ylabel("predictive launch: mean wait (s)")
    bottom.set_xlabel("flat spin rate (deg/s)")
    bottom.set_xscale("log", base=2)
    bottom.set_xticks([0.5, 1, 2, 4, 8], ["0.5", "1", "2", "4", "8"])
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
