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
    config.addinivalue_line("markers", "ros: needs the ROS 2 Jazzy wheels and tethernet_msgs (scripts/setup.sh)")
    # lark (rosidl's IDL parser, imported by rclpy) imports modules deprecated in 3.11
    config.addinivalue_line("filterwarnings", "ignore:module 'sre_:DeprecationWarning")


def pytest_collection_modifyitems(config, items):
    """Under pytest-xdist (``make test``: ``-n 2 --dist loadgroup``) every ROS test runs
    on one worker, one after the other, as without xdist: their suites choose ROS domains
    from their process id, and two suites in one domain would answer each other."""
    import pytest

    for item in items:
        if item.get_closest_marker("ros") or item.path.name.startswith("test_ros_"):
            item.add_marker(pytest.mark.xdist_group("ros"))
