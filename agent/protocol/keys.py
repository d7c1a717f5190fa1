"""Zenoh key expressions of a run: defined once here, documented in docs/protocol.md (protocol v1).

    fluidswarm/<run>/state/<cx>/<cy>/<id>   agent id's state published in cell (cx, cy) (the record repeats the id)
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


def state_key(run: str, cx: int, cy: int, agent_id: int) -> str:
    """Agent `agent_id`'s state in cell (cx, cy). The id is in the key so that the router's access control
    lets each agent publish only its own states (docs/security.md); receivers check it equals the record's."""
    return f"{PREFIX}/{run}/state/{cx}/{cy}/{agent_id}"


def cell_expr(run: str, cx: int, cy: int) -> str:
    """Every agent's state in cell (cx, cy): what an agent subscribes to for each cell it watches."""
    return f"{PREFIX}/{run}/state/{cx}/{cy}/*"


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
