"""Backends give bit-identical samples; a dying or raising worker is retried once, then
counted as a 'worker error' failure (process pool and local Dask cluster)."""
import pytest

from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.design import REFERENCE_DESIGNS
from tethernet_ros.core.noise import NoiseModel
from tethernet_ros import montecarlo as mc

SHORT = SimConfig(settle_time=2.0)
FAST = SimConfig(settle_time=2.0, horizon=2.0)    # closing never triggers: ~0.2 s a sample
DESIGN = REFERENCE_DESIGNS["time-min"]
# faults on base seed 1 (seeds 1000003 + i), so that the equality runs (base seed 0) are clean
FAULTS = "exit-once:1000004,exit:1000005,raise:1000006"


@pytest.fixture(scope="module")
def reference():
    r = mc.evaluate(DESIGN, 4, 0, NoiseModel(), SHORT, mc.InProcessBackend(), record_trace=True)
    return [s.outcome() for s in r.samples]


def check_backend(backend, reference):
    r = mc.evaluate(DESIGN, 4, 0, NoiseModel(), SHORT, backend, record_trace=True)
    assert [s.outcome() for s in r.samples] == reference      # bit for bit, traces included

    f = mc.evaluate(DESIGN, 5, 1, NoiseModel(), FAST, backend)
    by_seed = {s.seed - 1_000_003: s for s in f.samples}
    assert sorted(by_seed) == [0, 1, 2, 3, 4]                  # nothing dropped
    assert by_seed[1].category == "closing never triggered" and by_seed[1].attempts == 2
    assert by_seed[2].category == "worker error" and "died" in by_seed[2].failure_reason
    assert by_seed[3].category == "worker error" and "injected fault" in by_seed[3].failure_reason
    assert by_seed[2].attempts == by_seed[3].attempts == 2
    assert by_seed[0].category == by_seed[4].category == "closing never triggered"
    assert f.failures_by_reason == {"closing never triggered": 3, "worker error": 2}

    # the backend still works after its workers died
    again = mc.evaluate(DESIGN, 2, 0, NoiseModel(), SHORT, backend, record_trace=True)
    assert [s.outcome() for s in again.samples] == reference[:2]


def test_process_pool_identical_and_survives_worker_death(reference, monkeypatch):
    monkeypatch.setenv(mc.FAULT_ENV, FAULTS)
    with mc.ProcessPoolBackend(2) as be:
        check_backend(be, reference)


def test_local_dask_identical_and_survives_worker_death(reference, monkeypatch):
    pytest.importorskip("distributed")
    monkeypatch.setenv(mc.FAULT_ENV, FAULTS)
    with mc.DaskBackend("local", 2) as be:
        check_backend(be, reference)


def test_make_backend():
    assert isinstance(mc.make_backend(workers=0), mc.InProcessBackend)
    assert isinstance(mc.make_backend(workers=3), mc.ProcessPoolBackend)
    assert mc.make_backend(workers=3).workers == 3
    assert isinstance(mc.make_backend(scheduler="local"), mc.DaskBackend)
    assert mc.make_backend(scheduler="tcp://1.2.3.4:8786").scheduler == "tcp://1.2.3.4:8786"


def test_dask_by_scheduler_address(reference):
    """A cluster reached by address (what --scheduler tcp://... does)."""
    pytest.importorskip("distributed")
    import logging

    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.CRITICAL) as cluster:
        with mc.DaskBackend(cluster.scheduler_address) as be:
            r = mc.evaluate(DESIGN, 2, 0, NoiseModel(), SHORT, be, record_trace=True)
            assert be.workers == 1 and cluster.scheduler_address in be.describe()
    assert [s.outcome() for s in r.samples] == reference[:2]
