"""Fidelities (tethernet_ros/core/fidelity.py, issue 33 point 2): the reference changes
nothing, exploration sets the implicit step to 2 ms and 8 sweeps (docs/studies/fidelity.md), their samples
never mix in a results file, and an optimisation may search at exploration but races and
validates at the reference."""
import json
import math

import numpy as np
import pytest

from optimizer.cases import CASE_MASS
from optimizer.run import run_optimization
from optimizer.settings import FIDELITY_PHASES, RunError, RunSettings, SettingError
from optimizer.testproblems import LatentDifficulty
from optimizer_fakes import SyntheticBackend
from script_modules import load_script
from tethernet_ros import cli, montecarlo
from tethernet_ros.commands.common import config_from_args, fidelity_config
from tethernet_ros.core.config import ConfigError, SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS, Design
from tethernet_ros.core.episode import run_episode
from tethernet_ros.core.fidelity import (EXPLORATION, FIDELITIES, REFERENCE, FidelityError,
                                         at_fidelity, check_fidelity)
from tethernet_ros.core.noise import NoiseModel
from tethernet_ros.design_problem import SimulatorProblem, optimize_design
from tethernet_ros.montecarlo import run_key, sample_seed

FAST = {"n_restarts_gp": 0, "n_candidates": 500}


def _outcome(r) -> dict:
    d = r.to_dict()
    d.pop("wall_time", None)
    return d


def _cli_config(*argv):
    args = cli.build_parser().parse_args(list(argv))
    return args, fidelity_config(args, config_from_args(args))


def test_reference_fidelity_is_the_default_bit_for_bit(tmp_path):
    """--fidelity reference (given or not) is the configuration as given: the same object,
    and one short episode's result identical to the default config's."""
    cfg = tmp_path / "short.yaml"
    cfg.write_text("settle_time: 2.0\n")
    base = SimConfig(settle_time=2.0)
    assert at_fidelity(base, REFERENCE) is base
    for argv in (["capture", "--design", "time-min", "--config", str(cfg)],
                 ["capture", "--design", "time-min", "--config", str(cfg),
                  "--fidelity", "reference"],
                 ["validate", "--design", "time-min", "--config", str(cfg),
                  "--fidelity", "reference"]):
        args, config = _cli_config(*argv)
        assert args.fidelity == REFERENCE and config == base, argv
    _, config = _cli_config("capture", "--design", "time-min", "--config", str(cfg),
                            "--fidelity", "reference")
    sample = NoiseModel().sample(5)
    got = run_episode(REFERENCE_DESIGNS["time-min"], sample, config)
    want = run_episode(REFERENCE_DESIGNS["time-min"], sample, SimConfig(settle_time=2.0))
    assert _outcome(got) == _outcome(want)


def test_exploration_sets_the_step_to_2_ms_8_sweeps_and_the_early_call_and_nothing_else():
    base = SimConfig(settle_time=2.0, tumble={"rate_deg_s": 2.0})
    fast = at_fidelity(base, EXPLORATION)
    assert fast.implicit_dt == 0.002 and fast.step_for(1.0) == 0.002
    assert fast.implicit_iterations == 8 and fast.early_call
    assert base.implicit_dt == 0.001 and base.implicit_iterations == 4     # not changed
    assert not base.early_call
    changed = ("implicit_dt", "implicit_iterations", "early_call")
    assert {k: v for k, v in fast.to_dict().items() if k not in changed} == \
        {k: v for k, v in base.to_dict().items() if k not in changed}
    _, config = _cli_config("validate", "--design", "baseline", "--fidelity", "exploration")
    assert config == SimConfig().replace(implicit_dt=0.002, implicit_iterations=8,
                                         early_call=True)
    assert FIDELITIES == (REFERENCE, EXPLORATION)


@pytest.mark.parametrize("config, field", [
    (SimConfig(implicit_dt=5e-4), "'implicit_dt' is 0.0005"),
    (SimConfig(dt=1e-3), "'dt' is 0.001"),
    (SimConfig(implicit_iterations=6), "'implicit_iterations' is 6"),
    (SimConfig(early_call=True), "'early_call' is True"),
    (SimConfig.preset("spec-text"), "'integrator' is 'explicit'"),
    (SimConfig(metric_rate=1000.0), "config field 'implicit_dt': 1/(metric_rate*implicit_dt)"),
])
def test_exploration_refuses_a_config_it_was_not_measured_on(config, field):
    with pytest.raises(FidelityError) as err:
        at_fidelity(config, EXPLORATION, field="--fidelity")
    assert str(err.value).startswith("--fidelity 'exploration': ") and field in str(err.value)
    assert at_fidelity(config, REFERENCE) is config                    # the reference: any


def test_bad_fidelity_names_the_field_and_the_allowed_values(capsys, tmp_path):
    with pytest.raises(FidelityError, match="fidelity: got 'fast'; must be one of "
                                            "'reference', 'exploration'"):
        check_fidelity("fast")
    with pytest.raises(FidelityError, match="--fidelity: got None"):
        at_fidelity(SimConfig(), None, field="--fidelity")
    for command in ("capture", "validate"):
        with pytest.raises(SystemExit):
            cli.build_parser().parse_args([command, "--design", "baseline", "--fidelity", "x"])
        err = capsys.readouterr().err
        assert "--fidelity" in err and "'reference', 'exploration'" in err
    # a conflicting --config: one line naming the flag and the field, exit status 2
    cfg = tmp_path / "half.yaml"
    cfg.write_text("implicit_dt: 0.0005\n")
    for command in ("capture", "validate"):
        assert cli.main([command, "--design", "baseline", "--fidelity", "exploration",
                         "--config", str(cfg)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"tethernet {command}: error: --fidelity " \
            "'exploration': config field 'implicit_dt' is 0.0005" in err, err


def test_run_keys_differ_so_a_results_file_never_mixes_fidelities(tmp_path):
    design, noise = REFERENCE_DESIGNS["baseline"], NoiseModel()
    ref = SimConfig()
    assert run_key(design, noise, ref) != run_key(design, noise, at_fidelity(ref, EXPLORATION))
    assert run_key(design, noise, ref) == run_key(design, noise, at_fidelity(ref, REFERENCE))
    path = tmp_path / "r.jsonl"
    backend = SyntheticBackend()
    a = montecarlo.evaluate(design, 4, 0, noise, ref, backend, results_path=path)
    b = montecarlo.evaluate(design, 4, 0, noise, at_fidelity(ref, EXPLORATION), backend,
                            results_path=path)
    assert a.reused == 0 and b.reused == 0 and a.key != b.key      # nothing reused across
    assert [t.config.implicit_dt for t in backend.tasks] == [0.001] * 4 + [0.002] * 4
    again = montecarlo.evaluate(design, 4, 0, noise, ref, backend, results_path=path)
    assert again.reused == 4 and again.key == a.key and len(backend.tasks) == 8


@pytest.mark.parametrize("fidelity, words", [
    ({"validation": EXPLORATION}, "must keep 'validation' at 'reference'"),
    ({"racing": EXPLORATION}, "must keep 'racing' at 'reference'"),
    ({"initial": EXPLORATION, "racing": EXPLORATION, "validation": EXPLORATION},
     "must keep 'racing' and 'validation' at 'reference'"),
    ({"seed": EXPLORATION}, "must name only the phases 'initial', 'iterations', 'racing', "
                            "'validation' (unknown: 'seed')"),
    ({"initial": 2}, "not for 'initial'"),
    ("exploration", "fidelity: got 'exploration'; must be a mapping of phases"),
])
def test_settings_refuse_racing_and_validation_away_from_the_reference(fidelity, words):
    with pytest.raises(SettingError) as err:
        RunSettings(fidelity=fidelity)
    assert err.value.field == "fidelity" and words in str(err.value)


def test_settings_fidelity_defaults_to_the_reference_and_is_recorded():
    s = RunSettings(fidelity={"initial": EXPLORATION})
    assert dict(s.fidelity) == {"initial": EXPLORATION, "iterations": REFERENCE,
                                "racing": REFERENCE, "validation": REFERENCE}
    assert tuple(s.fidelity) == FIDELITY_PHASES
    assert RunSettings() == RunSettings(fidelity={p: REFERENCE for p in FIDELITY_PHASES})
    rec = RunSettings().resolved(None, CASE_MASS).record("mass", {})
    assert rec["fidelity"] == {p: REFERENCE for p in FIDELITY_PHASES}
    from tethernet_ros.commands.optimize import run_settings

    args = cli.build_parser().parse_args(["optimize", "--case", "mass"])
    assert run_settings(args) == RunSettings() and args.explore_fidelity == REFERENCE
    args = cli.build_parser().parse_args(["optimize", "--case", "mass",
                                          "--explore-fidelity", "exploration"])
    assert dict(run_settings(args).fidelity) == {"initial": EXPLORATION,
                                                 "iterations": EXPLORATION,
                                                 "racing": REFERENCE, "validation": REFERENCE}


class _ReferenceOnly(LatentDifficulty):
    fidelities = ()


def test_a_problem_without_fidelities_refuses_exploration(tmp_path):
    with pytest.raises(SettingError, match="map phase 'initial' to one of the problem's "
                                           "fidelities: 'reference'"):
        run_optimization("mass", _ReferenceOnly(), run_dir=tmp_path / "r", seed_points=2,
                         iterations=0, samples=5, validation_samples=0,
                         fidelity={"initial": EXPLORATION})
    assert not (tmp_path / "r").exists()
    # a config exploration cannot apply to is refused before the run starts
    problem = SimulatorProblem(SyntheticBackend(), SimConfig(implicit_dt=5e-4))
    with pytest.raises(RunError, match="'implicit_dt' is 0.0005"):
        run_optimization("mass", problem, run_dir=tmp_path / "s", seed_points=2,
                         iterations=0, samples=5, validation_samples=0,
                         fidelity={"iterations": EXPLORATION})
    assert not (tmp_path / "s").exists()


def _records(path):
    lines = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    return [r for r in lines if "key" in r and "index" in r]


def test_optimisation_explores_by_phase_and_races_and_validates_at_the_reference(tmp_path):
    """Seed points at exploration, iterations at the reference: each evaluation's samples
    ran at its phase's step and record their fidelity; the race and the validations ran
    at 1 ms on keys of the reference config, none an exploration sample; a resume under
    another fidelity setting is refused."""
    backend = SyntheticBackend()
    config = SimConfig.preset("reference")
    run_dir = tmp_path / "run"
    kw = dict(seed_points=4, iterations=2, samples=20, validation_samples=200,
              validation_candidates=2, racing_candidates=2, racing_round=100,
              racing_budget=400, optimizer_options=FAST, fidelity={"initial": EXPLORATION})
    summary = optimize_design("mass", backend=backend, run_dir=run_dir, config=config, **kw)
    state = json.loads((run_dir / "checkpoint.json").read_text())["optimizer"]
    history = state["history"]
    assert [o["info"]["fidelity"] for o in history] == [EXPLORATION] * 4 + [REFERENCE] * 2
    assert [o["acquisition"]["phase"] == "initial" for o in history] == [True] * 4 + [False] * 2
    lines = (run_dir / "history.csv").read_text().splitlines()
    head = lines[0].split(",")
    assert head[-2:] == ["fidelity", "wall_time"]
    assert [line.split(",")[-2] for line in lines[1:]] == [EXPLORATION] * 4 + [REFERENCE] * 2
    assert json.loads((run_dir / "run.json").read_text())["fidelity"] == {
        "initial": EXPLORATION, "iterations": REFERENCE, "racing": REFERENCE,
        "validation": REFERENCE}
    assert summary["fidelity"]["initial"] == EXPLORATION
    assert "Fidelity: seed points at exploration" in (run_dir / "results.md").read_text()

    # the step each episode ran at, by the base seed of its samples
    fresh = {int(o["info"]["base_seed"]): o["info"]["fidelity"] for o in history}
    racing = {sample_seed(2, i) for i in range(400)}
    validation = {sample_seed(0, i) for i in range(200)}
    steps = {"optimisation": set(), "racing": set(), "validation": set()}
    for t in backend.tasks:
        if t.seed in racing:
            steps["racing"].add(t.config.implicit_dt)
        elif t.seed in validation:
            steps["validation"].add(t.config.implicit_dt)
        else:
            base = t.seed // montecarlo.SEED_STRIDE
            want = 0.002 if fresh[base] == EXPLORATION else 0.001
            assert t.config.implicit_dt == want, (t.seed, fresh[base])
            steps["optimisation"].add(t.config.implicit_dt)
    assert steps == {"optimisation": {0.001, 0.002}, "racing": {0.001}, "validation": {0.001}}
    assert summary["episodes_racing"] > 0 and summary["validation"] is not None

    # racing and validation samples carry the reference config's keys, never an
    # exploration sample's
    explored = {o["info"]["key"] for o in history if o["info"]["fidelity"] == EXPLORATION}
    for name in ("racing.jsonl", "validation.jsonl"):
        recs = _records(run_dir / name)
        assert recs and not {r["key"] for r in recs} & explored, name
    raced = [history[e["evaluation"] - 1] for e in summary["racing"]["entries"]]
    ref_keys = {run_key(Design.from_vector(np.array(o["x"])), NoiseModel(), config)
                for o in raced}
    assert {r["key"] for r in _records(run_dir / "racing.jsonl")} == ref_keys

    # a resume must ask for the same fidelities
    with pytest.raises(RunError, match="cannot resume: setting 'fidelity'"):
        optimize_design("mass", backend=backend, run_dir=run_dir, config=config, resume=True,
                        **{**kw, "fidelity": {}})


def test_a_run_at_the_reference_writes_what_it_always_did_and_resumes_old_run_dirs(tmp_path):
    """No fidelity column in a reference run's history.csv; a run.json from before the
    setting resumes as a reference run and refuses exploration."""
    kw = dict(seed_points=3, iterations=0, samples=5, validation_samples=0,
              racing_candidates=0, optimizer_options=FAST)
    run_dir = tmp_path / "r"
    optimize_design("mass", backend=SyntheticBackend(), run_dir=run_dir, **kw)
    head = (run_dir / "history.csv").read_text().splitlines()[0].split(",")
    assert "fidelity" not in head and head[-1] == "wall_time"
    record = json.loads((run_dir / "run.json").read_text())
    del record["fidelity"]
    (run_dir / "run.json").write_text(json.dumps(record))
    optimize_design("mass", backend=SyntheticBackend(), run_dir=run_dir, resume=True, **kw)
    with pytest.raises(RunError, match="cannot resume: setting 'fidelity'"):
        optimize_design("mass", backend=SyntheticBackend(), run_dir=run_dir, resume=True,
                        **{**kw, "fidelity": {"iterations": EXPLORATION}})


def test_early_verdict_reads_the_rule_at_the_trace_sample_nearest_closing_plus_s():
    """scripts/early_verdict.py (docs/studies/fidelity.md, "An earlier verdict"): the
    success rule on the trace sample nearest closing + s; the pairs that lock late and a
    CQI that falls late make an early verdict a lost capture, counted against the
    settle time's verdict."""
    from tethernet_ros.montecarlo.records import SampleResult

    ev = load_script("early_verdict")
    times = [round(0.1 * k, 1) for k in range(260)]           # 0-25.9 s at 10 Hz

    def sample(seed, cqi, pairs, success, closing=5.03, category=""):
        return SampleResult(key="k", index=seed, seed=seed, success=success,
                            settled_cqi=cqi(25.03), locked_pairs=pairs(25.03),
                            closing_time=closing, completion_time=closing + 20.0, mass=1.0,
                            failure_reason="", category=category,
                            trace={"time": times, "cqi": [cqi(t) for t in times],
                                   "locked_pairs": [pairs(t) for t in times]})

    cfg = SimConfig()
    late_pairs = sample(1, lambda t: 0.5, lambda t: 9 if t < 16.0 else 11, True)
    slow_cqi = sample(2, lambda t: 3.0 if t < 19.0 else 1.5, lambda t: 12, True)
    settled = sample(3, lambda t: 0.4, lambda t: 12, True)
    never = sample(4, lambda t: 6.0, lambda t: 0, False, closing=math.nan)
    assert [ev.verdict_at(late_pairs, s, cfg) for s in (8.0, 10.0, 12.0)] == [False, False, True]
    assert [ev.verdict_at(slow_cqi, s, cfg) for s in (8.0, 12.0, 15.0)] == [False, False, True]
    assert ev.verdict_at(settled, 6.0, cfg) and not ev.verdict_at(never, 6.0, cfg)
    truth = {s.seed: s for s in (late_pairs, slow_cqi, settled, never)}
    assert ev.compare(truth, truth, 8.0, cfg)[:3] == (4, 2, 0)
    assert ev.compare(truth, truth, 15.0, cfg)[:3] == (4, 0, 0)
    with pytest.raises(ValueError, match="no trace sample within"):
        ev.verdict_at(settled, 30.0, cfg)


def _verdict_fields(r) -> tuple:
    return (r.success, r.settled_cqi, r.locked_pairs, r.closing_time, r.steps,
            r.failure_reason, r.settled_terms)


def test_the_early_call_reads_a_clear_success_at_half_the_settle_time():
    """early_call (config.py, docs/model.md §7): at half the settle time a capture inside
    half the CQI bound with every pair locked is read as settled, bit for bit what a run
    with that shorter settle time reads, and the episode ends; T still counts the whole
    settle time, bit for bit the full run's.  A capture that is not clear there settles on
    to the full settle time, the same as without the call."""
    design, sample = REFERENCE_DESIGNS["time-min"], NoiseModel().sample(3)
    full = run_episode(design, sample, SimConfig(settle_time=8.0), record_trace=False)
    early = run_episode(design, sample, SimConfig(settle_time=8.0, early_call=True),
                        record_trace=False)
    half = run_episode(design, sample, SimConfig(settle_time=4.0), record_trace=False)
    assert early.settled_cqi <= 1.0 and early.locked_pairs == 12       # clear: called
    assert _verdict_fields(early) == _verdict_fields(half) and early.steps < full.steps
    assert early.completion_time == full.completion_time and early.success
    # not clear (half the bound is below any CQI): the full settle, as without the call
    strict = dict(settle_time=8.0, success_cqi=0.01)
    want = run_episode(design, sample, SimConfig(**strict), record_trace=False)
    got = run_episode(design, sample, SimConfig(**strict, early_call=True), record_trace=False)
    assert _verdict_fields(got) == _verdict_fields(want) and got.completion_time == \
        want.completion_time and not got.success


def test_the_early_call_is_refused_with_the_tug_and_through_ros():
    from tethernet_ros.ros.parameters import sim_config_of

    with pytest.raises(ConfigError, match="config field 'early_call': got 1; must be true"):
        SimConfig(early_call=1)
    with pytest.raises(ConfigError, match="config field 'early_call': the tug test starts"):
        SimConfig.from_dict({"early_call": True, "tether_order": "chain",
                             "tug": {"enabled": True, "peak_tension": 400.0}})
    with pytest.raises(ConfigError, match="sim_config: field 'early_call' is not supported "
                                          "through ROS"):
        sim_config_of({"sim_config": '{"early_call": true}', "settle_time": 20.0,
                       "horizon": 120.0})
    assert not sim_config_of({"sim_config": "{}", "settle_time": 20.0,
                              "horizon": 120.0}).early_call


def test_an_optimisation_refuses_the_early_call_in_its_configuration(tmp_path):
    """Racing and validation read the settled state: a configuration with early_call is
    refused before the run starts (a fidelity may use it for the search)."""
    with pytest.raises(ConfigError, match="config field 'early_call': an optimisation races"):
        optimize_design("mass", backend=SyntheticBackend(), run_dir=tmp_path / "r",
                        config=SimConfig(early_call=True), seed_points=2, iterations=0,
                        samples=5, validation_samples=0)
    assert not (tmp_path / "r").exists()


def test_sampler_wall_replays_the_samplers_batches_on_the_records():
    """scripts/sampler_wall.py (docs/cases/README.md, Case 2 at exploration): a batch's
    groups go to the first free worker and last their CPU sums; a design is replayed
    batch by batch to the case rule's decision, the samples past it counted."""
    from types import SimpleNamespace

    from optimizer.cases import CASE_MASS

    sw = load_script("sampler_wall")
    # 8 tasks on 2 workers: two groups of 4, the longer one sets the wall
    assert sw.batch_wall([1.0] * 4 + [2.0] * 4, 2) == 8.0
    assert sw.batch_wall([3.0], 2) == 3.0
    backend = SimpleNamespace(batch_size=8, max_batch_size=16)
    rule = CASE_MASS.sequential_rule(100)
    fails = {2, 3, 5}                                # the third failure decides at 6
    cpu = {i: 1.0 for i in range(8)}
    ok = {i: i not in fails for i in range(8)}
    wall, drawn, used, drawn_cpu = sw.replay(cpu, ok, rule, backend, 2, 100, 9.0)
    assert (drawn, used, wall, drawn_cpu) == (8, 6, 4.0, 8.0)
    # a success at every sample: Case 1 decides feasible at 98 (two failures could not
    # undo it); each batch of equal costs splits evenly over the two workers
    wall, drawn, used, drawn_cpu = sw.replay({}, {}, rule, backend, 2, 100, 1.0)
    assert used == 98 and 98 <= drawn <= 100 and drawn_cpu == drawn
    assert drawn / 2 <= wall <= drawn / 2 + 1
