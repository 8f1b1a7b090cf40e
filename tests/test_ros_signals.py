"""Every node stops cleanly on SIGTERM as on SIGINT, idle or mid-capture, and a bag being
recorded is left marked INCOMPLETE (readable up to where it stopped).

Each node runs as its own process (as a process manager or a launch file starts it); the
test sends the signal to that process and waits for it to exit with status 0.  The
generous WAIT bound is only there so that a node that ignores the signal fails the test
instead of hanging it; the measured exit times are printed (``-s``) for the record.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("rclpy", reason="ROS 2 wheels not installed: run scripts/setup.sh")

from tethernet_ros.bags import MARKER, BagError, read_bag  # noqa: E402
from tethernet_ros.core.config import SimConfig  # noqa: E402
from tethernet_ros.core.design import load_design  # noqa: E402
from tethernet_ros.core.noise import NoiseModel  # noqa: E402
from tethernet_ros.ros.names import NODES, TOPICS  # noqa: E402
from tethernet_ros.ros.suite import RosSuite, suite_environment  # noqa: E402

pytestmark = [pytest.mark.ros, pytest.mark.timeout(300)]

ROOT = Path(__file__).resolve().parent.parent
WAIT = 10.0          # s: a container runtime's grace period before it sends SIGKILL


def stop_with(proc: subprocess.Popen, sig: int) -> tuple[int | None, float]:
    """(exit status or None if still running after WAIT s, seconds it took)."""
    t0 = time.monotonic()
    proc.send_signal(sig)
    try:
        code = proc.wait(timeout=WAIT)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGUSR1)        # the node's stacks into its log (runner.py)
        time.sleep(1.0)
        proc.kill()
        proc.wait()
        code = None
    return code, time.monotonic() - t0


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_idle_nodes_stop_on_signal(tmp_path, sig):
    env = suite_environment()
    env["ROS_DOMAIN_ID"] = str((os.getpid() + sig) % 100 + 1)   # not another test's suite
    procs, logs = {}, {}
    for name in NODES:
        logs[name] = tmp_path / f"{name}.log"
        procs[name] = subprocess.Popen(
            [sys.executable, "-m", f"tethernet_ros.ros.nodes.{name}", "--ros-args",
             "--params-file", str(ROOT / "config" / "tethernet.yaml"),
             "-p", f"bag_dir:={tmp_path / 'bags'}"],
            stdout=open(logs[name], "wb"), stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
            env=env, cwd=tmp_path, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        for name in NODES:
            while "ready" not in logs[name].read_text(errors="replace"):
                assert procs[name].poll() is None, logs[name].read_text(errors="replace")
                assert time.monotonic() < deadline, f"{name} did not get ready"
                time.sleep(0.1)
        for name in NODES:
            code, took = stop_with(procs[name], sig)
            print(f"{name}: {signal.Signals(sig).name} idle -> exit {code} after {took:.2f} s")
            text = logs[name].read_text(errors="replace")
            assert code == 0, f"{name}: exit {code}; log: {text[-2000:]}"
            assert "Traceback" not in text
    finally:
        for p in procs.values():
            if p.poll() is None:
                p.kill()
                p.wait()


def recorded(bag: Path, topic: str, every: float = 0.5):
    """A predicate: the bag being written at ``bag`` holds a message of ``topic`` in a
    whole chunk on disk (read at most every ``every`` s)."""
    last = [0.0, False]

    def check() -> bool:
        if not last[1] and time.monotonic() - last[0] >= every:
            last[0] = time.monotonic()
            try:
                last[1] = bool(read_bag(bag, topics={topic}, decode=False).counts().get(topic))
            except (BagError, OSError):
                last[1] = False
        return last[1]
    return check


def test_nodes_stop_on_sigterm_mid_capture(tmp_path):
    """SIGTERM to each node while an episode runs: first the capture node (recording),
    whose bag stays marked INCOMPLETE with the reason and readable up to the stop; then the
    simulation node, which is still stepping, the monitor and the actuator.  The signal
    comes once the recorder has written a chunk of states: on a loaded machine (make test
    beside a Case run) the test once had 5 of the monitor's metrics while the recorder
    had recorded no state, and the stopped bag held none."""
    bag_dir = tmp_path / "bags"
    suite = RosSuite(config=SimConfig(), noise_model=NoiseModel(), bag_dir=bag_dir,
                     log_dir=tmp_path / "logs",
                     env={**os.environ, "ROS_DOMAIN_ID": str(os.getpid() % 100 + 101)})
    suite.start()
    try:
        future = suite.client.call_async(suite.request(load_design("baseline"), 5,
                                                       bag_name="stopped"))
        assert suite.spin_until(lambda: len(suite.metrics) >= 5, timeout=120), "no states"
        assert suite.spin_until(recorded(bag_dir / "stopped.partial", TOPICS["net_state"]),
                                timeout=120), "the recorder wrote no chunk of states"
        for name in ("capture_node", "sim_node", "monitor_node", "actuator_node"):
            if name == "sim_node":
                n = len(suite.metrics)
                assert suite.spin_until(lambda n=n: len(suite.metrics) > n, timeout=30), \
                    "the simulation is not running any more"
            code, took = stop_with(suite.procs[name], signal.SIGTERM)
            print(f"{name}: SIGTERM mid-capture -> exit {code} after {took:.2f} s")
            assert code == 0, f"{name}: exit {code}; log: {suite.log_tail(name, 20)}"
            assert "Traceback" not in (suite.log_dir / f"{name}.log").read_text(errors="replace")
        assert not future.done()              # the service went with its node: no answer
    finally:
        suite.stop()
    bag = bag_dir / "stopped.partial"
    assert sorted(p.name for p in bag_dir.iterdir()) == ["stopped.partial"]
    assert (bag / MARKER).read_text().startswith("incomplete: the capture node shut down")
    assert not (bag / "metadata.yaml").exists()
    contents = read_bag(bag)
    assert not contents.complete
    assert contents.counts()[TOPICS["setup"]] == 1            # readable up to the stop
    assert contents.by_topic(TOPICS["net_state"])
