"""What an agent tells the launcher and the recorder as it runs (`event/<id>`, docs/protocol.md "Events"):
typed here, versioned, encoded and decoded by the agent crate's event.rs (through agent._native).

JSON: {"v": 1, "id": <agent>, "step": <its step>, "event": <kind>, ...the kind's fields}. The fields are
fixed per kind and checked (types, ranges, finiteness, sizes); an unknown kind or field, another version or
anything else malformed makes `decode_event` return None, and the receiver drops and counts it.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from agent.records import native

VERSION = native.EVENTS_VERSION
MAX_BYTES = native.EVENTS_MAX_BYTES
MAX_AGENT = native.EVENTS_MAX_AGENT
MAX_STEP = native.EVENTS_MAX_STEP
MAX_LISTED = native.EVENTS_MAX_LISTED  # neighbours in one timeout event: far more than fit in a kernel support
MAX_SECONDS = native.EVENTS_MAX_SECONDS


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


def encode_event(event: AgentEvent) -> bytes:
    """The record's bytes (event.rs encode, after the receiver's checks: ValueError if it would be refused)."""
    return native.events_encode(event.as_json())


def decode_event(data: bytes) -> AgentEvent | None:
    """The event in `data`, or None if anything in it is malformed (event.rs decode)."""
    msg = native.events_decode(bytes(data))
    if msg is None:
        return None
    last_seen = msg.get("last_seen")
    return AgentEvent(
        msg["id"],
        msg["step"],
        EventKind(msg["event"]),
        tuple(msg.get("neighbours", ())),
        None if last_seen is None else tuple(Sighting(*s) for s in last_seen),
        msg.get("seconds_since_session_open"),
        msg.get("from_step"),
    )
