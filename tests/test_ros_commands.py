"""The commands' scenario options (issue 19): the target's tumble, the sensing and the
closing policy from the command line, a design file's ``tumble:`` mapping and --config,
in that order of precedence (commands/common.py, the one home of these arguments); bad
values refused with exit status 2 and one line naming the flag, the field and its range;
and the options of a controller through the ROS suite, refused without --via ros.  No ROS
needed: these are what reach the RunCapture request and the nodes' configuration.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import pytest

from tethernet_ros.commands.common import (add_config_argument, add_design_argument,
                                           config_from_args, controller_config,
                                           controller_label, read_design_file)
from tethernet_ros.core.config import ConfigError, SimConfig
from tethernet_ros.core.design import Design, DesignError, load_design
from tethernet_ros.core.episode import run_episode
from tethernet_ros.core.launch import LaunchConfig
from tethernet_ros.core.noise import NoiseModel
from tethernet_ros.core.policies import PolicyConfig
from tethernet_ros.core.sensing import SensingConfig
from tethernet_ros.core.tumble import TumbleConfig

ROOT = Path(__file__).resolve().parent.parent
TIME_MIN = ("m_c: 2.0478\nL_n: 19.8437\nr_n: 0.00104\nd_L: 16.1416\n"
            "V_e: [4.0237, 2.6035, 8.8838]\nd_c: 2.2589\n")


def parse(*argv):
    p = argparse.ArgumentParser()
    add_design_argument(p)
    add_config_argument(p)
    return p.parse_args(list(argv))


def cli(*argv, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "tethernet_ros.cli", *argv],
                          capture_output=True, text=True, cwd=cwd, timeout=300)


def test_flags_set_the_nested_settings_over_the_config_file_and_the_design_file(tmp_path):
    config = tmp_path / "sim.yaml"
    config.write_text("settle_time: 3.0\ntumble: {rate_deg_s: 1.0, axis: long, phase_deg: 5}\n"
                      "sensing: {rate_hz: 10.0, sigma_position: 0.1}\n")
    design = tmp_path / "d.yaml"
    design.write_text(TIME_MIN + "tumble: {rate_deg_s: 2.0, axis: [0, 1, 1]}\n"
                      "launch: {kind: predictive, max_tilt_deg: 15, max_wait: 100}\n")
    args = parse("--design", str(design), "--config", str(config), "--tumble-axis", "los",
                 "--sensing-rate", "50", "--latency", "0.04", "--policy", "adaptive",
                 "--net-point", "corners", "--launch-max-wait", "50")
    cfg = config_from_args(args)
    assert cfg.settle_time == 3.0
    # the design file's rate over the config file's; the flag's axis over both; the phase
    # of the config file where neither says
    assert cfg.tumble == TumbleConfig(rate_deg_s=2.0, axis="los", phase_deg=5.0)
    assert cfg.sensing == SensingConfig(rate_hz=50.0, latency=0.04, sigma_position=0.1,
                                        net_point="corners")
    assert cfg.policy.kind == "adaptive"
    # the design file's launch settings, the flag's max_wait over the file's
    assert cfg.launch == LaunchConfig(kind="predictive", max_tilt_deg=15.0, max_wait=50.0)
    assert read_design_file(str(design)) == (
        Design.from_dict(dict(m_c=2.0478, L_n=19.8437, r_n=0.00104, d_L=16.1416,
                              V_e=[4.0237, 2.6035, 8.8838], d_c=2.2589)),
        {"tumble": {"rate_deg_s": 2.0, "axis": [0, 1, 1]},
         "launch": {"kind": "predictive", "max_tilt_deg": 15, "max_wait": 100}})
    assert load_design(str(design)) == read_design_file(str(design))[0]   # the scenario aside
    # a vector axis; nothing given: the defaults (a target at rest, ideal sensing, threshold)
    assert config_from_args(parse("--design", "time-min", "--tumble-axis", "1,0,2",
                                  "--tumble-rate", "3")).tumble.axis == (1.0, 0.0, 2.0)
    assert config_from_args(parse("--design", "time-min")) == SimConfig()
    # a controller of one's own: the policy 'external' (its results are not the built-in's)
    ns = argparse.Namespace(controller="pkg.mod:MyPolicy")
    assert controller_config(ns, SimConfig()).policy == PolicyConfig(kind="external")
    assert controller_label(ns) == "_ctl-MyPolicy"
    assert controller_label(argparse.Namespace(controller=None)) == ""


@pytest.mark.parametrize("argv, line", [
    (["--tumble-rate", "61"], "--tumble-rate: tumble field 'rate_deg_s': got 61.0; must be a "
                              "rate in [0, 60] deg/s"),
    (["--tumble-rate", "-1"], "--tumble-rate: tumble field 'rate_deg_s': got -1.0; must be a "
                              "rate in [0, 60] deg/s"),
    (["--tumble-axis", "0,0,0"], "--tumble-axis: tumble field 'axis': got the zero vector; "
                                 "must have a direction"),
    (["--tumble-axis", "up"], "--tumble-axis 'up': must be one of flat, los, long, transverse "
                              "or three numbers X,Y,Z"),
    (["--sensing-rate", "2000"], "--sensing-rate: sensing field 'rate_hz': got 2000.0; must be "
                                 "a rate in [0, 1000] Hz"),
    (["--latency", "9"], "--latency: sensing field 'latency': got 9.0; must be a latency in "
                         "[0, 5] s"),
    (["--controller", "example_controller"], "--controller needs --via ros"),
    (["--lockstep"], "--lockstep needs --via ros"),
    (["--node-param", "sim_node.decision_timeout=20"], "--node-param needs --via ros"),
    (["--via", "ros", "--node-param", "sim_node.decision_timeout=-1"],
     "--node-param sim_node.decision_timeout: got -1.0; must be a number in [0.01, 3600] s"),
    (["--via", "ros", "--node-param", "sim_node.warm_up=yes"],
     "--node-param sim_node.warm_up: got 'yes'; must be true or false"),
    (["--via", "ros", "--node-param", "sim_node.decision_time=20"],
     "--node-param 'sim_node.decision_time=20': sim_node has no parameter 'decision_time'"),
    (["--via", "ros", "--node-param", "capture_node.settle_time=3"],
     "--node-param capture_node.settle_time: set by the command itself"),
])
def test_bad_values_name_the_flag_field_and_range(argv, line):
    out = cli("capture", "--design", "time-min", *argv)
    assert out.returncode == 2 and out.stdout == ""
    (err,) = out.stderr.strip().splitlines()
    assert err.startswith("tethernet capture: error: " + line), err


def test_bad_design_file_tumble_names_the_file(tmp_path):
    design = tmp_path / "d.yaml"
    design.write_text(TIME_MIN + "tumble: {rate_deg_s: 75}\n")
    out = cli("capture", "--design", str(design))
    assert out.returncode == 2
    assert f"--design {design} (tumble:): tumble field 'rate_deg_s': got 75" in out.stderr
    design.write_text(TIME_MIN + "tumble: {spin: 1}\n")
    with pytest.raises(ConfigError, match=r"config field 'tumble\.spin': unknown"):
        config_from_args(parse("--design", str(design)))
    design.write_text(TIME_MIN + "tumble: fast\n")
    out = cli("capture", "--design", str(design))
    assert out.returncode == 2 and "tumble" in out.stderr and "must be a mapping" in out.stderr


def test_bad_design_file_launch_names_the_file_field_and_range(tmp_path):
    design = tmp_path / "d.yaml"
    design.write_text(TIME_MIN + "launch: {max_tilt_deg: 120}\n")
    with pytest.raises(ConfigError, match=r"^--design .*d\.yaml \(launch:\): launch field "
                                          r"'max_tilt_deg': got 120.*\[0\.1, 90\]"):
        config_from_args(parse("--design", str(design)))
    design.write_text(TIME_MIN + "launch: 15\n")
    with pytest.raises(DesignError, match="launch.*must be a mapping of launch fields"):
        config_from_args(parse("--design", str(design)))


def test_capture_of_a_tumbling_target_from_the_command_line(tmp_path):
    """`tethernet capture` with the scenario flags gives run_episode of that configuration
    (the same path `--via ros` hands to the suite)."""
    design = tmp_path / "d.yaml"
    design.write_text(TIME_MIN + "tumble: {rate_deg_s: 5.0, axis: flat, phase_deg: 20}\n")
    out = cli("capture", "--design", str(design), "--seed", "4", "--json", "--sensing-rate",
              "50", "--policy", "adaptive", "--tumble-axis", "transverse",
              "--config", str(_short(tmp_path)))
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout)
    cfg = SimConfig(settle_time=2.0, tumble=TumbleConfig(rate_deg_s=5.0, axis="transverse",
                                                         phase_deg=20.0),
                    sensing=SensingConfig(rate_hz=50.0), policy=PolicyConfig(kind="adaptive"))
    ref = run_episode(read_design_file(str(design))[0], NoiseModel().sample(4), cfg,
                      record_trace=False)
    assert (got["settled_cqi"], got["closing_time"], got["completion_time"]) == \
        (ref.settled_cqi, ref.closing_time, ref.completion_time)


def _short(tmp_path: Path) -> Path:
    p = tmp_path / "short.yaml"
    p.write_text("settle_time: 2.0\n")
    return p


def test_a_request_naming_a_target_keeps_the_configured_attitude():
    """A RunCapture request that names a target keeps the configured target's
    attitude_deg, as `--target NAME` over a config file does (issue 54: it was dropped);
    its mass and mesh are the named target's.  The request's criterion and acceleration
    are refused naming the field."""
    from types import SimpleNamespace

    from tethernet_ros.core.target import TargetConfig
    from tethernet_ros.ros.conversions import RequestError, config_with_tumble

    config = SimConfig(target=TargetConfig(attitude_deg=(90.0, 0.0, 0.0)))
    request = SimpleNamespace(set_tumble=False, set_launch=False, target="envisat",
                              target_mass=0.0, target_units="", criterion="",
                              tow_acceleration=0.0)
    got = config_with_tumble(config, request)
    assert got.target.attitude_deg == (90.0, 0.0, 0.0) and got.target.name == "envisat"
    assert got.target.mass != config.target.mass
    held = config_with_tumble(config, SimpleNamespace(**{**vars(request), "criterion": "held",
                                                         "tow_acceleration": 0.1}))
    assert held.criterion == "held" and held.tug.enabled and held.tug.tow_acceleration == 0.1
    assert held.tether_order == "chain"
    for field, value in (("criterion", "tug"), ("tow_acceleration", -1.0)):
        with pytest.raises(RequestError, match=f"^{field}: got"):
            config_with_tumble(config, SimpleNamespace(**{**vars(request), field: value}))


def test_a_request_names_a_mesh_in_millimetres(tmp_path):
    """A request carries the unit of its mesh file (``target_units``; issue 54: RunCapture
    had none though the error said to give units 'mm'); without one the configured
    target's unit is kept (it was read in metres); a unit for a catalogue name, or for no
    target, is refused naming the field."""
    from types import SimpleNamespace

    import trimesh

    from tethernet_ros.core.target import TargetConfig
    from tethernet_ros.ros.conversions import RequestError, config_with_tumble

    part = tmp_path / "part.stl"
    trimesh.creation.box((2000.0, 3000.0, 1000.0)).export(part)      # a 2 x 3 x 1 m box, mm
    request = SimpleNamespace(set_tumble=False, set_launch=False, target=str(part),
                              target_mass=950.0, target_units="mm", criterion="",
                              tow_acceleration=0.0)
    got = config_with_tumble(SimConfig(), request)
    assert got.target.units == "mm" and got.target.mesh == str(part)
    with pytest.raises(RequestError, match=r"^target_units: .*give units 'mm'"):
        config_with_tumble(SimConfig(), SimpleNamespace(**{**vars(request), "target_units": ""}))
    in_mm = SimConfig(target=TargetConfig(mesh=str(part), mass=950.0, units="mm"))
    kept = config_with_tumble(in_mm, SimpleNamespace(**{**vars(request), "target_units": ""}))
    assert kept.target.units == "mm"
    for fields, field in (({"target": "envisat", "target_mass": 0.0}, "target_units"),
                          ({"target": "", "target_mass": 0.0}, "target_units")):
        with pytest.raises(RequestError, match=f"^{field}: "):
            config_with_tumble(SimConfig(), SimpleNamespace(**{**vars(request), **fields}))
