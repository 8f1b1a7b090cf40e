"""How far a run has come, read from its directory while it runs or after it stopped:
evaluations done and planned, samples drawn, the best design observed feasible so far and
the convergence figure so far (``progress.png``: the best design observed feasible, or
for a finished run its chosen design with the validated P*_s).  Reads only; the run's own
files stay as they are."""
from __future__ import annotations

import json
import math
from pathlib import Path

from .cases import P_SUCCESS, get_case, validation_rule_text
from .checkpoint import CheckpointError, load_checkpoint
from .finish import sampling_counts
from .observation import Observation
from .report import plot_convergence
from .run import RUN_FILES, RunError, read_run_settings

__all__ = ["run_status", "status_text", "PROGRESS_FIGURE"]

#: the figure of the run so far, beside the run's own files
PROGRESS_FIGURE = "progress.png"


def _history(run_dir: Path) -> list[Observation]:
    path = run_dir / RUN_FILES["checkpoint"]
    if not path.exists():
        return []
    doc = load_checkpoint(path)
    try:
        return [Observation.from_dict(d) for d in doc["optimizer"]["history"]]
    except (KeyError, TypeError, ValueError) as exc:
        raise CheckpointError(f"checkpoint {str(path)!r} lacks a readable optimiser history "
                              f"({exc})") from None


def run_status(run_dir: str | Path, figure: bool = True) -> dict:
    """The state of the run in ``run_dir``: ``case``, ``evaluations`` and ``planned``
    (seed points + iterations), the sampling counts (episodes drawn, full, saved),
    ``wall_time_s`` (sum of the evaluations' wall times, s), ``best`` (evaluation number,
    objective, P*_s with its successes and samples, m_a (kg), mean T (s), the design
    vector) or None, ``summary`` (the finished run's summary.json, or None) and
    ``figure`` (the path of progress.png, or None).  RunError if ``run_dir`` holds no
    readable run settings, CheckpointError if its checkpoint is unreadable."""
    run_dir = Path(run_dir)
    settings_path = run_dir / RUN_FILES["settings"]
    settings = read_run_settings(settings_path)
    try:
        case = get_case(settings["case"])
        planned = int(settings["seed_points"]) + int(settings["iterations"])
        samples = int(settings["samples"])
    except (ValueError, KeyError, TypeError) as exc:
        raise RunError(f"{settings_path} is unreadable ({exc})") from None
    history = _history(run_dir)
    feasible = [(i, o) for i, o in enumerate(history, 1) if o.feasible]
    best = None
    if feasible:
        i, o = min(feasible, key=lambda t: (t[1].objective, t[0]))
        best = {"evaluation": i, "objective": o.objective,
                "p_success": o.constraints.get(P_SUCCESS),
                "successes": o.info.get("successes"), "samples": o.info.get("samples"),
                "mass": o.info.get("mass"),
                "mean_completion_time": o.info.get("mean_completion_time"),
                "x": [float(v) for v in o.x]}
    summary_path = run_dir / RUN_FILES["summary"]
    summary = (json.loads(summary_path.read_text(encoding="utf-8"))
               if summary_path.exists() else None)
    out = {"case": case.name, "case_number": case.number, "run_dir": str(run_dir),
           "evaluations": len(history), "planned": planned,
           **sampling_counts(history, samples, bool(settings.get("sequential", False))),
           "wall_time_s": sum(float(o.info.get("wall_time") or 0.0) for o in history),
           "best": best, "summary": summary, "figure": None}
    if figure and history:
        best_obs = history[best["evaluation"] - 1] if best else None
        label, validated = "best feasible so far", None
        chosen = (summary or {}).get("best_evaluation")
        if isinstance(chosen, int) and 1 <= chosen <= len(history):
            # a finished run: its chosen design and validated P*_s, as in convergence.png
            best_obs, label = history[chosen - 1], "chosen design"
            validated = ((summary.get("validation") or {}).get("p_success"))
        out["figure"] = str(plot_convergence(run_dir / PROGRESS_FIGURE, history, case, best_obs,
                                             validated, best_label=label))
    return out


def status_text(st: dict) -> str:
    """A few lines for people."""
    lines = [f"Case {st['case_number']} ({st['case']}), {st['run_dir']}: "
             f"{st['evaluations']} of {st['planned']} designs evaluated"
             + (" (finished)" if st["summary"] else ""),
             f"samples drawn {st['episodes']} of {st['episodes_full']} "
             f"({st['episodes_saved']} saved by {st['sampling']} sampling); "
             f"{st['wall_time_s'] / 3600:.2f} h of evaluation wall time"]
    b = st["best"]
    if b is None:
        lines.append("no design observed feasible yet")
    else:
        t = b["mean_completion_time"]
        lines.append(f"best feasible so far: evaluation {b['evaluation']}, objective "
                     f"{b['objective']:.4g}, P*_s {b['successes']}/{b['samples']}, m_a "
                     f"{b['mass']:.3f} kg, mean T "
                     + ("n/a" if t is None or not math.isfinite(t) else f"{t:.2f} s"))
    chosen = chosen_text(st["summary"])
    if chosen:
        lines.append(chosen)
    if st["figure"]:
        lines.append(f"figure so far: {st['figure']}")
    return "\n".join(lines)


def chosen_text(summary: dict | None) -> str | None:
    """A finished run's choice after validation, in a line (None before the end or when
    nothing was chosen)."""
    if not summary or not isinstance(summary.get("best_evaluation"), int):
        return None
    text = (f"chosen after validation: evaluation {summary['best_evaluation']}, objective "
            f"{summary['best_objective']:.4g}")
    v = summary.get("validation")
    if v:
        verdict = "meets" if v.get("meets_requirement") else "does NOT meet"
        text += (f", validated P*_s {v['successes']}/{v['samples']} "
                 f"[{v['wilson'][0]:.3f}, {v['wilson'][1]:.3f}], {verdict} C_P = "
                 f"{summary.get('p_threshold', 0.98):g}"
                 f"{validation_rule_text(summary.get('validation_rule'))}")
    return text
