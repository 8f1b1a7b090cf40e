"""A node of the suite that dies during an episode is noticed at once, not after the
stall timeout: its process killed (SIGKILL, which the ROS graph shows only after DDS's
participant lease, about 20 s), the capture answers ABORTED naming it, by the liveliness
of the topic that shows it alive (names.WATCHED, qos.ALIVE_DEADLINE_S).  The stall
timeout is set far above that here, so an answer that waited for it fails the test."""
from __future__ import annotations

import os
import signal
import time

import pytest

pytest.importorskip("rclpy", reason="ROS 2 wheels not installed: run scripts/setup.sh")

from ros_graph import private_domain  # noqa: E402
from tethernet_msgs.srv import RunCapture  # noqa: E402

from tethernet_ros.core.config import SimConfig  # noqa: E402
from tethernet_ros.core.design import load_design  # noqa: E402
from tethernet_ros.core.noise import NoiseModel  # noqa: E402
from tethernet_ros.core.sensing import SensingConfig  # noqa: E402
from tethernet_ros.ros.names import WATCHED  # noqa: E402
from tethernet_ros.ros.suite import RosSuite, suite_environment  # noqa: E402

pytestmark = [pytest.mark.ros, pytest.mark.timeout(300)]

STALL = 60.0           # s: the last resort, far above what the liveliness needs
#: lockstep at 50 Hz, so that every node of the suite takes part until closing
CONFIG = SimConfig(settle_time=2.0, sensing=SensingConfig(rate_hz=50.0))


@pytest.mark.parametrize("victim", sorted(WATCHED.values()))
def test_a_killed_node_aborts_the_capture_naming_it(tmp_path, victim):
    domain = private_domain(70 + sorted(WATCHED.values()).index(victim))
    suite = RosSuite(config=CONFIG, noise_model=NoiseModel(), bag_dir=tmp_path / "bags",
                     log_dir=tmp_path / "logs", lockstep=True,
                     env={**suite_environment(), "ROS_DOMAIN_ID": str(domain)},
                     params={"capture_node": {"stall_timeout": STALL, "ready_timeout": 2.0}})
    with suite:
        future = suite.client.call_async(suite.request(load_design("baseline"), 5,
                                                       bag_name="dies"))
        # in flight, before closing starts (the loop's nodes all take part until then)
        assert suite.spin_until(lambda: len(suite.metrics) >= 3, timeout=120), "no states"
        os.kill(suite.procs[victim].pid, signal.SIGKILL)
        killed = time.monotonic()
        assert suite.spin_until(future.done, timeout=STALL / 2), "no answer before the stall"
        waited = time.monotonic() - killed
        print(f"{victim}: answered {waited:.2f} s after SIGKILL")      # (pytest -s)
        resp = future.result()
        assert resp.status == RunCapture.Response.ABORTED, (resp.status, resp.error)
        assert resp.error.startswith(f"{victim} (no live publisher"), (waited, resp.error)
        assert "left the suite during the episode" in resp.error
        assert resp.bag_path.endswith("dies.partial")
        # the next request is refused at once, naming it, while the graph still lists it
        resp = suite.call(suite.request(load_design("baseline"), 6, record_bag=False),
                          timeout=60, check_processes=False)
        assert resp.status == RunCapture.Response.REJECTED, resp.error
        assert f"{victim} (no live publisher" in resp.error and "not alive" in resp.error
