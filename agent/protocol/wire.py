"""Binary state record exchanged between agents (wire format v2): a typed wrapper of the one implementation,
the agent crate's wire.rs (agent/native/src/wire.rs, called through agent._native).

Layout, little-endian, 104 bytes (docs/protocol.md): version (= 2) u8, kind (= 1) u8, flags u16 (bit 0:
frozen), agent id u32, step u32, particle class u16, reserved u16, then 11 f64: x, y, vx, vy, rho, p, sxx,
sxy, syy (SI units; rho/p/s of the previous step), heading [rad] in [-pi, pi] and forward speed [m/s].

Messages come from the network and are untrusted: `decode_state` checks version, length, kind, finiteness
and ranges, and returns (None, reason) (the caller counts the rejection) instead of raising. The version
byte comes first, so a record of an older version is refused as such ("version": v1, the 88-byte record
without a pose), whatever its length.
"""

from __future__ import annotations

from collections.abc import Sequence

from agent.records import native

VERSION = native.STATE_VERSION
KIND_STATE = native.STATE_KIND
STATE_SIZE = native.STATE_SIZE  # 104
MAX_ID = native.STATE_MAX_ID
MAX_ABS = native.STATE_MAX_ABS  # larger magnitudes are garbage, not physics

# Reasons a message is rejected (the counters' names).
REJECT_LENGTH = "length"
REJECT_VERSION = "version"
REJECT_VALUE = "value"

# ((agent_id, step, particle_class, values), None) with values a tuple of NFIELDS floats, or (None, reason). A tuple
# of floats: immutable, and not tracked by the garbage collector.
decode_state = native.state_decode

# ((agent_id, x, y), None) of a state record, for routing it by position (the relays), or (None, reason) as
# decode_state gives it for the header and the position. Receivers decode it in full.
peek_id_position = native.state_peek_id_position

# (agent_id, step) of a state record without decoding its values (observers that only follow the run's
# progress), or None if it is not a record of this length.
peek_id_step = native.state_peek_id_step


def batch_records(data: bytes) -> list[bytes] | None:
    """The state records of a router's batch (docs/protocol.md "State batches": whole records, concatenated), or
    None when its length is not a whole number of records (refused whole). Each record is still the receiver's to
    check."""
    if len(data) % STATE_SIZE:
        return None
    return [data[at : at + STATE_SIZE] for at in range(0, len(data), STATE_SIZE)]


def encode_state(agent_id: int, step: int, state: Sequence[float], particle_class: int = 0) -> bytes:
    """The record of `state` (NFIELDS values, agent/sph/particle.py; FROZEN nonzero: flags bit 0)."""
    return native.state_encode(agent_id, step, [float(v) for v in state], particle_class)
