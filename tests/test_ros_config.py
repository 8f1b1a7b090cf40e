"""config/tethernet.yaml and the nodes' built-in parameter defaults agree."""
import os

import yaml

from tethernet_ros.nodes.common import DEFAULTS

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _flatten(d, prefix=""):
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flatten(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def test_yaml_defaults_match_node_defaults():
    with open(os.path.join(ROOT, "config", "tethernet.yaml")) as f:
        cfg = yaml.safe_load(f)
    shared = _flatten(cfg["/**"]["ros__parameters"])
    for node, defaults in DEFAULTS.items():
        params = dict(shared)
        params.update(_flatten(cfg.get(f"/{node}", {}).get("ros__parameters", {})))
        for key, value in defaults.items():
            assert key in params, f"{node}: {key} missing from config/tethernet.yaml"
            assert params[key] == value, f"{node}: {key} is {params[key]!r} in the YAML, {value!r} in the node"
