"""`tethernet capture`: JSON output, figure, and one-line errors for bad input."""
import json
import os
import subprocess
import sys

import pytest

from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.core.episode import run_episode
from tethernet_ros.core.noise import NoiseModel

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def tethernet(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "tethernet_ros.cli", *args], capture_output=True,
                          text=True, cwd=cwd or ROOT, timeout=300)


@pytest.fixture(scope="module")
def short_config(tmp_path_factory):
    p = tmp_path_factory.mktemp("cfg") / "short.yaml"
    p.write_text("settle_time: 2.0\n")
    return str(p)


def test_capture_json_matches_library(short_config):
    out = tethernet("capture", "--design", "time-min", "--seed", "5", "--json", "--config", short_config)
    assert out.returncode == 0, out.stderr
    d = json.loads(out.stdout)
    for key in ("success", "settled_cqi", "locked_pairs", "closing_time", "completion_time", "mass",
                "failure_reason", "wall_time"):
        assert key in d
    ref = run_episode(REFERENCE_DESIGNS["time-min"], NoiseModel().sample(5), SimConfig(settle_time=2.0))
    assert d["settled_cqi"] == ref.settled_cqi          # bit for bit through JSON (repr round-trip)
    assert d["locked_pairs"] == ref.locked_pairs
    assert d["completion_time"] == ref.completion_time
    assert d["mass"] == pytest.approx(11.49, abs=0.01)


def test_capture_summary_writes_png(tmp_path, short_config):
    png = tmp_path / "c.png"
    out = tethernet("capture", "--design", "time-min", "--nominal", "--png", str(png), "--config", short_config)
    assert out.returncode == 0, out.stderr
    assert "settled CQI" in out.stdout and "locked pairs" in out.stdout
    assert png.stat().st_size > 10_000


@pytest.mark.parametrize("args, words", [
    (["--design", "nonsense"], ["unknown design", "baseline"]),
    (["--design", "/no/such/file.yaml"], ["does not exist"]),
    (["--design", "time-min", "--seed", "-2"], ["--seed"]),
    (["--design", "time-min", "--noise-scale", "speed=abc"], ["FACTOR"]),
    (["--design", "time-min", "--noise-scale", "wind=2"], ["scales.wind"]),
])
def test_bad_input_one_line_no_traceback(args, words):
    out = tethernet("capture", *args)
    assert out.returncode == 2
    assert "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1
    for w in words:
        assert w in out.stderr


@pytest.mark.parametrize("content, field", [
    ("m_c: .nan\nL_n: 20\nr_n: 0.001\nd_L: 20\nV_e: [1, 1, 5]\nd_c: 0.5\n", "m_c"),
    ("m_c: 1\nL_n: -20\nr_n: 0.001\nd_L: 20\nV_e: [1, 1, 5]\nd_c: 0.5\n", "L_n"),
    ("m_c: 1\nL_n: 20\nr_n: 0\nd_L: 20\nV_e: [1, 1, 5]\nd_c: 0.5\n", "r_n"),
    ("m_c: 1\nL_n: 20\nr_n: 0.001\nV_e: [1, 1, 5]\nd_c: 0.5\n", "d_L"),
    ("m_c: 1\nL_n: 20\nr_n: 0.001\nd_L: 20\nV_e: [1, 5]\nd_c: 0.5\n", "V_e"),
    ("m_c: [1\n", "YAML"),
    ("- 1\n- 2\n", "mapping"),
])
def test_bad_design_files(tmp_path, content, field):
    f = tmp_path / "d.yaml"
    f.write_text(content)
    out = tethernet("capture", "--design", str(f))
    assert out.returncode == 2, out.stdout
    assert "Traceback" not in out.stderr and field in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1


def test_bad_config_file(tmp_path):
    f = tmp_path / "c.yaml"
    f.write_text("dt_safety: 5\n")
    out = tethernet("capture", "--design", "time-min", "--config", str(f))
    assert out.returncode == 2 and "dt_safety" in out.stderr and "Traceback" not in out.stderr


def test_top_level_help_lists_every_command():
    out = tethernet("--help")
    assert out.returncode == 0, out.stderr
    for name in ("capture", "validate", "sensitivity", "figures", "replay", "optimize"):
        assert name in out.stdout


def test_a_command_module_that_fails_to_import_is_not_skipped(monkeypatch):
    """A command module missing or failing to import stops the parser with its error
    (issue 54: it was left out of `tethernet --help` silently)."""
    from tethernet_ros import cli

    monkeypatch.setattr(cli, "COMMANDS", cli.COMMANDS + ("no_such_command",))
    with pytest.raises(ModuleNotFoundError, match="tethernet_ros.commands.no_such_command"):
        cli.build_parser()


def test_target_show_tells_what_the_tool_made_of_a_target(tmp_path):
    """`tethernet target show` (issue 54 point 8): the catalogue's Zenit-2 with its
    closed-form numbers, a mesh file with its repairs and a drawing, and a refusal in one
    line for a mesh of two bodies."""
    import trimesh

    out = tethernet("target", "show", "zenit-2", "--json")
    assert out.returncode == 0, out.stderr
    d = json.loads(out.stdout)
    assert d["kind"] == "revolution" and d["mass"] == 8300.0
    assert d["required_pull"] == 415.0 and d["design_bounds"]["m_c"] == [1.0, 4.0]
    assert d["L_c"] == pytest.approx(1.95) and d["bounding_radius"] == pytest.approx(5.554, abs=1e-3)
    box = trimesh.creation.box((4.0, 1.0, 2.0))
    box.faces = box.faces[:, ::-1]                      # inverted: repaired and reported
    path = tmp_path / "box.stl"
    box.export(path)
    png = tmp_path / "box.png"
    out = tethernet("target", "show", str(path), "--target-mass", "80", "--png", str(png))
    assert out.returncode == 0, out.stderr
    assert "volume             8 m^3" in out.stdout and "inverted normals" in out.stdout
    assert "principal moments  (33.33" in out.stdout and png.stat().st_size > 1000
    two = trimesh.util.concatenate([trimesh.creation.box((1, 1, 1)), trimesh.creation.box(
        (1, 1, 1), transform=trimesh.transformations.translation_matrix((5.0, 0.0, 0.0)))])
    two.export(tmp_path / "two.stl")
    out = tethernet("target", "show", str(tmp_path / "two.stl"), "--target-mass", "80")
    assert out.returncode == 2 and "2 separate bodies apart" in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("args, words", [
    (["--criterion", "held", "--tow-acceleration", "-0.05"],
     "--tow-acceleration: tug field 'tow_acceleration': got -0.05; must be an acceleration "
     "in [1e-4, 10] m/s^2"),
    (["--criterion", "held", "--tow-acceleration", "nan"], "got nan; must be an acceleration"),
    (["--criterion", "held", "--tow-acceleration", "0"], "got 0.0; must be an acceleration"),
    (["--criterion", "held", "--tow-acceleration", "6"],
     "tug field 'tow_acceleration': got 6 m/s^2, a pull of 4.98e+04 N on the 8300 kg target; "
     "must be at most 4.996 m/s^2"),
    (["--criterion", "tug"], "argument --criterion: invalid choice: 'tug'"),
    (["--config", "CRIT"], "config field 'criterion': got 'tug'; must be one of 'source', 'held'"),
    (["--config", "PULL"], "tug field 'tow_acceleration': got 6 m/s^2"),
], ids=["negative", "nan", "zero", "above-breaking-load", "unknown-flag", "unknown-file",
        "above-breaking-load-file"])
def test_bad_criterion_and_acceleration_are_refused_in_one_line(tmp_path, args, words):
    """Issue 53 point 6 through the CLI and a config file: each refused with status 2 in
    one line naming the field and its range, no traceback."""
    (tmp_path / "crit.yaml").write_text("criterion: tug\n")
    (tmp_path / "pull.yaml").write_text("criterion: held\ntug: {tow_acceleration: 6.0}\n")
    args = [str(tmp_path / "crit.yaml") if a == "CRIT" else
            str(tmp_path / "pull.yaml") if a == "PULL" else a for a in args]
    out = tethernet("capture", "--design", "mass-min", *args)
    assert out.returncode == 2 and words in out.stderr, out.stderr
    assert "Traceback" not in out.stderr
    assert len([ln for ln in out.stderr.splitlines() if "error" in ln]) == 1
