"""Former home of the ROS episode backend; it is :mod:`tethernet_ros.ros.backend` now.

Kept only while ``tethernet_ros/commands/optimize.py`` imports it from here; remove it
when that import names ``..ros.backend``.
"""
from .ros.backend import BagResultError, RosBackend, result_from_bag  # noqa: F401
