"""Monte Carlo figures: CQI over time for every sample (grey) with the mean (black)."""
from __future__ import annotations

import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np


def mean_trace(traces: list[dict], field: str = "cqi") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean of a trace series over the samples still running at each time.

    Series are aligned by index: every trace is sampled at the metric rate from launch
    (t_k = k / metric_rate).  Returns (time, mean, number of samples running)."""
    n = max((len(t[field]) for t in traces), default=0)
    vals = np.full((len(traces), n), np.nan)
    time = np.full(n, np.nan)
    for i, t in enumerate(traces):
        y = np.asarray(t[field], dtype=float)
        vals[i, :len(y)] = y
        tt = np.asarray(t["time"], dtype=float)
        fill = np.isnan(time[:len(tt)])
        time[:len(tt)][fill] = tt[fill]
    count = np.sum(np.isfinite(vals), axis=0)
    with np.errstate(invalid="ignore"):
        mean = np.nansum(vals, axis=0) / np.maximum(count, 1)
    mean[count == 0] = np.nan
    return time, mean, count


def plot_cqi_traces(result, path: str | Path, title: str = "", success_cqi: float = 2.0) -> Path:
    """PNG of I_CQ(t) of every sample of a :class:`~tethernet_ros.montecarlo.MonteCarloResult`
    (grey) and their mean (black; over the samples still running at each time, drawn while
    at least half of them run), with the success threshold.  Samples need traces
    (evaluate(..., record_trace=True)).  Returns the path."""
    traces = [s.trace for s in result.samples if s.trace]
    if not traces:
        raise ValueError("no sample carries a CQI trace (evaluate with record_trace=True)")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(8, 5))
    alpha = max(0.08, min(0.6, 8.0 / math.sqrt(len(traces)) / 4))
    for tr in traces:
        ax.plot(tr["time"], tr["cqi"], color="0.55", lw=0.7, alpha=alpha)
    t, m, count = mean_trace(traces)
    keep = count >= max(1, len(traces) / 2)
    ax.plot(t[keep], m[keep], color="k", lw=2.0, label=f"mean of {len(traces)} samples")
    ax.plot([], [], color="0.55", lw=0.7, label="one sample")
    ax.axhline(success_cqi, color="r", ls=":", lw=1.2, label=f"success threshold {success_cqi:g}")
    ax.set_yscale("log")
    ax.set_xlabel("time since launch (s)")
    ax.set_ylabel("capture quality index $I_{CQ}$ (-)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="upper right")
    stats = (f"P*_s = {result.p_success:.3f} [{result.ci_low:.3f}, {result.ci_high:.3f}], "
             f"N = {result.n_samples}")
    ax.set_title(f"{title}\n{stats}" if title else stats, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
