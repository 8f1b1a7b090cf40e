"""What a run writes for people: the history (CSV, one row per evaluated design), the
results table (CSV + Markdown) and the convergence-history figure."""
from __future__ import annotations

import csv
import math
from pathlib import Path
from collections.abc import Sequence

import numpy as np

from .cases import P_SUCCESS, Case, validation_rule_text
from .jsonio import atomic_write_text

__all__ = ["write_history", "write_results", "plot_convergence", "results_markdown"]

#: the results CSV's columns after the design variables
_CSV_FIELDS = ["m_a_kg", "mean_T_s", "p_success_opt", "successes_opt", "samples_opt",
               "opt_wilson_low", "opt_wilson_high", "p_success_validated", "successes_validated",
               "samples_validated", "validated_wilson_low", "validated_wilson_high",
               "validated_cp_low", "validated_cp_high", "validated_mean_T_s", "selection_rule"]


def _missing(v) -> bool:
    """None or a non-finite float: nothing to print."""
    return v is None or (isinstance(v, float) and not math.isfinite(v))


def _f(v, digits=3):
    return "n/a" if _missing(v) else f"{v:.{digits}f}"


def _num(v):
    if _missing(v):
        return ""
    return repr(float(v)) if isinstance(v, float) else str(v)


def _fmt(v) -> str:
    if _missing(v):
        return ""
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def write_history(path: str | Path, history, variable_names: Sequence[str]) -> None:
    """``history.csv``: one row per evaluated design (variables, objective, P*_s, the
    samples it rests on, feasibility, m_a, mean T, acquisition diagnostics, wall time).
    When an evaluation ran at another fidelity than the reference (``info["fidelity"]``,
    docs/optimizer.md, fidelities), a ``fidelity`` column before the wall time says each
    row's; a run wholly at the reference writes the columns it always did."""
    fidelities = [o.info.get("fidelity", "reference") for o in history]
    mixed = any(f != "reference" for f in fidelities)
    head = (["evaluation", "phase", *variable_names, "objective", "p_success", "successes",
             "samples", "feasible", "mass", "mean_completion_time", "probability_feasible",
             "eiplus_tries", *(["fidelity"] if mixed else []), "wall_time"])
    lines = [",".join(head)]
    for i, o in enumerate(history, 1):
        a, info = o.acquisition, o.info
        vals = [i, a.get("phase", ""), *[f"{v:.10g}" for v in o.x], f"{o.objective:.10g}",
                f"{o.constraints[P_SUCCESS]:.6g}", info.get("successes", ""),
                info.get("samples", ""), int(o.feasible), _fmt(info.get("mass")),
                _fmt(info.get("mean_completion_time")), _fmt(a.get("probability_feasible")),
                a.get("eiplus_tries", ""), *([fidelities[i - 1]] if mixed else []),
                _fmt(info.get("wall_time"))]
        lines.append(",".join(str(v) for v in vals))
    atomic_write_text(path, "\n".join(lines) + "\n")


def write_results(csv_path: str | Path, md_path: str | Path, summary: dict) -> None:
    """``results.csv`` (one row per table row, every number) and ``results.md`` (the
    table of docs/model.md §12: m_a, mean T, P*_s during optimisation, validated P*_s with its
    Wilson and Clopper-Pearson 95 % intervals)."""
    rows = summary["table"]
    with open(csv_path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["case", "design", "evaluation", *summary["variables"], *_CSV_FIELDS])
        for r in rows:
            x, v = r["x"], r["validation"] or {}
            w.writerow([summary["case"], r["design"], _num(r["evaluation"]),
                        *map(_num, _flat(x)), _num(r["mass"]), _num(r["mean_completion_time"]),
                        _num(r["p_success"]), _num(r["successes"]), _num(r["samples"]),
                        _num(r["ci"][0]), _num(r["ci"][1]), _num(v.get("p_success")),
                        _num(v.get("successes")), _num(v.get("samples")),
                        _num((v.get("wilson") or [None])[0]),
                        _num((v.get("wilson") or [None, None])[1]),
                        _num((v.get("clopper_pearson") or [None])[0]),
                        _num((v.get("clopper_pearson") or [None, None])[1]),
                        _num(v.get("mean_completion_time")),
                        summary["selection_rule"] if r["evaluation"] else ""])
    Path(md_path).write_text(results_markdown(summary), encoding="utf-8")


def results_markdown(summary: dict) -> str:
    rows = summary["table"]
    n_opt = summary["samples"]
    n_val = summary.get("validation_samples") or next(
        (r["validation"]["samples"] for r in rows if r["validation"]), None)
    out = [f"# Case {summary['case_number']} results", "",
           f"{summary['problem']}." + (f" Scenario: {summary['scenario']}."
                                        if summary.get("scenario") else ""), "",
           f"{summary['evaluations']} designs evaluated ({summary['seed_points']} seed points + "
           f"{max(summary['evaluations'] - summary['seed_points'], 0)} "
           f"iterations), {_samples_text(summary)}, "
           f"{summary['feasible_evaluations']} observed feasible. Status: {summary['status']}.", ""]
    if not rows:
        out += ["No evaluated design met the constraints; nothing to validate.", ""]
        return "\n".join(out)
    val_head = f"validated P*_s (N={n_val}) [Wilson 95%]" if n_val else "validated P*_s"
    head = ["design", "m_a (kg)", "mean T (s)", f"P*_s (N={n_opt}) [Wilson 95%]", val_head,
            "Clopper-Pearson 95%", "validated mean T (s)"]
    out += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        v = r["validation"]
        opt = f"{_f(r['p_success'], 2)} [{_f(r['ci'][0])}, {_f(r['ci'][1])}]"
        if r["samples"] is not None and r["samples"] != n_opt:
            opt += f" (N={r['samples']})"
        if v:
            val = f"{_f(v['p_success'])} [{_f(v['wilson'][0])}, {_f(v['wilson'][1])}]"
            if v.get("stopped"):
                val += (f" (N={v['samples']}: stopped at the failure that decided it "
                        f"misses C_P)")
            cp = f"[{_f(v['clopper_pearson'][0])}, {_f(v['clopper_pearson'][1])}]"
            vt = _f(v["mean_completion_time"], 2)
        else:
            val, cp, vt = "not validated", "", ""
        out.append("| " + " | ".join([r["design"], _f(r["mass"], 2),
                                      _f(r["mean_completion_time"], 2), opt, val, cp, vt]) + " |")
    pub = summary.get("published")
    if pub:
        p_opt = pub["p_success_optimisation"]
        out.append("| " + " | ".join([
            f"source's {pub['design']} (Table 4)", _f(pub["mass"], 2),
            _f(pub["mean_completion_time"], 1), "n/a" if p_opt is None else _f(p_opt, 2),
            _f(pub["p_success_validated"]), "", ""]) + " |")
    out += ["", "Design variables:", ""] + _variables_table(rows, summary["variables"])
    out += _racing_lines(summary)
    out += _fidelity_lines(summary)
    out += ["", f"Chosen by: {summary['selection_rule']}."]
    if rows[0]["evaluation"]:
        out.append(f"Best design = evaluation {rows[0]['evaluation']}.")
    v = rows[0]["validation"]
    if v and rows[0]["evaluation"]:
        out.append(f"Validated with {v['samples']} fresh samples (base seed {v['base_seed']}): "
                   f"P*_s {'meets' if v['meets_requirement'] else 'does NOT meet'} the "
                   f"requirement C_P = {summary['p_threshold']:g}"
                   f"{validation_rule_text(summary.get('validation_rule'))}.")
    out.append("mean T is over all samples (closing never triggered: T = horizon).")
    return "\n".join(out) + "\n"


def _flat(design: dict) -> list:
    """A design dict's values in order, lists spread out (the design vector)."""
    out = []
    for v in design.values():
        out += list(v) if isinstance(v, (list, tuple)) else [v]
    return out


def _variables_table(rows: list[dict], names: Sequence[str]) -> list[str]:
    """The rows' design variables: the tether-net's with their units, any other
    problem's by name."""
    if rows and "V_e" in rows[0]["x"]:
        out = ["| design | m_c (kg) | L_n (m) | r_n (m) | d_L (m) | V_e (m/s) | d_c (m) |",
               "|---|---|---|---|---|---|---|"]
        for r in rows:
            x = r["x"]
            ve = ", ".join(f"{v:.2f}" for v in x["V_e"])
            out.append(f"| {r['design']} | {x['m_c']:.2f} | {x['L_n']:.2f} | {x['r_n']:.4f} | "
                       f"{x['d_L']:.2f} | [{ve}] | {x['d_c']:.2f} |")
        return out
    out = ["| design | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]
    for r in rows:
        out.append(f"| {r['design']} | " + " | ".join(f"{v:.6g}" for v in _flat(r["x"])) + " |")
    return out


def _racing_lines(summary: dict) -> list[str]:
    """The race before the validations (optimizer/racing.py) as a table, and the
    episodes of the whole run; nothing for a run that did not race."""
    race = summary.get("racing")
    if not race:
        return []
    out = ["", f"Racing on fresh samples before validation: {race['episodes']} samples in "
               f"{race['rounds']} rounds ({race['stopped_by']}); episodes in all: "
               f"{summary.get('episodes')} optimisation + {summary.get('episodes_racing')} "
               f"racing + {summary.get('episodes_validation')} validation = "
               f"{summary.get('episodes_total')}.", "",
           "| evaluation | objective | racing P*_s [Wilson 95%] | samples | status |",
           "|---|---|---|---|---|"]
    for e in race["entries"]:
        p = e["successes"] / e["samples"] if e["samples"] else None
        out.append(f"| {e['evaluation']} | {_fmt(e['objective'])} | {_f(p)} "
                   f"[{_f(e['wilson'][0])}, {_f(e['wilson'][1])}] | {e['samples']} | "
                   f"{e['status']} |")
    return out


def _fidelity_lines(summary: dict) -> list[str]:
    """Which phases ran at another fidelity than the reference (docs/optimizer.md,
    fidelities); nothing for a run wholly at the reference."""
    fid = summary.get("fidelity") or {}
    other = {p: f for p, f in fid.items() if f != "reference"}
    if not other:
        return []
    names = {"initial": "seed points", "iterations": "iterations"}
    said = ", ".join(f"{names.get(p, p)} at {f}" for p, f in other.items())
    return ["", f"Fidelity: {said}; so the optimisation P*_s and mean T above are "
                f"{'/'.join(sorted(set(other.values())))}-fidelity estimates that only "
                "steered the search. Racing and validation ran at the reference fidelity: "
                "the validated columns are reference-fidelity results."]


def _samples_text(summary: dict) -> str:
    """How many samples each design got: N each, or up to N with sequential sampling."""
    n, seed = summary["samples"], summary["sample_seed"]
    if summary.get("sampling") != "sequential":
        return f"{n} samples each (base seed {seed})"
    return (f"up to {n} samples each (base seed {seed}; sequential sampling: "
            f"{summary['episodes']} of {summary['episodes_full']} drawn, "
            f"{summary['episodes_saved']} saved)")


def plot_convergence(path: str | Path, history, case: Case, best=None,
                     validated_p: float | None = None, best_label: str = "chosen design") -> Path:
    """Three panels over the evaluation number: the objective of each evaluated design
    (filled: observed feasible, hollow: infeasible) with the best feasible so far; P*_s
    with the threshold; the other quantity of the results table (Case 1: mean T; Case 2:
    m_a with C_m).  A panel whose values span more than a decade is drawn on a log scale.
    The seed phase is shaded and the chosen design starred (with its validated P*_s if
    given; ``best_label`` names it)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    n = len(history)
    it = np.arange(1, n + 1)
    obj = np.array([o.objective for o in history]) if n else np.zeros(0)
    p = np.array([o.constraints[P_SUCCESS] for o in history]) if n else np.zeros(0)
    other_key, other_label = (("mean_completion_time", "mean T (s)") if case.objective == "mass"
                              else ("mass", "m_a (kg)"))
    other = (np.array([float(o.info.get(other_key) or math.nan) for o in history]) if n
             else np.zeros(0))
    feas = np.array([o.feasible for o in history], dtype=bool) if n else np.zeros(0, bool)
    n_seed = sum(1 for o in history if o.acquisition.get("phase", "initial") == "initial")
    best_so_far = np.full(n, np.nan)
    cur = math.inf
    for i, o in enumerate(history):
        if o.feasible:
            cur = min(cur, o.objective)
        best_so_far[i] = cur if math.isfinite(cur) else np.nan

    fig, axes = plt.subplots(3, 1, figsize=(8, 8.5), sharex=True)
    ax = axes[0]
    ax.plot(it[~feas], obj[~feas], "o", mfc="none", mec="0.6", ms=4, label="infeasible (observed)")
    ax.plot(it[feas], obj[feas], "o", color="tab:blue", ms=4, label="feasible (observed)")
    ax.step(it, best_so_far, where="post", color="k", lw=1.5, label="best feasible so far")
    ax.set_ylabel(f"{case.objective_label} ({case.objective_unit})")
    ax = axes[1]
    ax.plot(it, p, ".", color="tab:green", ms=5)
    ax.axhline(case.p_threshold, color="r", ls=":", lw=1, label=f"C_P = {case.p_threshold:g}")
    ax.set_ylabel("P*_s (optimisation samples)")
    ax.set_ylim(-0.03, 1.03)
    ax = axes[2]
    ax.plot(it, other, ".", color="tab:purple", ms=5)
    if case.mass_limit is not None and other_key == "mass":
        ax.axhline(case.mass_limit, color="r", ls=":", lw=1, label=f"C_m = {case.mass_limit:g} kg")
    ax.set_ylabel(other_label)
    ax.set_xlabel("evaluation")
    for ax, values in ((axes[0], obj), (axes[2], other)):
        v = values[np.isfinite(values) & (values > 0)]
        if v.size and v.max() > 10 * v.min():
            ax.set_yscale("log")
    if best is not None and n:
        i = next(k for k, o in enumerate(history) if o is best) + 1
        axes[0].plot([i], [best.objective], "*", color="tab:red", ms=13, label=best_label)
        axes[1].plot([i], [best.constraints[P_SUCCESS]], "*", color="tab:red", ms=13)
        if validated_p is not None and math.isfinite(validated_p):
            axes[1].plot([i], [validated_p], "D", mfc="none", mec="tab:red", ms=8,
                         label="validated P*_s")
        axes[2].plot([i], [other[i - 1]], "*", color="tab:red", ms=13)
    for ax in axes:
        if n_seed:
            ax.axvspan(0.5, min(n_seed, max(n, 1)) + 0.5, color="0.92", zorder=0)
        ax.grid(alpha=0.3)
        handles, labels = ax.get_legend_handles_labels()
        if handles:
            ax.legend(fontsize=8, loc="best")
    axes[0].set_title(f"{case.describe()}  (shaded: {n_seed} seed points)", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
