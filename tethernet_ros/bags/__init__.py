"""rosbag2 bags of captures: one folder per episode, MCAP storage, metadata version 9.

naming.py     the one home of the bag naming rule: names, ``<name>.partial/``, INCOMPLETE
typestore.py  message definitions and type hashes (rosbags' Jazzy store + tethernet_msgs)
writer.py     BagWriter over rosbags' rosbag2 Writer; atomic completion by rename
reader.py     read_bag: damage-tolerant reading (mcap + mcap-ros2-support)
damage.py     copy_truncated: a damaged copy of a bag, for tests and demonstrations

No ROS import: bags are written from serialized CDR messages and read without rclpy.
"""
from .naming import MARKER, PARTIAL_SUFFIX, BagError
from .reader import BagContents, BagMessage, describe, read_bag
from .typestore import message_definition, type_hash
from .writer import BagWriter, qos_profile
from .damage import copy_truncated

__all__ = ["BagError", "BagWriter", "BagContents", "BagMessage", "read_bag", "message_definition",
           "type_hash", "qos_profile", "copy_truncated", "MARKER", "PARTIAL_SUFFIX", "describe"]
