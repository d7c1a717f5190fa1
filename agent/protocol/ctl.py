"""The launcher's control messages to the agents (`ctl/<what>`, docs/protocol.md "Control messages"): typed here,
versioned, encoded and decoded by the agent crate's ctl.rs (agent/native/src/ctl.rs, through agent._native).

Payload: version (u8, 1), kind (u8: start 1, stop 2, clock 3, end 4, gone 5), then the kind's body,
little-endian: clock and end a step (u64), gone an agent id (u32), start and stop nothing. The kind is said
twice, in the key and in the payload, and both must agree: a clock payload put on `ctl/end` is malformed.
Only the launcher may put these keys (docs/security.md), but a receiver still checks every byte.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

from agent.protocol import keys
from agent.records import native

VERSION = native.CTL_VERSION
MAX_STEP = native.CTL_MAX_STEP  # steps are u32 in the state record (agent/protocol/wire.py)
MAX_AGENT = native.CTL_MAX_AGENT  # agent ids, as in the spec and the report


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
    """The payload of `msg`; it goes on `keys.ctl_key(run, kind_of(msg).what)`. ValueError for a step or an
    agent out of range."""
    value = msg.step if isinstance(msg, (Clock, End)) else msg.agent if isinstance(msg, Gone) else 0
    return native.ctl_encode(kind_of(msg).what, value)


def ctl_message(run: str, msg: Ctl) -> tuple[str, bytes]:
    """(key, payload) of `msg` in run `run`: the key's kind and the payload's are the same by construction
    (a receiver drops a payload put on another kind's key)."""
    return keys.ctl_key(run, kind_of(msg).what), encode_ctl(msg)


def decode_ctl(what: str | None, data: bytes) -> Ctl | None:
    """The message of payload `data` received on `ctl/<what>`, or None if anything in it is malformed
    (another version, a kind that is not the key's, a wrong length, a value out of range)."""
    decoded = native.ctl_decode(what, bytes(data))
    if decoded is None:
        return None
    name, value = decoded
    if value is None:
        return Start() if name == "start" else Stop()
    if name == "gone":
        return Gone(value)
    return Clock(value) if name == "clock" else End(value)
