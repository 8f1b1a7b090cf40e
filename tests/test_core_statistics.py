"""Convergence and agreement judged on statistics over common random numbers (docs/model.md
§11), never on one chaotic trajectory.  CI runs short versions; the full studies
(N = 200 per design, all four reference designs) are `tethernet study convergence` and
`tethernet study agreement` (docs/studies/)."""
import pytest

from tethernet_ros import montecarlo as mc
from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.studies.cells import agreement_cells, convergence_cells
from tethernet_ros.studies.paired import CellStats, PairedStats


def _paired(cells, design, n):
    specs = [mc.RunSpec(REFERENCE_DESIGNS[design], config=c.config, label=c.label) for c in cells]
    with mc.ProcessPoolBackend(2) as be:
        a, b = mc.evaluate_many(specs, n, 0, be)
    sa = CellStats.from_samples(cells[0].label, design, a.samples)
    sb = CellStats.from_samples(cells[1].label, design, b.samples)
    ps = PairedStats.from_samples(sa, sb, a.samples, b.samples)
    print(f"{design}: {sa.label} P {sa.p:.3f} [{sa.lo:.3f}, {sa.hi:.3f}] T {sa.mean_t:.2f}; "
          f"{sb.label} P {sb.p:.3f} [{sb.lo:.3f}, {sb.hi:.3f}] T {sb.mean_t:.2f}; "
          f"flips {ps.flips}/{sa.n}")
    return ps


@pytest.mark.slow
def test_halving_the_implicit_step_keeps_reliability_and_completion_time():
    """time-min, 16 paired samples: P*_s moves by less than the smaller interval's
    half-width and mean T by less than 2 % when the 1 ms step is halved."""
    ps = _paired(convergence_cells(SimConfig())[:2], "time-min", 16)
    assert ps.within_half_width
    assert abs(ps.t_rel_diff) < 0.02


@pytest.mark.slow
def test_implicit_agrees_with_explicit_on_statistics():
    """mass-min, 8 paired samples (the explicit method costs about 8 CPU-s an episode):
    P*_s within the smaller interval's half-width, mean T within 2 %."""
    ps = _paired(agreement_cells(SimConfig()), "mass-min", 8)
    assert ps.within_half_width
    assert abs(ps.t_rel_diff) < 0.02
