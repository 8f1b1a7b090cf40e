"""Noise sensitivity figure: P*_s against the scale of one noise source, one curve each."""
from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt

SOURCE_LABELS = {
    "speed": "launch speed $v_{rnd}$",
    "polar": r"launch polar angle $\theta_{rnd}$",
    "azimuth": r"launch azimuth $\phi_{rnd}$",
    "distance": "distance to target $D_{rnd}$",
    "orientation": r"target orientation $\alpha_{rnd}$",
    "closing": "closing displacement $d_{rnd}$",
}


def plot_sensitivity(rows: list[dict], path: str | Path, title: str = "") -> Path:
    """PNG of P*_s (with its 95 % interval as a band) against the noise scale factor (log
    axis), one curve per source.  ``rows``: dicts with source, scale, p_success, ci_low,
    ci_high (the sensitivity CSV's columns).  Returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    sources = list(dict.fromkeys(r["source"] for r in rows))
    fig, ax = plt.subplots(figsize=(8, 5))
    for k, src in enumerate(sources):
        pts = sorted((float(r["scale"]), float(r["p_success"]), float(r["ci_low"]), float(r["ci_high"]))
                     for r in rows if r["source"] == src)
        x = [p[0] for p in pts]
        color = f"C{k}"
        ax.plot(x, [p[1] for p in pts], "o-", color=color, lw=1.5, ms=4,
                label=SOURCE_LABELS.get(src, src))
        ax.fill_between(x, [p[2] for p in pts], [p[3] for p in pts], color=color, alpha=0.15, lw=0)
    ax.axvline(1.0, color="0.5", ls="--", lw=1)
    xs = sorted({float(r["scale"]) for r in rows})
    pos = [x for x in xs if x > 0]
    if xs and xs[0] == 0:  # a zero scale cannot sit on a log axis: linear below the smallest > 0
        ax.set_xscale("symlog", linthresh=pos[0] if pos else 1.0, linscale=0.5)
    else:
        ax.set_xscale("log")
    ax.set_xticks(xs)
    ax.set_xticklabels([f"{x:g}" for x in xs])
    ax.minorticks_off()
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlabel("noise scale factor (x nominal spread)")
    ax.set_ylabel("probability of success $P^*_s$")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="lower left")
    n = rows[0].get("samples") if rows else None
    sub = "one source scaled at a time; bands: Wilson 95 %" + (f"; N = {n} per point" if n else "")
    ax.set_title(f"{title}\n{sub}" if title else sub, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
