"""A host's share clock in a split run (`fluidswarm/<run>/pace/<id>`, docs/protocol.md "Share clocks"): launcher
-> the launcher that owns the run's clock. Launchers only: no agent reads it, so it has no Rust twin.

In a split run each host's launcher follows only its own agents' states and says the slowest live one's step
here; the host that owns the run's clock (the main host; in a `launch`/`verify` split, the host holding the
swarm's smallest id) puts `ctl/clock` = the minimum over every host's share clock (swarmhost/pacing.py).

Payload, 14 bytes little-endian: version (u8, 1), flags (u8: bit 0 `done`: no agent of the share holds the
clock any more; no other bit), first (u32: the share's smallest agent id, also the key's id chunk), agents
(u32: how many agents the share holds, 1..MAX_AGENTS), step (u32: the share's clock). The key's id and
`first` must agree; anything else is malformed (decode_pace: None).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from agent.protocol import keys

VERSION = 1
_FORMAT = struct.Struct("<BBIII")
SIZE = _FORMAT.size  # 14
DONE = 1
MAX_STEP = 2**32 - 1


@dataclass(frozen=True)
class Pace:
    """Share clock of the host whose share's smallest id is `first` and holds `agents` agents: its slowest
    live agent is at `step`; `done`: none of them holds the clock any more (finished, or all lost)."""

    first: int
    agents: int
    step: int
    done: bool = False

    def encode(self) -> bytes:
        """The payload; ValueError for a field out of range."""
        if not 0 <= self.first < keys.MAX_AGENTS:
            raise ValueError(f"pace first {self.first}: ids 0..{keys.MAX_AGENTS - 1}")
        if not 1 <= self.agents <= keys.MAX_AGENTS:
            raise ValueError(f"pace agents {self.agents}: 1..{keys.MAX_AGENTS}")
        if not 0 <= self.step <= MAX_STEP:
            raise ValueError(f"pace step {self.step}: 0..{MAX_STEP}")
        return _FORMAT.pack(VERSION, DONE if self.done else 0, self.first, self.agents, self.step)


def pace_key(run: str, first: int) -> str:
    return f"{keys.PREFIX}/{run}/pace/{keys.id_chunk(first)}"


def pace_expr(run: str) -> str:
    return f"{keys.PREFIX}/{run}/pace/*"


def decode_pace(key: str, data: bytes) -> Pace | None:
    """The share clock put on `key`, or None if anything is malformed: another length or version, an unknown
    flag, a field out of range, or a key that is not exactly `fluidswarm/<run>/pace/<id of first>`."""
    data = bytes(data)
    if len(data) != SIZE:
        return None
    version, flags, first, agents, step = _FORMAT.unpack(data)
    if version != VERSION or flags & ~DONE or first >= keys.MAX_AGENTS or not 1 <= agents <= keys.MAX_AGENTS:
        return None
    chunks = key.split("/")
    if len(chunks) != 4 or chunks[0] != keys.PREFIX or chunks[2] != "pace" or not keys.valid_run_name(chunks[1]):
        return None
    if keys.id_of_chunk(chunks[3]) != first:
        return None
    return Pace(first, agents, step, bool(flags & DONE))
