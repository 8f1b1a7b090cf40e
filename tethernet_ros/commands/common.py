"""Arguments and helpers shared by several commands."""
from __future__ import annotations

import argparse
import json

from optimizer.jsonio import json_clean

from ..core.design import Design, load_design
from ..core.noise import NOISE_SOURCES, NoiseModel
from ..errors import UserError


def add_design_argument(p: argparse.ArgumentParser) -> None:
    p.add_argument("--design", required=True, metavar="NAME|FILE.yaml",
                   help="reference design (baseline, suboptimal, mass-min, time-min) or a YAML "
                        "file with keys m_c, L_n, r_n, d_L, V_e, d_c")


def add_noise_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--noise-scale", action="append", default=[], metavar="SOURCE=FACTOR",
                   help=f"multiply one noise source's spread; sources: {', '.join(NOISE_SOURCES)} "
                        "(repeatable)")
    p.add_argument("--orientation-axis", choices=("z", "y"), default="z",
                   help="axis of the target-orientation noise (default z, the line of sight)")


def add_config_argument(p: argparse.ArgumentParser) -> None:
    p.add_argument("--config", default=None, metavar="FILE.yaml",
                   help="simulation settings overriding the defaults of docs/model.md (SimConfig fields, "
                        "e.g. settle_time: 20.0, dt_safety: 0.5, target: {nozzle: true})")


def config_from_args(args, **overrides):
    """SimConfig from --config (if given) with ``overrides`` applied on top."""
    from ..core.config import ConfigError, SimConfig

    data = {}
    if getattr(args, "config", None):
        import yaml
        from pathlib import Path

        path = Path(args.config)
        if not path.is_file():
            raise UserError(f"--config: file {str(path)!r} does not exist")
        try:
            data = yaml.safe_load(path.read_text()) or {}
        except yaml.YAMLError:
            raise UserError(f"--config: file {str(path)!r} is not valid YAML") from None
        if not isinstance(data, dict):
            raise UserError(f"--config: file {str(path)!r} must hold a mapping of SimConfig fields")
    data.update(overrides)
    try:
        return SimConfig.from_dict(data)
    except TypeError as exc:
        raise ConfigError(f"config: {exc}") from None


def add_backend_arguments(p: argparse.ArgumentParser) -> None:
    """--workers / --scheduler: which EpisodeBackend runs the episodes."""
    p.add_argument("--workers", type=int, default=None, metavar="K",
                   help="local worker processes (default: all cores; 0: in this process)")
    p.add_argument("--scheduler", default=None, metavar="ADDR|local",
                   help="run on a Dask cluster at ADDR (tcp://host:8786), or 'local' for a "
                        "local Dask cluster of --workers processes")


def check_backend_arguments(args) -> None:
    if args.workers is not None and args.workers < 0:
        raise UserError(f"--workers {args.workers}: must be an integer >= 0 (0: in-process)")
    if args.scheduler is not None and args.workers == 0:
        raise UserError("--workers 0 (in-process) cannot be combined with --scheduler")


def backend_from_args(args):
    """The EpisodeBackend chosen by --workers / --scheduler."""
    from ..montecarlo import make_backend

    return make_backend(workers=args.workers, scheduler=args.scheduler)


def design_from_args(args) -> Design:
    return load_design(args.design)


def noise_model_from_args(args) -> NoiseModel:
    scales = {}
    for item in args.noise_scale:
        if "=" not in item:
            raise UserError(f"--noise-scale {item!r}: expected SOURCE=FACTOR, sources {list(NOISE_SOURCES)}")
        k, v = item.split("=", 1)
        try:
            scales[k.strip()] = float(v)
        except ValueError:
            raise UserError(f"--noise-scale {item!r}: FACTOR must be a number in [0, 100]") from None
    return NoiseModel(orientation_axis=args.orientation_axis, scales=scales)


def print_json(obj) -> None:
    print(json.dumps(json_clean(obj), indent=2, sort_keys=False))
