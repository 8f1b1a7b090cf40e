"""LaunchCommand.msg and ClosingCommand.msg from and to the core's actions and world."""
from __future__ import annotations

import array
import numpy as np

from ...core.noise import (NoiseModel, NoiseSample)
from ...core.scenario import Actions, World
from .noise import noise_sample_msg


def launch_command_msg(actions: Actions, world: World, seed: int | None, key: tuple[int, int],
                       frame_id: str = "chaser", sample: NoiseSample | None = None,
                       model: NoiseModel | None = None):
    """LaunchCommand: noisy corner velocities and the target placement and tumble the
    actuator drew, with the draw itself (``sample`` of ``model``; None: nominal).  Its
    header stamp is the EpisodeSetup's stamp (the episode's correlation key)."""
    from tethernet_msgs.msg import LaunchCommand

    m = LaunchCommand()
    m.header.stamp.sec, m.header.stamp.nanosec = key
    m.header.frame_id = frame_id
    m.seed = 0 if seed is None else int(seed)
    m.corner_velocities = array.array("d", np.ascontiguousarray(actions.corner_velocities,
                                                                dtype=float).tobytes())
    m.distance_to_target = float(world.distance)
    m.target_rotation = float(world.rotation)
    m.rotation_axis = world.rotation_axis
    m.spin_rate = float(world.spin_rate)
    m.spin_axis = [float(c) for c in world.spin_axis]
    m.spin_phase = float(world.spin_phase)
    m.noise = noise_sample_msg(sample, model)
    return m


def closing_command_msg(actions: Actions, key: tuple[int, int], frame_id: str = "chaser"):
    """ClosingCommand: the noisy closing displacement (m), stamped like the launch."""
    from tethernet_msgs.msg import ClosingCommand

    m = ClosingCommand()
    m.header.stamp.sec, m.header.stamp.nanosec = key
    m.header.frame_id = frame_id
    m.closing_displacement = float(actions.closing_displacement)
    return m


def commands_from_msgs(launch, closing) -> tuple[Actions, World]:
    """The core's Actions and World of a LaunchCommand and a ClosingCommand."""
    cv = np.array(np.asarray(launch.corner_velocities, dtype=float)).reshape(4, 3)
    actions = Actions(corner_velocities=cv, closing_displacement=float(closing.closing_displacement))
    spin = {}
    rate = float(getattr(launch, "spin_rate", 0.0))       # (a bag from before the tumble: 0)
    if rate != 0.0:
        spin = dict(spin_rate=rate, spin_axis=tuple(float(c) for c in launch.spin_axis),
                    spin_phase=float(launch.spin_phase))
    drawn = getattr(launch, "noise", None)                # the target's mass properties' draws
    world = World(distance=float(launch.distance_to_target), rotation=float(launch.target_rotation),
                  rotation_axis=launch.rotation_axis or "z",
                  target_mass_offset=float(getattr(drawn, "target_mass_offset", 0.0)),
                  target_inertia_offsets=tuple(float(v) for v in getattr(
                      drawn, "target_inertia_offsets", (0.0, 0.0, 0.0))),
                  target_com_offset=tuple(float(v) for v in getattr(
                      drawn, "target_com_offset", (0.0, 0.0, 0.0))), **spin)
    return actions, world
