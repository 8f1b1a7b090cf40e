"""ROS parameter defaults of the nodes, and reading them.

config/tethernet.yaml mirrors these defaults (tests/test_ros_bags.py checks that they
agree).  Rates are in Hz of *simulated* time; timeouts in wall-clock seconds; SI units.
The actuator's noise spreads default to the core's NoiseModel (docs/noise.md §1).
"""
from __future__ import annotations

from ..core.noise import SPREAD_FIELDS, NoiseModel
from .names import SERVICE, TOPICS

#: parameter defaults per node (nested names use '.')
DEFAULTS: dict[str, dict] = {
    "sim_node": {
        "publish_rate": 10.0,        # NetState / target pose / clock rate (Hz of sim time)
        "marker_rate": 2.0,          # MarkerArray rate (Hz of sim time)
        "real_time_factor": 0.0,     # > 0: pace the episode at this multiple of real time
        "frame_id": "chaser",
        "queue_depth": 1000,
        "min_state_subscribers": 2,  # monitor + recorder: wait for them before stepping
        "match_timeout": 5.0,        # s (wall) to wait for those subscribers
        "warm_up": True,             # load the numba kernels before announcing the node
    },
    "monitor_node": {
        "queue_depth": 1000,
        "frame_id": "chaser",
    },
    "actuator_node": {
        # spreads of docs/noise.md §1 (each request's NoiseSettings scales them)
        **{f"noise.{k}": float(v) for k, v in NoiseModel().spreads().items()},
        "min_command_subscribers": 3,         # sim + monitor + recorder
        "match_timeout": 5.0,
        "frame_id": "chaser",
    },
    "capture_node": {
        "bag_dir": "bags",
        "compression": "zstd",       # MCAP chunk compression: zstd or none
        "settle_time": 20.0,         # s (sim) after closing activation: docs/model.md §7
        "horizon": 120.0,            # s (sim): docs/model.md §7
        "sim_config": "{}",          # JSON of further SimConfig overrides
        "start_timeout": 60.0,       # s (wall) for the first state of an episode
        "stall_timeout": 15.0,       # s (wall) without a new state -> the episode is aborted
        "episode_timeout": 3600.0,   # s (wall) for a whole episode
        "ready_timeout": 30.0,       # s (wall) to wait for the other nodes before an episode
        "drain_time": 0.0,           # s (wall) of extra quiet time before closing a bag
                                     # (completeness is checked by stamps, not by waiting)
        # topics recorded in bags (keys of TOPICS; names.ALWAYS_RECORDED are added);
        # /clock and the target pose are left out by default: the states carry both
        "record_topics": ["setup", "launch_command", "closing_command", "net_state", "markers",
                          "metrics", "result", "verdict"],
    },
}
for _node in DEFAULTS.values():
    _node.update({f"topics.{k}": v for k, v in TOPICS.items()})
DEFAULTS["capture_node"]["service"] = SERVICE


def declare(node, name: str) -> None:
    """Declare every default parameter of ``name`` (a key of DEFAULTS) on ``node``."""
    for key, value in DEFAULTS[name].items():
        node.declare_parameter(key, value)


def param(node, key: str):
    return node.get_parameter(key).value


def topic(node, key: str) -> str:
    return node.get_parameter(f"topics.{key}").value


def node_spreads(node) -> dict[str, float]:
    """The actuator node's noise spreads (its ``noise.*`` parameters)."""
    return {k: float(param(node, f"noise.{k}")) for k in SPREAD_FIELDS}
