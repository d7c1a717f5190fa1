"""The agent's final report (`final/<id>`, docs/protocol.md "Final report"), decoded and validated only here.

The report comes from the network and is untrusted: `decode_report` checks every field it keeps (types,
ranges, finiteness) and returns None for anything malformed; the launcher then treats that agent as one
that never reported. Fields the reader does not know are ignored (forward compatibility).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

from agent.protocol.json_fields import integer, number
from agent.sph.particle import NFIELDS

VERSION = 1
MAX_BYTES = 64 * 1024  # a report is ~1 kB; anything far larger is not one
MAX_COUNT = 2**63 - 1
MAX_ABS = 1e12  # as for state records (agent/native/src/wire.rs): larger magnitudes are garbage, not physics


class Status(str, Enum):
    """How an agent's run ended: its last step reached (`done`), told to stop, or left behind by the swarm."""

    DONE = "done"
    STOPPED = "stopped"
    FELL_BEHIND = "fell_behind"


@dataclass(frozen=True)
class FinalReport:
    """One agent's end: `state` is its final row (x, y, vx, vy, rho, p, sxx, sxy, syy, frozen, heading, speed:
    agent/sph/particle.py) in SI units;
    times are Unix seconds (None when never reached); `rss_mb` the process's peak RSS [MB]; `cpu_seconds`
    process CPU time [s]; the command fields are -1 / None unless the agent follows gesture commands."""

    id: int
    status: Status
    steps: int
    state: tuple[float, ...]
    msgs_received: int = 0
    neighbours: int = 0
    rejected: dict[str, int] = field(default_factory=dict)
    timeouts: int = 0
    deaths_seen: int = 0
    stale: int = 0
    dropped_out: int = 0
    lost: int = 0
    t_start: float | None = None
    t_end: float | None = None
    session_opened_at: float | None = None
    rss_mb: float = 0.0
    cpu_seconds: float = 0.0
    cpu_seconds_at_start: float | None = None
    agent: str = ""
    commands_accepted: int = 0
    particle_class: int = 0
    waypoint_index: int = -1
    command_seq: int = -1
    first_command_at: float | None = None

    @property
    def done(self) -> bool:
        return self.status is Status.DONE


_COUNTS = (
    "msgs_received",
    "neighbours",
    "timeouts",
    "deaths_seen",
    "stale",
    "dropped_out",
    "lost",
    "commands_accepted",
    "particle_class",
)
_SIGNED = ("waypoint_index", "command_seq")
_OPTIONAL_TIMES = ("t_start", "t_end", "session_opened_at", "cpu_seconds_at_start", "first_command_at")
_TIMES = ("rss_mb", "cpu_seconds")


def decode_report(data: bytes) -> FinalReport | None:
    """The report in `data` (JSON, wire version 1), or None if any field it carries is malformed."""
    if len(data) > MAX_BYTES:
        return None
    try:
        msg = json.loads(data)
        if not isinstance(msg, dict) or msg.get("v", VERSION) != VERSION:
            return None
        state = msg["state"]
        if not isinstance(state, list) or not 9 <= len(state) <= NFIELDS:
            return None
        rejected = msg.get("rejected", {})
        if not isinstance(rejected, dict) or len(rejected) > 64:
            return None
        kw: dict[str, Any] = {
            "id": integer(msg["id"], 0, 2**31 - 1),
            "status": Status(msg["status"]),
            "steps": integer(msg["steps"], 0, MAX_COUNT),
            "state": tuple(number(v, -MAX_ABS, MAX_ABS) for v in state),
            "rejected": {str(k)[:64]: integer(v, 0, MAX_COUNT) for k, v in rejected.items()},
            "agent": str(msg.get("agent", ""))[:32],
        }
        for name in _COUNTS:
            if name in msg:
                kw[name] = integer(msg[name], 0, MAX_COUNT)
        for name in _SIGNED:
            if name in msg:
                kw[name] = integer(msg[name], -1, MAX_COUNT)
        for name in _TIMES:
            if name in msg:
                kw[name] = number(msg[name], -MAX_ABS, MAX_ABS)
        for name in _OPTIONAL_TIMES:
            if msg.get(name) is not None:
                kw[name] = number(msg[name], -MAX_ABS, MAX_ABS)
    except (ValueError, KeyError, TypeError, RecursionError):  # RecursionError: nested deeper than json's stack
        return None
    return FinalReport(**kw)


def done_reports(finals: dict[int, FinalReport]) -> dict[int, FinalReport]:
    """The reports of the agents that reached their last step, by id."""
    return {i: r for i, r in finals.items() if r.done}
