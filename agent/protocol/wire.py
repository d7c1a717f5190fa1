"""Binary state record exchanged between agents (wire format v2), encoded and decoded only here.

Layout, little-endian, 104 bytes (docs/protocol.md):

    offset  type     field
    0       u8       version (= 2)
    1       u8       kind (= 1, state)
    2       u16      flags (bit 0: frozen, the particle left the domain)
    4       u32      agent id
    8       u32      step
    12      u16      particle class (from the gesture command; 0 if none)
    14      u16      reserved (0)
    16      9 x f64  x, y, vx, vy, rho, p, sxx, sxy, syy   (SI units; rho/p/s of the previous step)
    88      f64      heading [rad] in [-pi, pi] (a unicycle robot's, agent/sph/robot.py; 0 otherwise)
    96      f64      forward speed [m/s] (a unicycle's; 0 otherwise)

Messages come from the network and are untrusted: `decode_state` checks version, length, kind, finiteness
and ranges, and returns None (the caller counts the rejection) instead of raising. The version byte comes
first, so a record of an older version is refused as such ("version": v1, the 88-byte record without a
pose), whatever its length.
"""

from __future__ import annotations

import math
import struct

from agent.sph.particle import FROZEN, HEADING, SPEED, X

VERSION = 2
KIND_STATE = 1
_HEADER = struct.Struct("<BBHIIHH")
_RECORD = struct.Struct("<BBHIIHH11d")
_ID_STEP = struct.Struct("<II")  # agent id and step, at offset 4
_HEAD_XY = struct.Struct("<BBHIIHH2d")  # the header and the first two values (x, y)
_FLAG_VALUE = (0.0, 1.0)  # flags bit 0 (frozen) as the state's FROZEN field
STATE_SIZE = _RECORD.size  # 104
_VERSION_BYTE = bytes([VERSION])
MAX_ID = 2**31 - 1
MAX_ABS = 1e12  # larger magnitudes are garbage, not physics

# Reasons a message is rejected (the counters' names).
REJECT_LENGTH = "length"
REJECT_VERSION = "version"
REJECT_VALUE = "value"


def encode_state(agent_id: int, step: int, state, particle_class: int = 0) -> bytes:
    flags = 1 if state[FROZEN] != 0.0 else 0
    return _RECORD.pack(
        VERSION,
        KIND_STATE,
        flags,
        agent_id,
        step,
        particle_class,
        0,
        *map(float, state[X:FROZEN]),
        float(state[HEADING]),
        float(state[SPEED]),
    )


def peek_id_step(data: bytes) -> tuple[int, int] | None:
    """(agent_id, step) of a state record without decoding its values (observers that only follow the
    run's progress), or None if it is not a record of this length."""
    if len(data) != STATE_SIZE:
        return None
    return _ID_STEP.unpack_from(data, 4)


def peek_id_position(data: bytes):
    """((agent_id, x, y), None) of a state record, for routing it by position (the relays), or
    (None, reason) as decode_state gives it for the header and the position. Receivers decode it in full."""
    if data[:1] != _VERSION_BYTE:
        return None, REJECT_VERSION
    if len(data) != STATE_SIZE:
        return None, REJECT_LENGTH
    version, kind, _flags, agent_id, _step, _cls, _pad, x, y = _HEAD_XY.unpack_from(data)
    if version != VERSION or kind != KIND_STATE:
        return None, REJECT_VERSION
    if not (-MAX_ABS <= x <= MAX_ABS and -MAX_ABS <= y <= MAX_ABS):  # also false for NaN and infinities
        return None, REJECT_VALUE
    return (agent_id, x, y), None


def decode_state(data: bytes):
    """(agent_id, step, particle_class, values) with values a tuple of NFIELDS floats, or (None, reason)."""
    if data[:1] != _VERSION_BYTE:
        return None, REJECT_VERSION
    if len(data) != STATE_SIZE:
        return None, REJECT_LENGTH
    record = _RECORD.unpack(data)
    version, kind, flags, agent_id, step, particle_class = record[:6]
    if version != VERSION or kind != KIND_STATE:
        return None, REJECT_VERSION
    if agent_id > MAX_ID or flags > 1:
        return None, REJECT_VALUE
    values = record[7:]
    for v in values:
        if not -MAX_ABS <= v <= MAX_ABS:  # also false for NaN and infinities
            return None, REJECT_VALUE
    if values[4] <= 0.0:  # a density must be positive
        return None, REJECT_VALUE
    if not -math.pi <= values[9] <= math.pi:  # a heading is an angle in [-pi, pi]
        return None, REJECT_VALUE
    # A tuple of floats: immutable, and not tracked by the garbage collector.
    return (agent_id, step, particle_class, values[:9] + (_FLAG_VALUE[flags],) + values[9:]), None
