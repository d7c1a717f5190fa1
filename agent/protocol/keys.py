"""Zenoh key expressions of a run: defined once here, documented in docs/protocol.md (protocol v1).

    fluidswarm/<run>/state/<cx>/<cy>        a state published in cell (cx, cy) (the record names the agent)
    fluidswarm/<run>/state/<cx>/<cy>/<id>   the same with the id in the key, under per-process rights (acl)
    fluidswarm/<run>/alive/<id>             liveliness token: the agent process is up
    fluidswarm/<run>/ctl/start|stop|clock|end|gone  launcher -> agents: begin / stop / pace / end / an agent is gone
    fluidswarm/<run>/final/<id>             agent -> launcher: final state and counters (JSON)
    fluidswarm/<run>/event/<id>             agent -> recorder: notable events (JSON)
    fluidswarm/<run>/command                coordinator -> agents: the signed gesture command
"""

from __future__ import annotations

import math
import re

PREFIX = "fluidswarm"
_RUN_RE = re.compile(r"^[A-Za-z0-9_-]{1,64}$")


def valid_run_name(run: str) -> bool:
    """Run names become one key chunk: letters, digits, '-' and '_' only (no '/', '*', '$')."""
    return bool(_RUN_RE.match(run))


def cell_of(x: float, y: float, cell: float) -> tuple[int, int]:
    return math.floor(x / cell), math.floor(y / cell)


def state_key(run: str, cx: int, cy: int, agent_id: int | None = None) -> str:
    """A state published in cell (cx, cy). With `agent_id` (a router with per-process rights) the id is the
    last chunk, so the router's access control lets each agent publish only its own states
    (docs/security.md); without, one exact key per cell, the id only in the record (zenoh dispatches it by a
    table look-up; the id in the key costs 31-42 % of the steps/s, docs/benchmarks/security.md)."""
    cell = f"{PREFIX}/{run}/state/{cx}/{cy}"
    return cell if agent_id is None else f"{cell}/{agent_id}"


def cell_expr(run: str, cx: int, cy: int, ids: bool = True) -> str:
    """What an agent subscribes to for each cell it watches: every agent's key in it, or the cell's one key."""
    return f"{PREFIX}/{run}/state/{cx}/{cy}/*" if ids else state_key(run, cx, cy)


def state_sender(key: str) -> int | None:
    """The sender id of a state key (`.../state/<cx>/<cy>/<id>`); None for a cell key or anything else."""
    chunks = key.split("/")
    return id_from_key(key) if len(chunks) == 6 and chunks[2] == "state" else None


def state_all_expr(run: str) -> str:
    """Every state message of the run: for passive observers (recorder, launcher), never for agents."""
    return f"{PREFIX}/{run}/state/**"


def alive_key(run: str, agent_id: int) -> str:
    return f"{PREFIX}/{run}/alive/{agent_id}"


def alive_expr(run: str) -> str:
    return f"{PREFIX}/{run}/alive/*"


def ctl_key(run: str, what: str) -> str:
    return f"{PREFIX}/{run}/ctl/{what}"


def ctl_expr(run: str) -> str:
    return f"{PREFIX}/{run}/ctl/*"


def final_key(run: str, agent_id: int) -> str:
    return f"{PREFIX}/{run}/final/{agent_id}"


def final_expr(run: str) -> str:
    return f"{PREFIX}/{run}/final/*"


def event_key(run: str, agent_id: int) -> str:
    return f"{PREFIX}/{run}/event/{agent_id}"


def event_expr(run: str) -> str:
    return f"{PREFIX}/{run}/event/*"


def command_key(run: str) -> str:
    return f"{PREFIX}/{run}/command"


def id_from_key(key: str) -> int | None:
    """The agent id in the last chunk of a key, or None if it is not a decimal integer."""
    last = key.rsplit("/", 1)[-1]
    return int(last) if last.isdigit() and len(last) < 10 else None
