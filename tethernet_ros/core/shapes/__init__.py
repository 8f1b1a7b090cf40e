"""The target as a shape (docs/model.md §15): one type that the kernel, sensing, policies,
metrics, tumble, markers and figures all read, whatever the target is.

A :class:`Shape` is a rigid body in its own body frame: the origin at its centre of mass,
the axes its principal axes, ordered so that body x is the axis of least inertia (the
"long" axis) and body y the axis of greatest inertia (a "flat" spin, where a dissipating
body ends up); body z is the remaining one (the line of sight at the nominal attitude).
Units: m, kg, kg m^2.

Kinds, each one module (a new kind is one more module, one more entry in ``_kinds()`` and
the settings that select it, ``TargetConfig.kind``):

- ``revolution`` (:mod:`.revolution`): the Zenit-2 stage of the source, exact solids of
  revolution (the default; every result before shapes existed is this kind's);
- ``mesh`` (:mod:`.mesh`): a closed triangle mesh read from a file by trimesh, its mass
  properties computed in IEEE operations (:mod:`.mass_properties`).

:func:`target_shape` is the one dispatch from a :class:`~tethernet_ros.core.target.TargetConfig`
to its shape; it caches one shape per configuration in each process.
"""
from __future__ import annotations

import functools

from .base import Shape


def _kinds() -> dict:
    """The shape kinds, by the name ``TargetConfig.kind`` gives."""
    from .mesh import MeshShape
    from .revolution import RevolutionShape

    return {"revolution": RevolutionShape, "mesh": MeshShape}


@functools.lru_cache(maxsize=16)
def target_shape(config) -> Shape:
    """The shape of a target configuration (``core.target.TargetConfig``), built once per
    configuration and process."""
    return _kinds()[config.kind].from_config(config)


__all__ = ["Shape", "target_shape"]
