"""Message definitions and type hashes for bags, from rosbags' type system.

The standard types (std_msgs, geometry_msgs, visualization_msgs, rosgraph_msgs,
builtin_interfaces) come from rosbags' ROS 2 Jazzy store; the tethernet_msgs types are
registered from the ``.msg`` files installed under ``<prefix>/share/tethernet_msgs/msg``
(the venv, or $AMENT_PREFIX_PATH), or else from msg_defs/ of the source tree.  rosbags
generates the ros2msg definition (every nested type after a ``====`` / ``MSG:`` line, as
rosbag2 embeds it) and the RIHS01 type hash, which equals rosidl's (tested).
"""
from __future__ import annotations

import os
import sys
from functools import lru_cache
from pathlib import Path

from .naming import BagError

PACKAGE = "tethernet_msgs"
SOURCE_MSGS = Path(__file__).resolve().parents[2] / "msg_defs" / "msg"


def _msg_folder() -> Path:
    prefixes = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    for prefix in [*prefixes, Path(sys.prefix)]:
        folder = prefix / "share" / PACKAGE / "msg"
        if folder.is_dir():
            return folder
    if SOURCE_MSGS.is_dir():
        return SOURCE_MSGS
    raise BagError(f"the {PACKAGE} message files are not installed (run scripts/setup.sh)")


@lru_cache(maxsize=1)
def typestore():
    """rosbags Typestore: Jazzy's standard types plus tethernet_msgs."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    types = {}
    for path in sorted(_msg_folder().glob("*.msg")):
        types.update(get_types_from_msg(path.read_text(), f"{PACKAGE}/msg/{path.stem}"))
    store.register(types)
    return store


def _known(msgtype: str) -> str:
    if msgtype not in typestore().fielddefs:
        raise BagError(f"message type {msgtype!r} is unknown (expected pkg/msg/Name of "
                       f"{PACKAGE} or a standard Jazzy package)")
    return msgtype


def message_definition(msgtype: str) -> str:
    """ros2msg definition of ``msgtype`` with every nested type, as rosbag2 embeds it."""
    text, _ = typestore().generate_msgdef(_known(msgtype), ros_version=2)
    return text


def type_hash(msgtype: str) -> str:
    """RIHS01 type-description hash of ``msgtype``."""
    return typestore().hash_rihs01(_known(msgtype))
