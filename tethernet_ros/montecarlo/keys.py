"""Run keys: the identity of the episodes a (design, noise model, config) produces.

A results-file record carries the key of its run; a record is reused only under the same
key, so results of another design, noise model, configuration, seed mapping or simulator
source are never mixed in.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import asdict
from functools import lru_cache
from pathlib import Path

from ..core.config import SimConfig
from ..core.design import Design
from ..core.noise import NoiseModel
from .seeds import SEED_STRIDE


@lru_cache(maxsize=1)
def model_version() -> str:
    """Hash of the simulator core's source (tethernet_ros/core/**/*.py), so that results of
    a changed model are never reused.  Computed once per process."""
    from .. import core as core_pkg

    return model_version_of(Path(core_pkg.__file__).parent)


def model_version_of(core: Path) -> str:
    """The model version of a copy of tethernet_ros/core (e.g. of an earlier commit)."""
    h = hashlib.sha256()
    for p in sorted(Path(core).rglob("*.py")):
        h.update(p.relative_to(core).as_posix().encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def run_key(design: Design, noise_model: NoiseModel, config: SimConfig,
            model: str | None = None, episode_source: str | None = None) -> str:
    """Identity of the episodes a (design, noise model, config) produces for a seed, under
    this process's model version (or ``model``, one recorded in a results file), and, when
    something outside the library decides them (``episode_source``: a user's controller,
    :attr:`.backends.EpisodeBackend.episode_source`), its identity."""
    ident = {"design": design.to_dict(), "noise": asdict(noise_model), "config": config.to_dict(),
             "seed_map": f"b*{SEED_STRIDE}+i", "model": model or model_version()}
    if episode_source is not None:
        ident["episode_source"] = str(episode_source)
    blob = json.dumps(ident, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:20]
