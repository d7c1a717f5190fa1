"""The standard ROS 2 messages' codec: rosbags' type store of ROS 2 Jazzy (no codec of our own), CDR as rmw_zenoh
and rosbag2 carry it, and each type's RIHS01 hash and full definition (what rmw_zenoh's keys and tokens and a
bag's schemas name)."""

from __future__ import annotations

from functools import cache

from rosbags.typesys import Stores, get_typestore


@cache
def typestore():
    """The standard message definitions (ROS 2 Jazzy's; their RIHS01 hashes are the distribution's)."""
    return get_typestore(Stores.ROS2_JAZZY)


@cache
def type_hash(msgtype: str) -> str:
    return typestore().hash_rihs01(msgtype)


@cache
def msgdef(msgtype: str) -> str:
    """The full .msg text with its dependencies (rosbag2's `ros2msg` schema encoding)."""
    return typestore().generate_msgdef(msgtype, ros_version=2)[0]


def serialize(msg, msgtype: str) -> bytes:
    """CDR (XCDR1, little-endian, with its 4-byte encapsulation header), as rmw_zenoh and rosbag2 carry it."""
    return bytes(typestore().serialize_cdr(msg, msgtype))


def deserialize(data: bytes, msgtype: str):
    return typestore().deserialize_cdr(data, msgtype)
