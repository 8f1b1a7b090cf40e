"""Figure of one capture: CQI (and its terms) and locked pairs over time."""
from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt

from ..core.episode import EpisodeResult


def plot_capture_trace(result: EpisodeResult, path: str | Path, title: str = "") -> Path:
    """Write a PNG of I_CQ(t) with its three terms and n_L(t); closing onset and the
    settled reading are marked.  Returns the path."""
    tr = result.trace
    if tr is None or not tr.time:
        raise ValueError("the episode has no trace (run it with record_trace=True)")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True,
                                   gridspec_kw={"height_ratios": [2, 1]})
    ax1.plot(tr.time, tr.cqi, "k", lw=1.6, label="CQI $I_{CQ}$")
    ax1.plot(tr.time, tr.volume_term, lw=0.9, label="volume term")
    ax1.plot(tr.time, tr.area_term, lw=0.9, label="area term")
    ax1.plot(tr.time, tr.distance_term, lw=0.9, label="CoM-distance term")
    ax1.axhline(2.0, color="r", ls=":", lw=1, label="success threshold 2.0")
    ax1.set_ylabel("CQI (-)")
    ax1.set_yscale("symlog", linthresh=1.0)
    ax2.step(tr.time, tr.locked_pairs, where="post", color="tab:purple")
    ax2.axhline(10, color="r", ls=":", lw=1)
    ax2.set_ylabel("locked pairs $n_L$")
    ax2.set_ylim(-0.5, 12.5)
    ax2.set_xlabel("time since launch (s)")
    for ax in (ax1, ax2):
        if result.closing_time == result.closing_time:  # not NaN
            ax.axvline(result.closing_time, color="0.5", ls="--", lw=1)
        ax.grid(alpha=0.3)
    if result.settled_cqi == result.settled_cqi:
        ax1.plot([result.completion_time], [result.settled_cqi], "o", color="r", label="settled CQI")
    ax1.legend(fontsize=8, loc="upper right")
    verdict = "success" if result.success else f"failure: {result.failure_reason}"
    fig.suptitle(f"{title}  ({verdict})" if title else verdict, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
