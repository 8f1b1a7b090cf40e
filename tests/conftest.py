import os
import sys

sys.path.insert(0, os.path.dirname(__file__))

# ROS 2 isolation for tests that use rclpy: a DDS domain of this test process's own, and
# discovery kept on this host (Jazzy's default, SUBNET, multicasts to 239.255.0.1 on the
# network interface). Set before any test module imports rclpy; the environment wins.
os.environ.setdefault("ROS_DOMAIN_ID", str(os.getpid() % 100 + 100))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: long physics studies (CI runs them; -m 'not slow' skips)")
    config.addinivalue_line("markers", "second_half: run by scripts/test.sh in its second process")
    config.addinivalue_line("markers", "ros: needs the ROS 2 Jazzy wheels and tethernet_msgs (scripts/setup.sh)")
    # lark (rosidl's IDL parser, imported by rclpy) imports modules deprecated in 3.11
    config.addinivalue_line("filterwarnings", "ignore:module 'sre_:DeprecationWarning")


#: core modules that scripts/test.sh runs beside the ROS tests (the longest of them, so
#: that the two halves take about the same time on 2 cores: measured 2026-12-02, the ROS
#: tests 254 s and the rest 710 s; 2026-12-06, the second half 505 s and the first 639 s,
#: when the last three joined it, about 75 s between them)
BESIDE_ROS = ("test_core_statistics.py", "test_reproducibility.py", "test_montecarlo_golden.py",
              "test_studies_summary.py", "test_montecarlo_cli.py")


def pytest_collection_modifyitems(config, items):
    """Every test of a ``test_ros_*`` module carries the ``ros`` marker, and the tests that
    scripts/test.sh runs in its second process (the ROS tests, in file order as some of
    them require, and the modules of :data:`BESIDE_ROS`) the ``second_half`` marker."""
    import pytest

    for item in items:
        if item.path.name.startswith("test_ros_") and not item.get_closest_marker("ros"):
            item.add_marker(pytest.mark.ros)
        if item.get_closest_marker("ros") or item.path.name in BESIDE_ROS:
            item.add_marker(pytest.mark.second_half)
