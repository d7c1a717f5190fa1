"""The agent's final report (`final/<id>`, docs/protocol.md "Final report"): typed here, encoded by the agent
and decoded by the agent crate's final_report.rs (through agent._native).

The report comes from the network and is untrusted: the decoder checks every field it keeps (types, ranges,
finiteness) and `decode_report` returns None for anything malformed; the launcher then treats that agent as
one that never reported. Fields the reader does not know are ignored (forward compatibility).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

from agent.records import native

VERSION = native.REPORT_VERSION
MAX_BYTES = native.REPORT_MAX_BYTES
MAX_COUNT = native.REPORT_MAX_COUNT
MAX_ABS = native.REPORT_MAX_ABS  # as for state records: larger magnitudes are garbage, not physics


class Status(str, Enum):
    """How an agent's run ended: its last step reached (`done`), told to stop, or left behind by the swarm."""

    DONE = "done"
    STOPPED = "stopped"
    FELL_BEHIND = "fell_behind"


@dataclass(frozen=True)
class FinalReport:
    """One agent's end: `state` is its final row (x, y, vx, vy, rho, p, sxx, sxy, syy, frozen, heading, speed:
    agent/sph/particle.py) in SI units; times are Unix seconds (None when never reached); `rss_mb` the process's
    peak RSS [MB]; `pss_mb` its proportional set size at the end [MB] (shared pages divided among their
    processes); `cpu_seconds` process CPU time [s]; the command fields are -1 / None unless the agent follows
    gesture commands."""

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
    pss_mb: float = 0.0
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


def decode_report(data: bytes) -> FinalReport | None:
    """The report in `data` (JSON, wire version 1), or None if any field it carries is malformed
    (final_report.rs decode: every field checked there, the absent ones at their defaults)."""
    msg = native.report_decode(bytes(data))
    if msg is None:
        return None
    msg["status"] = Status(msg["status"])
    msg["state"] = tuple(msg["state"])
    return FinalReport(**msg)


def done_reports(finals: dict[int, FinalReport]) -> dict[int, FinalReport]:
    """The reports of the agents that reached their last step, by id."""
    return {i: r for i, r in finals.items() if r.done}
