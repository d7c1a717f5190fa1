"""The launcher's control messages to the agents (`ctl/<what>`, docs/protocol.md "Control messages"): typed,
versioned, encoded and decoded only here (the native agent's copy is agent/native/src/ctl.rs).

Payload: version (u8, 1), kind (u8: start 1, stop 2, clock 3, end 4, gone 5), then the kind's body,
little-endian: clock and end a step (u64), gone an agent id (u32), start and stop nothing. The kind is said
twice, in the key and in the payload, and both must agree: a clock payload put on `ctl/end` is malformed.
Only the launcher may put these keys (docs/security.md), but a receiver still checks every byte.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from enum import IntEnum

from agent.protocol import keys

VERSION = 1
MAX_STEP = 2**32 - 1  # steps are u32 in the state record (agent/protocol/wire.py)
MAX_AGENT = 2**31 - 1  # agent ids, as in the spec and the report

_HEAD = struct.Struct("<BB")
_STEP = struct.Struct("<Q")
_ID = struct.Struct("<I")


class CtlKind(IntEnum):
    """The kind byte; its name is the key's last chunk (`ctl/clock`)."""

    START = 1
    STOP = 2
    CLOCK = 3
    END = 4
    GONE = 5

    @property
    def what(self) -> str:
        return self.name.lower()


@dataclass(frozen=True)
class Start:
    """Every waiting agent steps from now (the start barrier is passed)."""


@dataclass(frozen=True)
class Stop:
    """Every agent stops and reports `stopped`."""


@dataclass(frozen=True)
class Clock:
    """The pacing clock: the slowest live agent's step; agents stay within CLOCK_LEAD steps of it."""

    step: int


@dataclass(frozen=True)
class End:
    """Every agent finishes at `step` (or at its own last step if that comes first)."""

    step: int


@dataclass(frozen=True)
class Gone:
    """Agent `agent` lost its liveliness: its neighbours stop waiting for it."""

    agent: int


Ctl = Start | Stop | Clock | End | Gone

_KIND = {Start: CtlKind.START, Stop: CtlKind.STOP, Clock: CtlKind.CLOCK, End: CtlKind.END, Gone: CtlKind.GONE}


def kind_of(msg: Ctl) -> CtlKind:
    return _KIND[type(msg)]


def encode_ctl(msg: Ctl) -> bytes:
    """The payload of `msg`; it goes on `keys.ctl_key(run, kind_of(msg).what)`."""
    kind = kind_of(msg)
    head = _HEAD.pack(VERSION, kind)
    if isinstance(msg, (Clock, End)):
        if not 0 <= msg.step <= MAX_STEP:
            raise ValueError(f"ctl/{kind.what}: step must be in [0, {MAX_STEP}], got {msg.step}")
        return head + _STEP.pack(msg.step)
    if isinstance(msg, Gone):
        if not 0 <= msg.agent <= MAX_AGENT:
            raise ValueError(f"ctl/gone: agent must be in [0, {MAX_AGENT}], got {msg.agent}")
        return head + _ID.pack(msg.agent)
    return head


def ctl_message(run: str, msg: Ctl) -> tuple[str, bytes]:
    """(key, payload) of `msg` in run `run`: the key's kind and the payload's are the same by construction
    (a receiver drops a payload put on another kind's key)."""
    return keys.ctl_key(run, kind_of(msg).what), encode_ctl(msg)


def decode_ctl(what: str | None, data: bytes) -> Ctl | None:
    """The message of payload `data` received on `ctl/<what>`, or None if anything in it is malformed
    (another version, a kind that is not the key's, a wrong length, a value out of range)."""
    if len(data) < _HEAD.size:
        return None
    version, code = _HEAD.unpack_from(data)
    if version != VERSION or code not in CtlKind._value2member_map_:
        return None
    kind = CtlKind(code)
    body = data[_HEAD.size :]
    if kind.what != what:
        return None
    if kind in (CtlKind.START, CtlKind.STOP):
        return (Start() if kind is CtlKind.START else Stop()) if not body else None
    if kind is CtlKind.GONE:
        if len(body) != _ID.size:
            return None
        (agent,) = _ID.unpack(body)
        return Gone(agent) if agent <= MAX_AGENT else None
    if len(body) != _STEP.size:
        return None
    (step,) = _STEP.unpack(body)
    if step > MAX_STEP:
        return None
    return Clock(step) if kind is CtlKind.CLOCK else End(step)
