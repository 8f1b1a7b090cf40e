"""The run settings (optimizer/settings.py): one home for the defaults, every field checked
with an error naming the field and its allowed range, the "as recorded" settings of a
resumed run, and the command line built on them."""
import dataclasses

import pytest

from optimizer.cases import CASE_MASS, CASE_TIME
from optimizer.run import run_optimization
from optimizer.settings import (NEW_RUN_DEFAULTS, RECORDED_DEFAULTS, RunError, RunSettings,
                                SettingError)
from tethernet_ros import cli


@pytest.mark.parametrize("name, value, message", [
    ("iterations", -1, "iterations: got -1; must be an integer >= 0"),
    ("seed_points", 0, "seed_points: got 0; must be an integer >= 1"),
    ("samples", 2.5, "samples: got 2.5; must be an integer >= 1"),
    ("validation_samples", True, "validation_samples: got True; must be an integer >= 0"),
    ("seed", -3, "seed: got -3; must be an integer >= 0"),
    ("sample_seed", "1", "sample_seed: got '1'; must be an integer >= 0"),
    ("validation_seed", 1, "validation_seed: got 1; must differ from sample_seed"),
    ("validation_candidates", 0, "validation_candidates: got 0; must be an integer >= 1"),
    ("validation_rule", "lower", "validation_rule: got 'lower'; must be one of estimate, wilson"),
    ("validation_stop", "yes", "validation_stop: got 'yes'; must be True or False"),
    ("sequential", 1, "sequential: got 1; must be True or False"),
    ("compare_reference", None, "compare_reference: got None; must be True or False"),
    ("min_probability", 1.5, "min_probability: got 1.5; must be None or a number in [0, 1]"),
    ("min_probability", float("nan"), "min_probability: got nan; must be None or a number"),
    ("optimizer_options", [1], "optimizer_options: got [1]; must be a mapping"),
    ("optimizer_options", {"seed": 3}, "must not set ['seed']"),
    ("sample_seed", 1_000_000, "sample_seed: got 1000000; must be an integer >= 0 and <= 999999"),
    ("fresh_samples", 0, "fresh_samples: got 0; must be True or False"),
    ("racing_candidates", -1, "racing_candidates: got -1; must be an integer >= 0"),
    ("racing_round", 0, "racing_round: got 0; must be an integer >= 1"),
    ("racing_budget", -5, "racing_budget: got -5; must be an integer >= 0"),
    ("racing_seed", 0, "racing_seed: got 0; must differ from sample_seed and validation_seed"),
    ("racing_seed", 1, "racing_seed: got 1; must differ from sample_seed and validation_seed"),
    ("racing_max_samples", -1, "racing_max_samples: got -1; must be an integer >= 0"),
    ("fidelity", {"validation": "exploration"},
     "fidelity: got {'validation': 'exploration'}; must keep 'validation' at 'reference'"),
    ("fidelity", ["exploration"], "fidelity: got ['exploration']; must be a mapping of phases"),
])
def test_every_field_is_checked(name, value, message):
    with pytest.raises(SettingError) as err:
        RunSettings(**{name: value})
    assert err.value.field == name and message in str(err.value)
    assert isinstance(err.value, RunError) and isinstance(err.value, ValueError)


def test_settings_are_frozen_and_normalised():
    s = RunSettings(min_probability=1, optimizer_options={"n_candidates": 10})
    assert s.min_probability == 1.0 and isinstance(s.min_probability, float)
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.samples = 3
    with pytest.raises(TypeError):
        s.optimizer_options["n_candidates"] = 11
    assert s.replace(samples=7).samples == 7 and s.samples == 100
    with pytest.raises(SettingError, match="samples"):
        s.replace(samples=0)
    # no validation: the validation seed may equal the optimisation's; no racing: the
    # racing seed may equal either
    assert RunSettings(validation_samples=0, validation_seed=1).validation_seed == 1
    assert RunSettings(racing_candidates=0, racing_seed=0).racing_seed == 0


def test_as_recorded_settings_resolve_for_new_and_resumed_runs():
    s = RunSettings()
    assert all(getattr(s, name) is None for name in NEW_RUN_DEFAULTS)
    with pytest.raises(ValueError, match="resolved"):
        s.record("mass", {})
    new = s.resolved(None, CASE_MASS)
    assert {n: getattr(new, n) for n in NEW_RUN_DEFAULTS} == {
        n: v(CASE_MASS) if callable(v) else v for n, v in NEW_RUN_DEFAULTS.items()}
    assert new.fresh_samples is True                   # Case 1: exact objective
    time_run = s.resolved(None, CASE_TIME)             # Case 2: mean T compared on CRN
    assert time_run.fresh_samples is False and time_run.shared_luck is True
    with pytest.raises(ValueError, match="needs its case"):
        s.resolved(None)
    old = s.resolved({})                 # a run.json from before the settings existed
    assert {n: getattr(old, n) for n in NEW_RUN_DEFAULTS} == {
        n: RECORDED_DEFAULTS[n] for n in NEW_RUN_DEFAULTS}
    flipped = {n: not v if isinstance(v, bool) else v for n, v in new.record('mass', {}).items()
               if n in NEW_RUN_DEFAULTS}
    assert s.resolved(flipped) == s.replace(**flipped)
    explicit = RunSettings(validation_stop=False)
    assert explicit.resolved(None, CASE_MASS).validation_stop is False
    rec = new.record("mass", {"model_version": "m"})
    assert rec["case"] == "mass" and rec["model_version"] == "m"
    assert set(RunSettings.field_names()) <= set(rec)


def test_run_refuses_unknown_settings():
    with pytest.raises(TypeError, match="unknown settings \\['sample'\\]"):
        run_optimization("mass", problem=None, sample=3)


def test_command_line_defaults_are_the_settings_defaults():
    parser = cli.build_parser()
    args = parser.parse_args(["optimize", "--case", "mass"])
    from tethernet_ros.commands.optimize import run_settings

    assert run_settings(args) == RunSettings()
    for name in ("iterations", "seed_points", "samples", "validation_samples", "seed",
                 "sample_seed", "validation_seed", "validation_candidates",
                 "validation_rule", "validation_stop"):
        assert getattr(args, name) == getattr(RunSettings(), name), name


def test_run_directory_records_the_machine_and_a_resume_elsewhere_says_so(tmp_path):
    """run.json records the machine facts that decide comparability (issue 18 point 3);
    resuming where they differ warns in one line naming the differing facts, continues,
    keeps the first machine's facts and adds the new ones to ``resumed_on``."""
    import json
    import warnings

    from optimizer_fakes import SyntheticBackend
    from tethernet_ros import machine
    from tethernet_ros.design_problem import optimize_design

    kw = dict(iterations=1, seed_points=3, samples=3, validation_samples=0,
              racing_candidates=0, optimizer_options={"n_restarts_gp": 0,
                                                      "n_candidates": 500})
    run_dir = tmp_path / "r"
    optimize_design("mass", backend=SyntheticBackend(), run_dir=run_dir, **kw)
    record = json.loads((run_dir / "run.json").read_text())
    here = record["machine"]
    assert {k: here[k] for k in ("cpu_features", "blas", "numpy", "numba")} == {
        k: machine.machine_facts()[k] for k in ("cpu_features", "blas", "numpy", "numba")}
    assert here["scikit-learn"] and here["scikit-optimize"]
    with warnings.catch_warnings():                      # same machine: nothing said
        warnings.simplefilter("error")
        optimize_design("mass", backend=SyntheticBackend(), run_dir=run_dir, resume=True,
                        **{**kw, "iterations": 2})
    other = {**here, "numpy": "0.0", "cpu_features": "SSE"}
    (run_dir / "run.json").write_text(json.dumps({**record, "machine": other}))
    with pytest.warns(RuntimeWarning) as got:
        optimize_design("mass", backend=SyntheticBackend(), run_dir=run_dir, resume=True,
                        **{**kw, "iterations": 3})
    [line] = [str(w.message) for w in got if "machine" in str(w.message)]
    assert "\n" not in line and "numpy: '0.0'" in line and "cpu_features" in line
    assert "blas" not in line
    after = json.loads((run_dir / "run.json").read_text())
    assert after["machine"] == other and after["resumed_on"] == [here]
