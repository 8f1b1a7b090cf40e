"""The tumbling study's report (tethernet_ros/studies/tumbling.py) on a study run on some
cells only: the tables and the 90 % rate use the measured rates and axes, a missing cell
of one design shows as '-', and the figure is drawn."""
import math

from tethernet_ros.studies.paired import CellStats
from tethernet_ros.studies.tumbling import (falls_below, measured_rates, plot_tumbling,
                                            tumbling_table)


def _stats(label, design, successes, n=200):
    p = successes / n
    return CellStats(label, design, n, successes, p, p - 0.02, min(1.0, p + 0.02), 30.0, {})


def test_report_of_a_partial_grid(tmp_path):
    stats = {}
    for label, k in (("rest threshold", 196), ("flat 2 threshold", 190),
                     ("flat 8 threshold", 150), ("flat 8 adaptive", 185)):
        stats[(label, "a")] = _stats(label, "a", k)
    stats[("rest threshold", "b")] = _stats("rest threshold", "b", 200)
    assert measured_rates(stats, "flat") == [0.0, 2.0, 8.0]
    assert measured_rates(stats, "los") == [0.0]
    assert falls_below(stats, "a", "flat", "threshold") == "8"        # 75 % at 8 deg/s
    # the adaptive policy was not run at rest or at 2 deg/s: nothing can be said
    assert falls_below(stats, "a", "flat", "adaptive") == "-"
    assert falls_below(stats, "b", "flat", "threshold") == "-"       # b's 2 deg/s missing
    text = tumbling_table(["a", "b"], stats)
    assert "| flat | 8 | 75.0 [73.0, 77.0] | 30.00 | 92.5 [90.5, 94.5] | 30.00 |" in text
    assert "| flat | 4 |" not in text and "| los |" not in text       # not measured
    assert "| design | flat |" in text and "| a | 8 / - |" in text
    plot_tumbling(["a", "b"], stats, tmp_path / "t.png", "partial")
    assert (tmp_path / "t.png").stat().st_size > 1000


def test_long_axis_against_the_line_of_sight_follows_the_phase():
    """About the flat axis (body y) with no axis tilt, the long axis (body x) turned by the
    phase phi has |a_z| = |sin phi| whatever the orientation noise about the line of sight;
    a roll about the long axis leaves it across the line of sight."""
    import math

    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.design import REFERENCE_DESIGNS
    from tethernet_ros.core.noise import NoiseModel
    from tethernet_ros.core.tumble import TumbleConfig
    from tethernet_ros.montecarlo.attitude import attitude_bin, long_axis_los

    design = REFERENCE_DESIGNS["mass-min"]
    noise = NoiseModel(sigma_spin_axis_deg=0.0)
    flat = SimConfig().replace(tumble=TumbleConfig(rate_deg_s=2.0, axis="flat"))
    roll = SimConfig().replace(tumble=TumbleConfig(rate_deg_s=2.0, axis="long"))
    for seed in range(6):
        phi = noise.sample(seed).spin_phase
        assert math.isclose(long_axis_los(design, flat, noise, seed), abs(math.sin(phi)),
                            abs_tol=1e-12)
        assert long_axis_los(design, roll, noise, seed) < 1e-12
    # a sample's launch attitude is computed once per (design, tumble, noise, seed): the
    # roll above did not reuse the flat spin's, and asking again reuses it
    from tethernet_ros.montecarlo.attitude import _launch_attitude
    assert _launch_attitude(design, flat, noise, 0) is _launch_attitude(design, flat, noise, 0)
    assert [attitude_bin(a) for a in (0.0, 0.49, 0.5, 0.89, 0.9, 1.0)] == [0, 0, 1, 1, 2, 2]


def test_attitude_table_splits_each_cell_by_bin():
    """The table counts each policy's successes per bin of |a_z|, from the samples' seeds."""
    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.design import REFERENCE_DESIGNS
    from tethernet_ros.montecarlo.seeds import sample_seed
    from tethernet_ros.studies.cells import tumbling_cells
    from tethernet_ros.studies.summary import CellRecord, Verdict
    from tethernet_ros.montecarlo.attitude import attitude_bin, long_axis_los
    from tethernet_ros.studies.tumbling import attitude_table

    design = REFERENCE_DESIGNS["baseline"]
    cells = tumbling_cells(SimConfig())
    cell = next(c for c in cells if c.label == "flat 2 threshold")
    seeds = [sample_seed(0, i) for i in range(40)]
    bins = [attitude_bin(long_axis_los(design, cell.config, cell.noise, s)) for s in seeds]
    # successes exactly where the stage lies across the line of sight
    verdicts = tuple(Verdict(s, b == 0) for s, b in zip(seeds, bins))
    rec = CellRecord(_stats("flat 2 threshold", "baseline", sum(b == 0 for b in bins), 40),
                     "k", 0, verdicts)
    text = attitude_table(["baseline"], cells, {("flat 2 threshold", "baseline"): rec},
                          {"baseline": design})
    n = [bins.count(k) for k in range(3)]
    assert all(n), n        # 40 uniform phases reach every bin
    assert f"| flat | 2 | baseline | {n[0]}/{n[0]} / - | 0/{n[1]} / - | 0/{n[2]} / - |" in text
    # a roll about the long axis keeps every sample across the line of sight: left out
    roll = CellRecord(_stats("long 2 threshold", "baseline", 40, 40), "k", 0,
                      tuple(Verdict(s, True) for s in seeds))
    assert attitude_table(["baseline"], cells, {("long 2 threshold", "baseline"): roll},
                          {"baseline": design}) == ""


def test_error_bars_of_a_cell_at_every_or_no_success(tmp_path):
    """At 0 or n successes the Wilson bound may sit on the wrong side of p by round-off
    (10 of 10: hi = 1 - 1e-16); the bars stay non-negative and both figures draw."""
    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.metrics import wilson_interval
    from tethernet_ros.studies.cells import Cell
    from tethernet_ros.studies.report import error_bars, plot_study

    stats = {}
    for label, k in (("rest threshold", 10), ("flat 2 threshold", 0)):
        lo, hi = wilson_interval(k, 10)
        stats[(label, "mass-min")] = CellStats(label, "mass-min", 10, k, k / 10, lo, hi, 30.0, {})
    below, above = error_bars([1.0, 0.0], *zip(wilson_interval(10, 10), wilson_interval(0, 10)))
    assert (below >= 0).all() and (above >= 0).all() and above[1] > 25 and below[0] > 25
    cells = [Cell("rest threshold", "a", SimConfig()), Cell("flat 2 threshold", "b", SimConfig())]
    plot_study(["mass-min"], cells, stats, tmp_path / "s.png")
    plot_tumbling(["mass-min"], stats, tmp_path / "t.png", "edges")
    assert (tmp_path / "s.png").stat().st_size > 1000 and (tmp_path / "t.png").stat().st_size > 1000


def test_policy_table_pairs_the_policies_sample_by_sample():
    """The adaptive cell against the threshold cell of the same (axis, rate, design): the
    flips are counted seed by seed, McNemar's p is the exact binomial one, and a cell with
    one policy only (a study still running) is left out."""
    from scipy.stats import binomtest

    from tethernet_ros.montecarlo.seeds import sample_seed
    from tethernet_ros.studies.summary import CellRecord, Verdict
    from tethernet_ros.studies.tumbling import policy_pairs, policy_table

    seeds = [sample_seed(0, i) for i in range(20)]
    # threshold: samples 0-9 succeed; adaptive: samples 3-17 succeed
    th_ok = [i < 10 for i in range(20)]
    ad_ok = [3 <= i < 18 for i in range(20)]

    def rec(label, ok, t):
        s = CellStats(label, "a", 20, sum(ok), sum(ok) / 20, 0.0, 1.0, t, {})
        return CellRecord(s, "k", 0, tuple(Verdict(x, b) for x, b in zip(seeds, ok)))

    records = {("flat 2 threshold", "a"): rec("flat 2 threshold", th_ok, 40.0),
               ("flat 2 adaptive", "a"): rec("flat 2 adaptive", ad_ok, 27.5),
               ("flat 4 threshold", "a"): rec("flat 4 threshold", th_ok, 40.0)}
    pairs = policy_pairs(["a"], records)
    assert list(pairs) == [("flat", 2.0, "a")]
    p = pairs[("flat", 2.0, "a")]
    assert (p.b_only, p.a_only) == (8, 3)          # samples 10-17 / samples 0-2
    assert math.isclose(p.mcnemar_p, binomtest(3, 11, 0.5).pvalue)
    text = policy_table(pairs)
    assert f"| flat | 2 | a | +25.0 | 8 / 3 | {p.mcnemar_p:.2g} | -12.50 |" in text
    assert policy_table({}) == ""


def test_attitude_at_a_later_time_follows_the_kernel_untouched():
    """long_axis_los at t s is where the kernel turns the stage's long axis when the net
    is out of reach (d_L = 1000 m): a noisy flat spin (axis tilted off the principal axis,
    so the top precesses) at 8 deg/s, after 3 s."""
    from dataclasses import replace

    from tethernet_ros.core import kernel as kn
    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.design import REFERENCE_DESIGNS
    from tethernet_ros.core.episode import CaptureSimulation
    from tethernet_ros.core.noise import NoiseModel
    from tethernet_ros.core.scenario import scenario_for
    from tethernet_ros.core.tumble import TumbleConfig
    from tethernet_ros.montecarlo.attitude import long_axis_los

    design = replace(REFERENCE_DESIGNS["time-min"], d_L=1000.0)
    cfg = SimConfig(tumble=TumbleConfig(rate_deg_s=8.0, axis="flat"))
    noise = NoiseModel()
    seed = 5
    sample = noise.sample(seed)
    assert sample.spin_axis_tilt != 0.0
    sim = CaptureSimulation(scenario_for(design, sample, cfg))
    a0 = long_axis_los(design, cfg, noise, seed)
    assert math.isclose(abs(kn.quat_to_matrix(sim.s.target_body.quat)[2, 0]), a0, abs_tol=1e-12)
    sim.advance(3000)
    t = sim.time
    got = abs(kn.quat_to_matrix(sim.s.target_body.quat)[2, 0])
    assert math.isclose(long_axis_los(design, cfg, noise, seed, t), got, abs_tol=1e-7)
    assert abs(got - a0) > 0.05           # the axis moved: 24 deg turned in 3 s


def test_closing_attitude_table_counts_the_samples_that_never_closed():
    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.design import REFERENCE_DESIGNS
    from tethernet_ros.montecarlo.seeds import sample_seed
    from tethernet_ros.studies.cells import tumbling_cells
    from tethernet_ros.studies.summary import CellRecord, Verdict
    from tethernet_ros.montecarlo.attitude import attitude_bin, long_axis_los
    from tethernet_ros.studies.tumbling import attitude_table

    design = REFERENCE_DESIGNS["mass-min"]
    cells = tumbling_cells(SimConfig())
    cell = next(c for c in cells if c.label == "flat 4 threshold")
    seeds = [sample_seed(0, i) for i in range(30)]
    times = tuple(math.nan if i % 5 == 0 else 20.0 + 0.1 * i for i in range(30))
    bins = [None if not math.isfinite(t) else
            attitude_bin(long_axis_los(design, cell.config, cell.noise, s, t))
            for s, t in zip(seeds, times)]
    verdicts = tuple(Verdict(s, b == 0) for s, b in zip(seeds, bins))
    k = sum(b == 0 for b in bins)
    rec = CellRecord(_stats("flat 4 threshold", "mass-min", k, 30), "k", 0, verdicts, 0.0, times)
    no_times = CellRecord(rec.stats, "k", 0, verdicts)
    text = attitude_table(["mass-min"], cells, {("flat 4 threshold", "mass-min"): rec},
                          {"mass-min": design}, at="closing")
    n = [bins.count(j) for j in range(3)]
    assert f"| flat | 4 | mass-min | {n[0]}/{n[0]} / - | 0/{n[1]} / - | 0/{n[2]} / - | 0/6 / - |" \
        in text and "closing never started" in text
    assert attitude_table(["mass-min"], cells, {("flat 4 threshold", "mass-min"): no_times},
                          {"mass-min": design}, at="closing") == ""


def test_rest_table_pairs_each_tumbling_cell_with_the_rest_cell_of_its_policy():
    """A tumbling cell is compared with the target at rest under the same policy, seed by
    seed; a policy without its rest cell shows '-' and a cell with neither is left out."""
    from scipy.stats import binomtest

    from tethernet_ros.montecarlo.seeds import sample_seed
    from tethernet_ros.studies.summary import CellRecord, Verdict
    from tethernet_ros.studies.tumbling import rest_pairs, rest_table

    seeds = [sample_seed(0, i) for i in range(20)]

    def rec(label, ok):
        s = CellStats(label, "a", 20, sum(ok), sum(ok) / 20, 0.0, 1.0, 30.0, {})
        return CellRecord(s, "k", 0, tuple(Verdict(x, b) for x, b in zip(seeds, ok)))

    rest = [i % 2 == 0 for i in range(20)]              # even samples at rest
    spun = [i % 2 == 0 or i < 7 for i in range(20)]     # and samples 1, 3, 5 spun
    records = {("rest threshold", "a"): rec("rest threshold", rest),
               ("los 4 threshold", "a"): rec("los 4 threshold", spun),
               ("los 4 adaptive", "a"): rec("los 4 adaptive", spun),   # no adaptive rest
               ("flat 8 adaptive", "a"): rec("flat 8 adaptive", spun)}
    pairs = rest_pairs(["a"], records)
    assert list(pairs) == [("los", 4.0, "threshold", "a")]
    p = pairs[("los", 4.0, "threshold", "a")]
    assert (p.b_only, p.a_only) == (3, 0)
    assert math.isclose(p.mcnemar_p, binomtest(0, 3, 0.5).pvalue)
    text = rest_table(pairs)
    assert f"| los | 4 | a | +15.0 / - | 3/0 / - | {p.mcnemar_p:.2g} / - |" in text
    assert "flat" not in text.split("|---|")[-1]
    assert rest_table({}) == ""


def test_any_shape_turns_free_of_torque_as_the_kernel_turns_it():
    """An asymmetric top (Envisat: three distinct moments) spun about a tilted axis: the
    core's free rotation is the kernel's untouched target, bit for bit, and long_axis_los
    follows it."""
    from dataclasses import replace

    import numpy as np

    from tethernet_ros.core import kernel as kn
    from tethernet_ros.core.config import SimConfig
    from tethernet_ros.core.design import REFERENCE_DESIGNS
    from tethernet_ros.core.episode import CaptureSimulation
    from tethernet_ros.core.noise import NoiseModel
    from tethernet_ros.core.scenario import scenario_for
    from tethernet_ros.core.target import TargetConfig
    from tethernet_ros.core.tumble import TumbleConfig, free_rotation
    from tethernet_ros.montecarlo.attitude import long_axis_los

    design = replace(REFERENCE_DESIGNS["time-min"], d_L=1000.0)
    cfg = SimConfig(target=TargetConfig(name="envisat"),
                    tumble=TumbleConfig(rate_deg_s=8.0, axis=(0.3, 1.0, 0.2)))
    noise = NoiseModel()
    sim = CaptureSimulation(scenario_for(design, noise.sample(2), cfg))
    t = sim.s.target_body
    q0, L0, inertia = t.quat.copy(), t.ang_mom.copy(), np.array(t.inertia)
    assert len(set(inertia.tolist())) == 3
    sim.advance(2500)
    q = free_rotation(q0, L0, inertia, 2500 * sim.dt, dt=sim.dt)
    assert np.array_equal(q, sim.s.target_body.quat)
    a = long_axis_los(design, cfg, noise, 2, 2500 * sim.dt)
    assert a == abs(kn.quat_to_matrix(sim.s.target_body.quat)[2, 0])
