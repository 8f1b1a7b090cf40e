"""The ROS episode backend (tethernet_ros.ros.backend): Monte Carlo samples run through the
suite's RunCapture service, results read back from the recorded MCAP bags.

Same per-sample results as the in-process backend for the same seeds (short scenario,
settle time 2 s); one suite serves a whole evaluation; two suites side by side (each in
its own ROS domain) give them too; a damaged bag is refused; and `tethernet optimize --via
ros` runs a tiny optimisation through the suite.  About a minute.
"""
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("rclpy", reason="ROS 2 wheels not installed: run scripts/setup.sh")

from tethernet_ros.bags import copy_truncated  # noqa: E402
from tethernet_ros.core.config import SimConfig  # noqa: E402
from tethernet_ros.core.design import REFERENCE_DESIGNS  # noqa: E402
from tethernet_ros.montecarlo import InProcessBackend, evaluate  # noqa: E402
from tethernet_ros.ros.backend import BagResultError, RosBackend, result_from_bag  # noqa: E402

pytestmark = [pytest.mark.ros, pytest.mark.timeout(600)]

ROOT = Path(__file__).resolve().parent.parent
CONFIG = SimConfig(settle_time=2.0)
DESIGN = REFERENCE_DESIGNS["time-min"]
FIELDS = ("key", "seed", "success", "settled_cqi", "locked_pairs", "closing_time",
          "completion_time", "mass", "failure_reason", "category")


def same(a, b):
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def test_ros_backend_equals_in_process(tmp_path):
    ref = evaluate(DESIGN, 2, 7, config=CONFIG, backend=InProcessBackend())
    bag_dir = tmp_path / "bags"
    with RosBackend(bag_dir=bag_dir, log_dir=tmp_path / "logs") as be:
        got = evaluate(DESIGN, 2, 7, config=CONFIG, backend=be)
        assert be.suite_starts == 1 and be.episodes == 2
    for a, b in zip(ref.samples, got.samples):
        for f in FIELDS:                                   # bit for bit
            assert same(getattr(a, f), getattr(b, f)), (f, getattr(a, f), getattr(b, f))
    assert (got.successes, got.p_success, got.mean_completion_time) == \
        (ref.successes, ref.p_success, ref.mean_completion_time)
    assert list(bag_dir.iterdir()) == []                  # bags read, then removed


def test_controller_identity_follows_its_source(tmp_path, monkeypatch):
    """A user's controller enters the run key with its source's hash: editing it starts new
    samples in a resumed results file (tests/test_montecarlo.py checks the reuse)."""
    from tethernet_ros.ros.suite import controller_identity

    (tmp_path / "my_ctl.py").write_text("class Ctl:\n    pass\n")
    monkeypatch.setenv("PYTHONPATH", str(tmp_path))
    before = RosBackend(bag_dir=tmp_path, controller="my_ctl:Ctl").episode_source
    assert before.startswith("my_ctl:Ctl sha256:")
    assert controller_identity("my_ctl:Ctl") == before
    (tmp_path / "my_ctl.py").write_text("class Ctl:\n    pass  # edited\n")
    assert controller_identity("my_ctl:Ctl") not in (before, "my_ctl:Ctl")
    with pytest.warns(UserWarning, match="no source file found"):
        assert controller_identity("no_such_module_here:Ctl") == "no_such_module_here:Ctl"
    assert RosBackend(bag_dir=tmp_path).episode_source is None
    assert RosBackend(bag_dir=tmp_path, lockstep=True).episode_source is None


def test_two_suites_side_by_side_equal_in_process(tmp_path):
    """RosBackend(workers=2): two suites in domains of their own, a sample each as they
    free up; a tumbling target (a transverse axis drawn per sample) through the actuator's
    LaunchCommand: the in-process results, sample for sample."""
    from tethernet_ros.core.tumble import TumbleConfig

    cfg = CONFIG.replace(tumble=TumbleConfig(rate_deg_s=3.0, axis="transverse"))
    ref = evaluate(DESIGN, 4, 9, config=cfg, backend=InProcessBackend())
    with RosBackend(workers=2, log_dir=tmp_path / "logs") as be:
        got = evaluate(DESIGN, 4, 9, config=cfg, backend=be)
        assert be.suite_starts == 2 and be.episodes == 4
        assert "x 2 (domains" in be.describe()
    for a, b in zip(ref.samples, got.samples):
        for f in FIELDS:                                   # bit for bit
            assert same(getattr(a, f), getattr(b, f)), (f, getattr(a, f), getattr(b, f))


def test_ros_backend_kept_bag_and_damaged_bag(tmp_path):
    bag_dir = tmp_path / "bags"
    with RosBackend(bag_dir=bag_dir, keep_bags=True, log_dir=tmp_path / "logs") as be:
        got = evaluate(DESIGN, 1, 3, config=CONFIG, backend=be, record_trace=True)
    ref = evaluate(DESIGN, 1, 3, config=CONFIG, backend=InProcessBackend(), record_trace=True)
    (bag,) = list(bag_dir.iterdir())
    msg, metrics = result_from_bag(bag, bag.name, with_metrics=True)
    s = got.samples[0]
    assert msg.settled_cqi == s.settled_cqi == ref.samples[0].settled_cqi
    assert s.trace["time"][-1] == ref.samples[0].completion_time
    assert s.trace["cqi"][-1] == ref.samples[0].settled_cqi
    bad = copy_truncated(bag, tmp_path / "truncated", 0.5)
    with pytest.raises(BagResultError, match="incomplete or damaged"):
        result_from_bag(bad, bag.name)
    with pytest.raises(BagResultError, match="expected 1"):
        result_from_bag(bag, "another_episode")


def test_cli_optimize_via_ros(tmp_path):
    cfg = tmp_path / "short.yaml"
    cfg.write_text("settle_time: 2.0\nhorizon: 15.0\n")
    out = subprocess.run(
        [sys.executable, "-m", "tethernet_ros.cli", "optimize", "--case", "time", "--via", "ros",
         "--seed-points", "2", "--iterations", "0", "--samples", "1", "--validation-samples", "1",
         "--validation-rule", "estimate",        # (Wilson, the default, needs >= 189 samples)
         "--workers", "2", "--node-param", "capture_node.stall_timeout=60",   # 2 suites
         "--config", str(cfg), "--run-dir", str(tmp_path / "run"), "--keep-bags", "--json",
         "--gp-restarts", "0"],
        capture_output=True, text=True, cwd=ROOT, timeout=500)
    assert out.returncode == 0, out.stderr[-3000:]
    d = json.loads(out.stdout)
    assert d["evaluations"] == 2 and "ROS 2 suite x 2" in d["backend"]
    # a bag per episode: the evaluations', and those of racing and validation (if any)
    episodes = d.get("episodes_total", 2 + (1 if d["best_design"] else 0))
    assert len(list((tmp_path / "run" / "bags").iterdir())) == episodes
