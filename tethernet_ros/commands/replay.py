"""`tethernet replay BAG`: recompute CQI, n_L and the verdict from a recorded capture.

The bag's EpisodeSetup, LaunchCommand and ClosingCommand rebuild the episode's scenario
(:class:`~tethernet_ros.monitoring.StateMirror`); every recorded NetState is loaded into it
and the core's CQI function, locked-pair count and verdict rules are applied.  The
results are compared with the recorded CaptureMetrics, the simulation's EpisodeResult and
the monitor's verdict.  A lockstep episode's loop is replayed too: the core's Sensor,
seeded as the sensor node's, turns every recorded true measurement into the sensed one,
which must be the recorded one bit for bit; the built-in policies (``Policy``, and
``LaunchPolicy`` before the launch) decide on every recorded sensed measurement as the
actuator did, and must give the recorded decisions (a user's controller's are counted,
not recomputed); the episode's launch time must be the step of the first decision to
fire, and its closing time the step of the first decision to close; decisions from two nodes (two
controller names, or a control step decided twice) are reported as two deciders.  Messages of the types replay does
not use (markers, target poses, /clock, the sensed state in standard messages) are
skipped and counted per topic.  A truncated or corrupted bag is read up
to the damage and the damage is reported; exit status 1 then, or on any disagreement; 0 when everything
matches.  No ROS installation is needed (mcap + mcap-ros2-support decode the bag).
"""
from __future__ import annotations

import math
from pathlib import Path

from .common import print_json

NAME = "replay"
HELP = "recompute CQI, n_L and the verdict from a recorded bag and compare with its result"

SETUP = "tethernet_msgs/msg/EpisodeSetup"
LAUNCH = "tethernet_msgs/msg/LaunchCommand"
CLOSING = "tethernet_msgs/msg/ClosingCommand"
STATE = "tethernet_msgs/msg/NetState"
METRICS = "tethernet_msgs/msg/CaptureMetrics"
RESULT = "tethernet_msgs/msg/EpisodeResult"
MEASUREMENT = "tethernet_msgs/msg/Measurement"
DECISION = "tethernet_msgs/msg/ClosingDecision"
LAUNCH_DECISION = "tethernet_msgs/msg/LaunchDecision"
#: the types replay reads; the messages of every other type (markers, poses, /clock, the
#: sensed state in standard messages) are skipped and counted per topic
USED = {SETUP, LAUNCH, CLOSING, STATE, METRICS, RESULT, MEASUREMENT, DECISION, LAUNCH_DECISION}


def add_arguments(p):
    p.add_argument("bag", metavar="BAG", help="bag folder (metadata.yaml + .mcap) or .mcap file")
    p.add_argument("--json", action="store_true", help="print one JSON object")


def _result_dict(r) -> dict | None:
    from ..core import metrics

    if r is None:
        return None
    ct = r.closing_time
    return {"success": bool(r.success), "settled_cqi": float(r.settled_cqi),
            "locked_pairs": int(r.locked_pairs),
            "closing_time": None if ct is None or ct != ct or ct < 0 else float(ct),
            "completion_time": float(r.completion_time), "failure_reason": r.failure_reason,
            "criterion": metrics.criterion_of(r)}


def replay(path) -> dict:
    """Replay report of a bag (see the module docstring); raises BagError only if there
    is no bag at ``path``."""
    from ..bags import read_bag
    from ..monitoring import StateMirror
    from ..ros import conversions as conv
    from ..ros.names import TOPICS
    from ..ros.results import compare_results
    from ..ros.state import stamp_key

    contents = read_bag(path, types=USED)
    problems = list(contents.problems)
    read = contents.counts()
    report = {"bag": str(contents.path), "complete": contents.complete, "problems": problems,
              "messages": len(contents.messages) + contents.n_skipped,
              "messages_read": len(contents.messages), "messages_skipped": contents.n_skipped,
              "topics": {t: {"type": contents.topics[t], "read": read.get(t, 0),
                             "skipped": contents.skipped.get(t, 0)}
                         for t in sorted(contents.topics)},
              "bytes_read": contents.bytes_read, "file_size": contents.file_size}

    def decoded(msgtype, topic=None):
        return [m.msg for m in contents.messages
                if m.msgtype == msgtype and m.msg is not None and (topic is None or m.topic == topic)]

    setups, launches, closings = decoded(SETUP), decoded(LAUNCH), decoded(CLOSING)
    truths = decoded(MEASUREMENT, TOPICS["true_measurement"])
    sensed = decoded(MEASUREMENT, TOPICS["measurement"])
    decisions = decoded(DECISION)
    launch_decisions = decoded(LAUNCH_DECISION)
    states = sorted(decoded(STATE), key=lambda m: m.step)
    metrics = decoded(METRICS)
    results = [m for m in contents.messages if m.msgtype == RESULT and m.msg is not None]
    sim_results = [m.msg for m in results if m.topic != TOPICS["verdict"]]
    verdicts = [m.msg for m in results if m.topic == TOPICS["verdict"]]
    report.update(states=len(states), metrics_recorded=len(metrics))
    recomputed = None
    mirror = None
    setup = actions = world = None
    if not setups or not launches or not closings:
        missing = [n for n, v in (("EpisodeSetup", setups), ("LaunchCommand", launches),
                                  ("ClosingCommand", closings)) if not v]
        problems.append(f"cannot rebuild the scenario: no {', '.join(missing)} in the bag")
    else:
        try:
            setup = conv.setup_from_msg(setups[0])
            key = setup.stamp
            launch = next((m for m in launches if stamp_key(m.header) == key), launches[0])
            closing = next((m for m in closings if stamp_key(m.header) == key), closings[0])
            actions, world = conv.commands_from_msgs(launch, closing)
            mirror = StateMirror(setup.design, actions, world, setup.config)
            report.update(episode_id=setup.episode_id, design=setup.design.to_dict(),
                          seed=setup.seed, config_overrides=setups[0].sim_config_json,
                          target=setup.config.target.identity())
        except Exception as exc:  # noqa: BLE001 - a bag's content is reported, not raised
            problems.append(f"cannot rebuild the scenario: {exc}")
    if mirror is not None:
        by_time = {}
        for m in metrics:
            by_time.setdefault(m.sim_time, m)
        compared, max_diff, n_l_mismatch = 0, 0.0, 0
        for msg in states:
            try:
                mirror.load(conv.net_state_from_msg(msg))
            except Exception as exc:  # noqa: BLE001
                problems.append(f"state at step {msg.step}: {exc}")
                continue
            terms = mirror.terms()
            rec = by_time.get(msg.sim_time)
            if rec is not None:
                compared += 1
                a = terms.cqi if terms else math.nan
                if not (math.isnan(a) and math.isnan(rec.cqi)):
                    max_diff = max(max_diff, abs(a - rec.cqi)) if not math.isnan(a - rec.cqi) else math.inf
                n_l_mismatch += int(rec.locked_pairs != mirror.locked_pairs)
            if recomputed is None:
                recomputed = mirror.verdict()
        report.update(metrics_compared=compared, metrics_max_cqi_diff=max_diff,
                      metrics_locked_pair_mismatches=n_l_mismatch)
        if states:
            report.update(first_time=states[0].sim_time, last_time=states[-1].sim_time)
        if recomputed is None and states:
            problems.append(f"the recorded states end at t = {states[-1].sim_time:.3f} s, before "
                            "the episode's end: no verdict can be recomputed")
        if compared and (max_diff != 0.0 or n_l_mismatch):
            problems.append(f"recorded metrics differ from the recomputed ones (max |dCQI| = "
                            f"{max_diff:.3g}, {n_l_mismatch} n_L mismatches)")
    if truths or sensed or decisions or launch_decisions:
        try:
            report["loop"] = _replay_loop(setup, actions, world, truths, sensed, decisions,
                                          launch_decisions,
                                          sim_results[-1] if sim_results else None, problems)
        except Exception as exc:  # noqa: BLE001 - a bag's content is reported, not raised
            problems.append(f"cannot replay the closing loop: {exc}")
    report["recomputed"] = _result_dict(recomputed)
    report["recorded_result"] = _result_dict(sim_results[-1]) if sim_results else None
    # the tug test's verdict (docs/model.md §17) as the simulation recorded it; replay
    # recomputes the capture's verdict from the states, not the test's
    report["recorded_tug"] = conv.tug_from_msg(sim_results[-1]) if sim_results else None
    # the criterion that judged the recorded result (the recomputed verdict is the
    # source's: states cannot be pulled; they are compared by it, ros/results.py)
    report["criterion"] = (report["recorded_result"] or {}).get("criterion", "source")
    report["recorded_verdict"] = _result_dict(verdicts[-1]) if verdicts else None
    for key, recs in (("result", sim_results), ("verdict", verdicts)):
        if recomputed is None or not recs:
            report[f"matches_{key}"] = None
            if not recs:
                problems.append(f"no recorded {'EpisodeResult' if key == 'result' else 'monitor verdict'}")
            continue
        diff = compare_results(recomputed, recs[-1])
        report[f"matches_{key}"] = not diff
        if diff:
            problems.append(f"recomputed verdict differs from the recorded {key}: {diff}")
    report["ok"] = (not problems and recomputed is not None
                    and report.get("matches_result") is True)
    return report


def _two_deciders(decisions, what: str, problems) -> list[str]:
    """The controllers named in ``decisions`` (one kind); two names, or two decisions for
    one control step, are two nodes answering: a problem is appended."""
    controllers = sorted({d.controller for d in decisions})
    per_step = {}
    for d in decisions:
        per_step[int(d.step)] = per_step.get(int(d.step), 0) + 1
    doubled = sorted(step for step, n in per_step.items() if n > 1)
    if len(controllers) > 1 or doubled:
        problems.append(
            f"two deciders: {len(decisions)} {what} for {len(per_step)} control steps"
            + (f" from {', '.join(repr(c) for c in controllers)}" if len(controllers) > 1 else "")
            + (f"; {len(doubled)} steps decided more than once (first: step {doubled[0]})"
               if doubled else "")
            + " (the controller contract allows one node to decide)")
    return controllers


def _replay_loop(setup, actions, world, truths, sensed, decisions, launch_decisions, result,
                 problems) -> dict:
    """Replay a lockstep episode's loop (module docstring); problems are appended."""
    from ..ros import conversions as conv
    from ..ros.loop import episode_launch_policy, episode_policy, episode_scenario, \
        episode_sensor, is_builtin_controller

    def by_step(msgs):
        out = {}
        for m in msgs:
            out.setdefault(int(m.step), m)
        return out

    truth_at, sensed_at, decided_at = by_step(truths), by_step(sensed), by_step(decisions)
    launch_at = by_step(launch_decisions)
    # one decider of each kind per episode (docs/ros.md, the controller contract)
    controllers = _two_deciders(decisions, "decisions", problems)
    launch_controllers = _two_deciders(launch_decisions, "launch decisions", problems)
    loop = {"true_measurements": len(truths), "measurements": len(sensed),
            "decisions": len(decisions), "controllers": controllers,
            "launch_decisions": len(launch_decisions), "launch_controllers": launch_controllers,
            "sensed_recomputed": 0, "sensed_mismatches": 0,
            "decisions_recomputed": 0, "decision_mismatches": 0, "closing_step": None,
            "launch_step": None}
    closes = sorted(step for step, d in decided_at.items() if d.close)
    if closes:
        loop["closing_step"] = closes[0]
    fires = sorted(step for step, d in launch_at.items() if d.launch)
    if fires:
        loop["launch_step"] = fires[0]
    if setup is None or actions is None:
        return loop
    scenario = episode_scenario(setup, actions, world)
    sensor = episode_sensor(setup, scenario)
    builtin = bool(decisions) and all(is_builtin_controller(c) for c in controllers)
    policy = episode_policy(setup, scenario) if builtin else None
    builtin_launch = bool(launch_decisions) and all(is_builtin_controller(c)
                                                    for c in launch_controllers)
    launch_policy = episode_launch_policy(setup, scenario) if builtin_launch else None
    first_bad = None

    def same(a, b) -> bool:
        return (a is None and b is None) or (a is not None and b is not None
                                             and a.tobytes() == b.tobytes())

    for step in sorted(truth_at):
        mine = sensor.measure(conv.measurement_from_msg(truth_at[step]), step)
        rec = sensed_at.get(step)
        if rec is None:
            continue
        loop["sensed_recomputed"] += 1
        recorded = conv.measurement_from_msg(rec)
        if not same(mine, recorded):
            loop["sensed_mismatches"] += 1
            first_bad = step if first_bad is None else first_bad
        if policy is not None and step in decided_at:
            close = recorded is not None and policy.decide(recorded)
            loop["decisions_recomputed"] += 1
            if close != bool(decided_at[step].close):
                loop["decision_mismatches"] += 1
        if launch_policy is not None and step in launch_at:
            fire = launch_policy.decide(recorded, sensor.age(step, scenario.dt), step)
            loop["decisions_recomputed"] += 1
            if fire != bool(launch_at[step].launch):
                loop["decision_mismatches"] += 1
    if loop["sensed_mismatches"]:
        problems.append(f"{loop['sensed_mismatches']} recorded sensed measurements differ from "
                        f"the sensor's replay (first at step {first_bad})")
    if loop["decision_mismatches"]:
        problems.append(f"{loop['decision_mismatches']} recorded decisions differ from the "
                        "built-in policy's replay")
    if len(decided_at) + len(launch_at) < len(truth_at) \
            and not (result is not None and result.failure_reason):
        problems.append(f"{len(truth_at) - len(decided_at)} control steps have no recorded "
                        "decision")
    if result is not None and fires:
        lt = getattr(result, "launch_time", math.nan)
        if lt == lt and lt != fires[0] * scenario.dt:
            problems.append(f"the launch time {lt} s is not the first decision to fire "
                            f"(step {fires[0]}, t = {fires[0] * scenario.dt} s)")
    if result is not None and closes:
        ct = result.closing_time
        if ct >= 0 and ct != closes[0] * scenario.dt:
            problems.append(f"the closing time {ct} s is not the first decision to close "
                            f"(step {closes[0]}, t = {closes[0] * scenario.dt} s)")
    return loop


def target_text(t: dict) -> str:
    """The recorded target in words: its name (or mesh file, units, the start of its
    SHA-256) and kind."""
    if t.get("mesh"):
        sha = (t.get("mesh_sha256") or "")[:12]
        return (f"{t.get('name') or Path(t['mesh']).name} ({t.get('kind')}: {t['mesh']}, units "
                f"{t.get('units') or 'm'}" + (f", sha256 {sha}" if sha else "") + ")")
    return f"{t.get('name') or 'zenit-2'} ({t.get('kind')})"


def _fmt_result(r) -> str:
    if r is None:
        return "none"
    verdict = "SUCCESS" if r["success"] else "FAILURE"
    cqi = "n/a" if r["settled_cqi"] != r["settled_cqi"] else f"{r['settled_cqi']:.6g}"
    text = f"{verdict}: settled CQI {cqi}, n_L {r['locked_pairs']}, T {r['completion_time']:.4f} s"
    text += f" ({r['failure_reason']})" if r["failure_reason"] else ""
    return text + f"  [criterion {r.get('criterion', 'source')}]"


def run(args) -> int:
    from ..bags import BagError
    from ..errors import UserError

    try:
        report = replay(Path(args.bag))
    except BagError as exc:
        raise UserError(str(exc)) from None
    if args.json:
        print_json(report)
        return 0 if report["ok"] else 1
    lines = [f"replay of {report['bag']}"
             + (f" (episode {report['episode_id']}, seed "
                f"{'nominal' if report.get('seed') is None else report['seed']})"
                if "episode_id" in report else "")]
    lines.append(f"  bag               {'complete' if report['complete'] else 'INCOMPLETE / DAMAGED'}: "
                 f"{report['messages']} messages ({report['messages_read']} read, "
                 f"{report['messages_skipped']} skipped: not used by replay), "
                 f"{report['bytes_read']} of {report['file_size']} bytes")
    width = max((len(t) for t in report["topics"]), default=0)
    for name, t in report["topics"].items():
        counts = [f"{t['read']} read"] if t["read"] or not t["skipped"] else []
        counts += [f"{t['skipped']} skipped"] if t["skipped"] else []
        lines.append(f"    {name:<{width}}  {', '.join(counts)}")
    if report.get("target"):
        lines.append(f"  target            {target_text(report['target'])}")
    if "first_time" in report:
        lines.append(f"  states            {report['states']} (t = {report['first_time']:.3f} .. "
                     f"{report['last_time']:.3f} s)")
    else:
        lines.append(f"  states            {report['states']}")
    if "metrics_compared" in report:
        lines.append(f"  metrics           {report['metrics_compared']} compared, max |dCQI| = "
                     f"{report['metrics_max_cqi_diff']:.3g}, n_L mismatches "
                     f"{report['metrics_locked_pair_mismatches']}")
    loop = report.get("loop")
    if loop:
        lines.append(f"  closing loop      {loop['true_measurements']} true and "
                     f"{loop['measurements']} sensed measurements, {loop['decisions']} decisions "
                     f"({', '.join(loop['controllers']) or 'none'}); first to close at step "
                     f"{loop['closing_step']}")
        if loop["launch_decisions"]:
            lines.append(f"  launch            {loop['launch_decisions']} decisions "
                         f"({', '.join(loop['launch_controllers'])}); fired at step "
                         f"{loop['launch_step']}")
        lines.append(f"                    sensor replayed on {loop['sensed_recomputed']}: "
                     f"{loop['sensed_mismatches']} mismatches; policy replayed on "
                     f"{loop['decisions_recomputed']}: {loop['decision_mismatches']} mismatches")
    lines.append(f"  recomputed        {_fmt_result(report['recomputed'])}")
    for key, label in (("result", "recorded result"), ("verdict", "monitor verdict")):
        m = report[f"matches_{key}"]
        tag = "" if m is None else ("  -> match" if m else "  -> MISMATCH")
        lines.append(f"  {label:<17} {_fmt_result(report[f'recorded_{key}'])}{tag}")
    tug = report.get("recorded_tug")
    if tug:
        from ..core.tug import outcome_text
        lines.append(f"  tug test          (recorded; not recomputed) {outcome_text(tug)}")
    for p in report["problems"]:
        lines.append(f"  problem           {p}")
    lines.append("  => " + ("replay agrees with the recorded result" if report["ok"]
                           else "replay could not confirm the recorded result"))
    print("\n".join(lines))
    return 0 if report["ok"] else 1
