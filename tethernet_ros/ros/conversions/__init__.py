"""Conversions between tethernet_msgs / common_interfaces messages and the core's objects:
one module per message family (as rosbags keeps a file per concept), gathered here:
``<thing>_msg(...)`` builds a message, ``<thing>_from_msg(msg)`` reads one back.

Readers use attribute access only, so they accept rclpy messages as well as messages
decoded from a bag by mcap-ros2-support or rosbags.  Builders import the rclpy message
classes lazily.  Readers of request fields validate them: RequestError names the field.

Units: SI; times in s (builtin_interfaces/Time: sec + nanosec).  Quaternions are
(w, x, y, z) in the core and (x, y, z, w) in geometry_msgs.  NetState body order is the
core's body layout (core/layout.py): 289 net nodes (row-major), 4 corner masses, then
the main tether's lumped masses from the net centre toward the chaser, whose last entry
is the winch body on the chaser (so ``num_tether_nodes`` = tether_segments).
"""
from __future__ import annotations

from .errors import RequestError
from .stamps import split_time, set_time, time_from_msg
from .design import DESIGN_FIELDS, design_msg, design_from_msg
from .noise import (NOISE_FIELDS, noise_settings_msg, noise_settings_from_msg, noise_model_from_msg,
                    noise_sample_msg, noise_sample_from_msg)
from .setup import (LAUNCH_REQUEST_FIELDS, tumble_msg, tumble_from_msg, config_with_tumble,
                    launch_from_request, target_from_request, criterion_from_request, check_pull,
                    config_overrides, config_from_json, setup_msg, setup_from_msg)
from .commands import launch_command_msg, closing_command_msg, commands_from_msgs
from .states import net_state_msg, net_state_from_msg, target_pose_msg, clock_msg
from .loop import (measurement_msg, measurement_from_msg, decision_msg, launch_decision_msg,
                   sensed_msgs)
from .results import (TERM_FIELDS, TUG_FIELDS, metrics_msg, metrics_from_cdr, terms_from_msg,
                      episode_result_msg, episode_result_from_msg, tug_from_msg)
from .capture import Outcome, capture_reply, capture_feedback_msg, cancel_msg

__all__ = ["TUG_FIELDS", "tug_from_msg",
           "RequestError", "split_time", "set_time", "time_from_msg", "DESIGN_FIELDS", "design_msg",
           "design_from_msg", "NOISE_FIELDS", "noise_settings_msg", "noise_settings_from_msg",
           "noise_model_from_msg", "noise_sample_msg", "noise_sample_from_msg", "tumble_msg",
           "tumble_from_msg", "config_with_tumble", "LAUNCH_REQUEST_FIELDS", "launch_from_request",
           "target_from_request", "criterion_from_request", "check_pull",
           "config_overrides",
           "config_from_json", "setup_msg", "setup_from_msg", "launch_command_msg",
           "closing_command_msg", "commands_from_msgs", "net_state_msg", "net_state_from_msg",
           "target_pose_msg", "clock_msg", "measurement_msg", "measurement_from_msg",
           "decision_msg", "launch_decision_msg", "sensed_msgs", "TERM_FIELDS", "metrics_msg", "metrics_from_cdr",
           "terms_from_msg", "episode_result_msg", "episode_result_from_msg", "Outcome",
           "capture_reply", "capture_feedback_msg", "cancel_msg"]
