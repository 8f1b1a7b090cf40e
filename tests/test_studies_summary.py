"""A study's summary file (tethernet_ros/studies/summary.py): a study run again without
its results file (another machine, another session) takes the finished cells from the
summary committed beside its report and simulates only the others; the report's
hand-written part survives every rewrite."""
import json
import os
import subprocess
import sys

import pytest

from results_lines import sample_lines
from tethernet_ros.core.metrics import wilson_interval
from tethernet_ros.studies.summary import (KEEP_MARK, CellRecord, Verdict, keep_written_text,
                                            plan_text, reusable_cells)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def study(tmp_path, results, cells, samples=3, extra=()):
    cfg = tmp_path / "cfg.yaml"
    cfg.write_text("settle_time: 1.0\n")
    return subprocess.run(
        [sys.executable, "-m", "tethernet_ros.cli", "study", "tumbling", "--designs", "time-min",
         "--cells", cells, "--samples", str(samples), "--config", str(cfg), "--workers", "0",
         "--results", str(tmp_path / results), "--out", str(tmp_path / "docs"), "--no-progress", *extra],
        capture_output=True, text=True, cwd=ROOT, timeout=300)


def test_a_study_takes_its_finished_cells_from_the_summary(tmp_path):
    first = study(tmp_path, "a.jsonl", "rest threshold,flat 8 threshold")
    assert first.returncode == 0, first.stderr
    summary = json.loads((tmp_path / "docs" / "tumbling.json").read_text())
    assert [(s["label"], s["n"], len(s["verdicts"])) for s in summary["stats"]] == [
        ("rest threshold", 3, 3), ("flat 8 threshold", 3, 3)]
    assert all(s["seed"] == 0 and len(s["key"]) == 20 for s in summary["stats"])
    lines = sample_lines(tmp_path / "a.jsonl")
    assert len(lines) == 6
    # each sample's closing time, as the results file has it (null: never closed)
    closing = {(r["key"], r["seed"]): r["closing_time"] for r in map(json.loads, lines)}
    assert [s["closing_times"] for s in summary["stats"]] == [
        [closing[(s["key"], i)] for i in range(3)] for s in summary["stats"]]
    report = tmp_path / "docs" / "tumbling.md"
    assert KEEP_MARK in report.read_text()
    report.write_text(report.read_text() + "\nOur findings, by hand.\n")

    plan = study(tmp_path, "a.jsonl", "rest threshold,flat 8 threshold,flat 8 adaptive",
                 extra=["--plan"])
    assert plan.returncode == 0, plan.stderr
    assert "recorded in the summary: 2 of 3 (cell, design) pairs" in plan.stdout
    assert "3 episodes left, about" in plan.stdout                # simulates nothing
    assert len(sample_lines(tmp_path / "a.jsonl")) == 6

    # another session: no results file, one more cell
    second = study(tmp_path, "b.jsonl", "rest threshold,flat 8 threshold,flat 8 adaptive")
    assert second.returncode == 0, second.stderr
    assert "2 of 3 cells taken as recorded" in second.stderr
    assert len(sample_lines(tmp_path / "b.jsonl")) == 3          # the new cell only
    again = json.loads((tmp_path / "docs" / "tumbling.json").read_text())
    assert again["stats"][:2] == summary["stats"]
    assert [p["b"] for p in again["paired"]] == ["flat 8 threshold", "flat 8 adaptive"]
    assert again["paired"][0] == summary["paired"][0]             # pairs from the verdicts
    text = report.read_text()
    assert text.endswith("\nOur findings, by hand.\n") and text.count(KEEP_MARK) == 1
    assert "| flat | 8 |" in text

    # another number of samples is another study: nothing is taken, nothing is lost
    third = study(tmp_path, "c.jsonl", "rest threshold", samples=2)
    assert third.returncode == 0, third.stderr
    assert "taken as recorded" not in third.stderr
    assert len(sample_lines(tmp_path / "c.jsonl")) == 2
    kept = json.loads((tmp_path / "docs" / "tumbling.json").read_text())["kept"]
    assert [(k["label"], k["n"]) for k in kept] == [("rest threshold", 3), ("flat 8 threshold", 3),
                                                   ("flat 8 adaptive", 3)]
    fourth = study(tmp_path, "d.jsonl", "rest threshold,flat 8 threshold,flat 8 adaptive")
    assert "3 of 3 cells taken as recorded" in fourth.stderr
    assert not (tmp_path / "d.jsonl").exists() or not sample_lines(tmp_path / "d.jsonl")

    # --name: the table, summary and figure under that name; the study's own are untouched
    before = (tmp_path / "docs" / "tumbling.json").read_text()
    named = study(tmp_path, "d.jsonl", "rest threshold", samples=1, extra=["--name", "small"])
    assert named.returncode == 0, named.stderr
    assert "taken as recorded" not in named.stderr
    assert {p.name for p in (tmp_path / "docs").glob("small.*")} == {"small.md", "small.json",
                                                                     "small.png"}
    assert json.loads((tmp_path / "docs" / "small.json").read_text())["stats"][0]["n"] == 1
    assert (tmp_path / "docs" / "tumbling.json").read_text() == before


LO, HI = wilson_interval(1, 2)
REC = {"label": "rest threshold", "design": "time-min", "n": 2, "successes": 1, "p": 0.5,
       "lo": LO, "hi": HI, "mean_t": 5.0, "failures": {"x": 1}, "key": "k" * 20,
       "seed": 0, "verdicts": "10", "cpu_time": 1.5}


def test_unusable_summaries_give_no_cells(tmp_path):
    rec = dict(REC)
    path = tmp_path / "s.json"
    path.write_text(json.dumps({"stats": [rec, {**rec, "key": "b" * 20, "verdicts": "11"},
                                          {**rec, "key": "c" * 20, "seed": 1},
                                          {k: v for k, v in rec.items() if k != "verdicts"}]}))
    assert list(reusable_cells(path, 0, 2)) == ["k" * 20]          # the others disagree or lack
    assert reusable_cells(path, 0, 3) == {}
    cell = CellRecord.from_json(rec, "flat 1 threshold", "mass-min")
    assert cell.stats.label == "flat 1 threshold" and [v.seed for v in cell.verdicts] == [0, 1]
    assert cell.to_json() == {**rec, "label": "flat 1 threshold", "design": "mass-min"}
    path.write_text('{"stats": [')                                  # truncated
    assert reusable_cells(path, 0, 2) == {}
    path.write_text('{"stats": null, "kept": 3}')
    assert reusable_cells(path, 0, 2) == {}
    # the interval comes from the verdicts, not from the file
    assert CellRecord.from_json({**rec, "lo": 0.0, "hi": 1.0}, "a", "b").stats.lo == LO
    # a cell with gaps (samples 0 and 2 of an interrupted run) is shown, never reused
    gap = CellRecord(cell.stats, cell.key, 0, (Verdict(0, True), Verdict(2, False)))
    assert not gap.complete_prefix and "verdicts" not in gap.to_json()
    assert cell.complete_prefix
    with pytest.raises(ValueError, match="verdicts"):
        CellRecord.from_json({**rec, "verdicts": "1x"}, "a", "b")


def test_closing_times_are_kept_and_taken_from_a_results_file():
    """A summary written before closing times were kept takes them from a results file
    that holds every sample of the cell under its key, and not from one that lacks one."""
    import math
    from types import SimpleNamespace

    cell = CellRecord.from_json(REC, "flat 1 threshold", "mass-min")
    assert cell.closing_times is None and "closing_times" not in cell.to_json()
    one = {(REC["key"], 0): SimpleNamespace(closing_time=12.5)}
    assert cell.with_closing_times_from(one) is cell                   # seed 1 missing
    both = {**one, (REC["key"], 1): SimpleNamespace(closing_time=None)}
    filled = cell.with_closing_times_from(both)
    assert filled.closing_times[0] == 12.5 and math.isnan(filled.closing_times[1])
    assert filled.to_json()["closing_times"] == [12.5, None]
    again = CellRecord.from_json(filled.to_json(), "flat 1 threshold", "mass-min")
    assert again.closing_times[0] == 12.5 and math.isnan(again.closing_times[1])
    assert filled.with_closing_times_from({}) is filled                # kept as it is
    with pytest.raises(ValueError, match="closing_times"):
        CellRecord.from_json({**REC, "closing_times": [1.0]}, "a", "b")


def test_plan_of_what_is_left():
    recs = {("rest", "a"): CellRecord.from_json({**REC, "cpu_time": 4.0}, "rest", "a"),
            ("rest", "b"): CellRecord.from_json({**REC, "cpu_time": 1.0}, "rest", "b")}
    text = plan_text("tumbling", ["a", "b", "c"], ["rest", "flat 1"], 2, recs,
                     {("flat 1", "a"): 1}, workers=2)
    assert "recorded in the summary: 2 of 6 (cell, design) pairs" in text
    assert "| a | 1 | 2.00 | 0.00 |" in text                       # 2 - 1 in the results file
    assert "| b | 2 | 0.50 | 0.00 |" in text
    assert "| c | 4 | 1.25 (all designs) | 0.00 |" in text          # (4 + 1) / (2 + 2)
    assert "7 episodes left, about 0.0 CPU-hours" in text
    none = plan_text("tumbling", ["a"], ["rest"], 2, {}, {}, workers=1)
    assert "no CPU time recorded yet" in none


def test_the_hand_written_part_is_kept(tmp_path):
    md = tmp_path / "r.md"
    assert keep_written_text(md, "# table\n") == f"# table\n\n{KEEP_MARK}\n"
    md.write_text(f"# old table\n\n{KEEP_MARK}\n## Findings\n")
    assert keep_written_text(md, "# new table\n") == f"# new table\n\n{KEEP_MARK}\n## Findings\n"


def test_a_design_file_with_its_own_tumble_joins_a_study(tmp_path, capsys):
    """A design file that carries a tumble (a tumbling Case's choice) is taken by
    ``tethernet study``, each cell setting the tumble; --plan simulates nothing."""
    from tethernet_ros import cli

    f = tmp_path / "d.yaml"
    f.write_text("m_c: 1.0\nL_n: 20.0\nr_n: 0.001\nd_L: 30.0\nV_e: [2.5, 3.0, 7.5]\nd_c: 2.5\n"
                 "tumble: {rate_deg_s: 2.0, axis: transverse}\n")
    code = cli.main(["study", "tumbling", "--designs", f"{f},mass-min", "--samples", "4",
                     "--out", str(tmp_path / "s"), "--results", str(tmp_path / "r.jsonl"),
                     "--plan"])
    out = capsys.readouterr()
    assert code == 0
    assert "its tumble" in out.err and "is not used" in out.err
    assert f"| {f} | 128 |" in out.out                     # 32 cells x 4 samples


def test_a_design_files_launch_settings_hold_in_its_study_cells(tmp_path, capsys):
    """A design file's launch: (a tilt limit it was chosen with) sets its own cells as
    --launch-max-tilt would, so their run keys are the flag's; the cell sets the launch
    policy and the command line wins over the file; a bad value names the file."""
    from tethernet_ros.cli import build_parser
    from tethernet_ros.commands.common import config_from_args, read_design_file
    from tethernet_ros.commands.study import _design_launch, with_launch
    from tethernet_ros.core.noise import NoiseModel
    from tethernet_ros.errors import UserError
    from tethernet_ros.montecarlo.keys import run_key
    from tethernet_ros.studies.cells import STUDIES

    f = tmp_path / "d.yaml"
    f.write_text("m_c: 1.0\nL_n: 20.0\nr_n: 0.001\nd_L: 30.0\nV_e: [2.5, 3.0, 7.5]\nd_c: 2.5\n"
                 "launch: {kind: immediate, max_tilt_deg: 15}\n")
    scenario = read_design_file(str(f))[1]

    def cell_configs(*flags):
        args = build_parser().parse_args(["study", "launch", "--designs", str(f), *flags])
        launch = _design_launch(str(f), scenario, args)
        return [with_launch(c.config, launch) for c in STUDIES["launch"](config_from_args(args))]

    by_file, by_flag = cell_configs(), cell_configs("--launch-max-tilt", "15")
    assert by_file == by_flag
    design = read_design_file(str(f))[0]
    assert [run_key(design, NoiseModel(), c) for c in by_file] == \
        [run_key(design, NoiseModel(), c) for c in by_flag]          # the file's 15, the flag's 15.0
    assert {c.launch.kind for c in by_file} == {"immediate", "predictive"}   # the cells'
    assert {c.launch.max_tilt_deg for c in cell_configs("--launch-max-tilt", "20")} == {20.0}
    err = capsys.readouterr().err
    assert "its launch {'kind': 'immediate'} is not used" in err
    assert "its launch {'kind': 'immediate', 'max_tilt_deg': 15} is not used" in err
    f.write_text(f.read_text().replace("15}", "150}"))
    with pytest.raises(UserError, match=r"d\.yaml \(launch:\): launch field 'max_tilt_deg': "
                                        r"got 150"):
        _design_launch(str(f), read_design_file(str(f))[1],
                       build_parser().parse_args(["study", "launch", "--designs", str(f)]))


def _cell(label, verdicts, seed=0, wait=0.0):
    n, k = len(verdicts), verdicts.count("1")
    lo, hi = wilson_interval(k, n)
    return {**REC, "label": label, "n": n, "successes": k, "p": k / n, "lo": lo, "hi": hi,
            "verdicts": verdicts, "seed": seed, "mean_wait": wait}


def test_two_summaries_pair_their_cells_sample_by_sample(tmp_path, capsys):
    """scripts/pair_summaries.py: B's cells against A's of the same label and design (and
    of the reference launch), flip by flip; a cell of other samples is not paired."""
    from script_modules import load_script

    script = load_script("pair_summaries")
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(json.dumps({"stats": [_cell("flat 2 threshold immediate", "1000"),
                                       _cell("flat 2 threshold predictive", "1100", wait=9.0)],
                             "kept": [_cell("flat 8 threshold predictive", "1111", seed=7)]}))
    b.write_text(json.dumps({"stats": [_cell("flat 2 threshold predictive", "0111", wait=12.0),
                                       _cell("flat 8 threshold predictive", "1111")]}))
    assert script.main([str(a), str(b), "--label-a", "30", "--label-b", "15",
                        "--reference", "immediate"]) == 0
    rows = capsys.readouterr().out.splitlines()
    assert rows[0].startswith("| design | cell | P*_s 30 % | P*_s 15 % [95 %] |")
    flat2 = rows[2].split(" | ")
    # A's predictive 1100 against B's 0111: one success of A alone, two of B alone;
    # A's immediate 1000 against 0111: one of the immediate alone, three of B alone
    assert flat2[1:4] == ["flat 2 threshold predictive", "50.0", "75.0 [30.1, 95.4]"]
    assert flat2[4] == "12.0" and flat2[6] == "1 / 2" and flat2[8] == "25.0"
    assert flat2[9] == "1 / 3" and flat2[10] == "0.62 |"
    # A holds the 8 deg/s cell for another base seed only: no pair, no reference
    assert rows[3].split(" | ")[2] == "-" and rows[3].endswith("| - | - | - | - | - |")
    b.write_text(json.dumps({"stats": [{k: v for k, v in REC.items() if k != "verdicts"}]}))
    assert script.main([str(a), str(b)]) == 2


def test_seed_sets_pool_cell_by_cell_and_other_settings_are_refused(tmp_path, capsys):
    """scripts/pool_seed_sets.py: one cell's verdicts over seed sets, added up; the cells
    kept from earlier runs are not this run's (other settings under one label) and are
    left out; two summaries of one base seed, or a cell of other settings, are refused; a
    field only one configuration has is named."""
    from script_modules import load_script

    script = load_script("pool_seed_sets")
    label = "flat 4 adaptive predictive"
    cfg = {"launch": {"kind": "predictive", "max_tilt_deg": 30.0}, "settle_time": 20.0}
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(json.dumps({"seed": 0, "cells": [{"label": label, "config": cfg}],
                             "stats": [_cell(label, "1101")],
                             "kept": [_cell(label, "0000")]}))
    b.write_text(json.dumps({"seed": 5000, "cells": [{"label": label, "config": {
        **cfg, "launch": {"kind": "predictive", "max_tilt_deg": 30, "confirm_time": 1.0}}}],
        "stats": [_cell(label, "111111", seed=5000)]}))
    assert script.main([str(a), str(b)]) == 0
    rows = capsys.readouterr().out.splitlines()
    assert rows[0] == ("| cell | seed 0 | seed 5000 | pooled | P*_s pooled % [95 %] | "
                       "one set's P*_s % |")
    lo, hi = wilson_interval(9, 10)
    assert rows[2] == (f"| {label} | 3/4 | 6/6 | 9/10 | **90.0** [{100 * lo:.1f}, "
                       f"{100 * hi:.1f}] | 75.0-100.0 |")
    assert rows[3] == ("- fields only some configurations have (added later, at their "
                       "defaults): launch.confirm_time")
    same_seed = tmp_path / "c.json"
    same_seed.write_text(a.read_text())
    with pytest.raises(SystemExit, match="same base seed"):
        script.main([str(a), str(same_seed)])
    b.write_text(json.dumps({"seed": 5000, "cells": [{"label": label, "config": {
        **cfg, "launch": {"kind": "predictive", "max_tilt_deg": 15.0}}}],
        "stats": [_cell(label, "111111", seed=5000)]}))
    with pytest.raises(SystemExit, match=r"settings differ .*: launch\.max_tilt_deg$"):
        script.main([str(a), str(b)])
