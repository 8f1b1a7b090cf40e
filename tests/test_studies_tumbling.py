"""The tumbling study's report (tethernet_ros/studies/tumbling.py) on a study run on some
cells only: the tables and the 90 % rate use the measured rates and axes, a missing cell
of one design shows as '-', and the figure is drawn."""
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
