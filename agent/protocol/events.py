"""What an agent tells the launcher and the recorder as it runs (`event/<id>`, docs/protocol.md "Events"):
typed, versioned, encoded and decoded only here (the native agent's encoder is agent/native/src/event.rs).

JSON: {"v": 1, "id": <agent>, "step": <its step>, "event": <kind>, ...the kind's fields}. The fields are
fixed per kind and checked (types, ranges, finiteness, sizes); an unknown kind or field, another version or
anything else malformed makes `decode_event` return None, and the receiver drops and counts it.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from enum import Enum

from agent.protocol.json_fields import integer, number

VERSION = 1
MAX_BYTES = 64 * 1024
MAX_AGENT = 2**31 - 1
MAX_STEP = 2**32 - 1
MAX_LISTED = 4096  # neighbours in one timeout event: far more than fit in a kernel support
MAX_SECONDS = 1e9


class EventKind(str, Enum):
    STARTED = "started"  # passed the start barrier (or joined)
    COMMAND_RECEIVED = "command_received"  # its first gesture command
    NEIGHBOUR_TIMEOUT = "neighbour_timeout"  # expected neighbours it stopped waiting for
    FELL_BEHIND = "fell_behind"  # the swarm went on without it: it left (agents before issue 36)
    REJOINED = "rejoined"  # it stalled (frozen) while its neighbours went on, and adopted their step


@dataclass(frozen=True)
class Sighting:
    """What a lockstep agent knew of a neighbour it timed out on: the step of its last sighting (-1: known
    only from the launcher's placement), its distance then [m] (None: no position yet) and whether its cell
    was watched."""

    agent: int
    step: int
    distance: float | None
    watched: bool


@dataclass(frozen=True)
class AgentEvent:
    """One event of agent `id` at its step `step`. neighbour_timeout carries `neighbours` (ids) and, from a
    lockstep agent, `last_seen`; command_received carries `seconds_since_session_open` [s]; rejoined carries
    `from_step`, the step it stalled at (`step` is the one it adopted)."""

    id: int
    step: int
    kind: EventKind
    neighbours: tuple[int, ...] = ()
    last_seen: tuple[Sighting, ...] | None = None
    seconds_since_session_open: float | None = None
    from_step: int | None = None

    def as_json(self) -> dict:
        """The record as a JSON object (the same keys the wire carries)."""
        out: dict = {"v": VERSION, "id": self.id, "step": self.step, "event": self.kind.value}
        if self.kind is EventKind.NEIGHBOUR_TIMEOUT:
            out["neighbours"] = list(self.neighbours)
            if self.last_seen is not None:
                out["last_seen"] = [[s.agent, s.step, s.distance, s.watched] for s in self.last_seen]
        elif self.kind is EventKind.COMMAND_RECEIVED:
            out["seconds_since_session_open"] = self.seconds_since_session_open
        elif self.kind is EventKind.REJOINED:
            out["from_step"] = self.from_step
        return out


_FIELDS = {
    EventKind.STARTED: set(),
    EventKind.FELL_BEHIND: set(),
    EventKind.COMMAND_RECEIVED: {"seconds_since_session_open"},
    EventKind.NEIGHBOUR_TIMEOUT: {"neighbours", "last_seen"},
    EventKind.REJOINED: {"from_step"},
}
_REQUIRED = {
    EventKind.COMMAND_RECEIVED: {"seconds_since_session_open"},
    EventKind.NEIGHBOUR_TIMEOUT: {"neighbours"},
    EventKind.REJOINED: {"from_step"},
}


def encode_event(event: AgentEvent) -> bytes:
    return json.dumps(event.as_json(), separators=(",", ":"), allow_nan=False).encode()


def _sighting(v) -> Sighting:
    if not isinstance(v, list) or len(v) != 4 or not isinstance(v[3], bool):
        raise ValueError
    distance = None if v[2] is None else number(v[2], 0.0, MAX_SECONDS)
    return Sighting(integer(v[0], 0, MAX_AGENT), integer(v[1], -1, MAX_STEP), distance, v[3])


def _listed(v, item) -> tuple:
    if not isinstance(v, list) or len(v) > MAX_LISTED:
        raise ValueError
    return tuple(item(x) for x in v)


def decode_event(data: bytes) -> AgentEvent | None:
    """The event in `data`, or None if anything in it is malformed."""
    if len(data) > MAX_BYTES:
        return None
    try:
        msg = json.loads(data)
        if not isinstance(msg, dict) or type(msg.get("v")) is not int or msg["v"] != VERSION:
            return None
        kind = EventKind(msg["event"])
        if set(msg) - {"v", "id", "step", "event"} - _FIELDS[kind] or not _REQUIRED.get(kind, set()) <= set(msg):
            return None
        kw: dict = {"id": integer(msg["id"], 0, MAX_AGENT), "step": integer(msg["step"], 0, MAX_STEP), "kind": kind}
        if "neighbours" in msg:
            kw["neighbours"] = _listed(msg["neighbours"], lambda j: integer(j, 0, MAX_AGENT))
        if "last_seen" in msg:
            kw["last_seen"] = _listed(msg["last_seen"], _sighting)
        if "from_step" in msg:
            kw["from_step"] = integer(msg["from_step"], 0, MAX_STEP)
        if "seconds_since_session_open" in msg:
            kw["seconds_since_session_open"] = number(msg["seconds_since_session_open"], 0.0, MAX_SECONDS)
    except (ValueError, KeyError, TypeError, RecursionError):
        return None
    return AgentEvent(**kw)
