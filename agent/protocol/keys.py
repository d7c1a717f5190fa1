"""Zenoh key expressions of a run: defined once here, documented in docs/protocol.md (protocol v1).

    fluidswarm/<run>/state/<cx>/<cy>        a state of an agent in cell (cx, cy) (the record names the agent)
    fluidswarm/<run>/state/<id>             under per-process rights (acl): agent id puts its states here, the
                                            relay puts them on their cell's key (docs/protocol.md)
    fluidswarm/<run>/alive/<id>             liveliness token: the agent process is up
    fluidswarm/<run>/ctl/start|stop|clock|end|gone  launcher -> agents: begin / stop / pace / end / an agent is gone
    fluidswarm/<run>/final/<id>             agent -> launcher: final state and counters (JSON)
    fluidswarm/<run>/event/<id>             agent -> recorder: notable events (JSON)
    fluidswarm/<run>/command                coordinator -> agents: the signed gesture command

<id> in a key is the agent id written as ID_BITS letters, bit k (from the least significant) as one of two
letters that belong to position k only: 'a'/'b' for bit 0, 'c'/'d' for bit 1, ... 'y'/'z' for bit 12
(id 0 = "acegikmoqsuwy", id 5 = "bcfgikmoqsuwy"). Why: the router's access control then forbids an agent
every other agent's keys with ID_BITS patterns (`**/$*<letter>$*`, one per bit: "this bit is not mine"),
so per-process rights need no default-deny pass over every forwarded message (docs/security.md).
"""

from __future__ import annotations

import math
import re

PREFIX = "fluidswarm"
_RUN_RE = re.compile(r"^[A-Za-z0-9_-]{1,64}$")
_INT_RE = re.compile(r"^-?(0|[1-9][0-9]{0,9})$")
_CTL_RE = re.compile(r"^[a-z]{1,16}$")
ID_BITS = 13
MAX_AGENTS = 1 << ID_BITS  # ids 0 .. 8191 have a key


def bit_letter(k: int, bit: int) -> str:
    """The letter that writes bit `bit` (0 or 1) at position `k` of an id chunk."""
    return chr(ord("a") + 2 * k + bit)


def id_chunk(agent_id: int) -> str:
    """The key chunk of an agent id (see the module's docstring)."""
    i = int(agent_id)
    if not 0 <= i < MAX_AGENTS:
        raise ValueError(f"agent id {i}: ids 0..{MAX_AGENTS - 1} only (keys write the id in {ID_BITS} bits)")
    return "".join(bit_letter(k, (i >> k) & 1) for k in range(ID_BITS))


def id_of_chunk(chunk: str) -> int | None:
    """The id an id chunk writes, or None for anything else (a wildcard, a partial or foreign chunk)."""
    if len(chunk) != ID_BITS:
        return None
    i = 0
    for k, ch in enumerate(chunk):
        bit = ord(ch) - ord("a") - 2 * k
        if bit not in (0, 1):
            return None
        i |= bit << k
    return i


def valid_run_name(run: str) -> bool:
    """Run names become one key chunk: letters, digits, '-' and '_' only (no '/', '*', '$')."""
    return bool(_RUN_RE.match(run))


def cell_of(x: float, y: float, cell: float) -> tuple[int, int]:
    return math.floor(x / cell), math.floor(y / cell)


def cell_key(run: str, cx: int, cy: int) -> str:
    """The states of the agents in cell (cx, cy), the id only in the record: what agents hear on, one exact key
    per cell, the cheapest for zenoh. Put by the agents without per-process rights, else by the relay
    (docs/protocol.md)."""
    return f"{PREFIX}/{run}/state/{cx}/{cy}"


def state_key(run: str, agent_id: int) -> str:
    """Agent `agent_id`'s states under per-process rights (level acl): one exact key carrying its id, so the
    router's access control lets each agent publish only its own states (docs/security.md)."""
    return f"{PREFIX}/{run}/state/{id_chunk(agent_id)}"


def state_sender(key: str) -> int | None:
    """The sender id of a state key (`fluidswarm/<run>/state/<id>`), None for anything else."""
    chunks = key.split("/")
    ok = len(chunks) == 4 and chunks[0] == PREFIX and chunks[2] == "state" and valid_run_name(chunks[1])
    return id_of_chunk(chunks[3]) if ok else None


def state_key_vouches(key: str, record_id: int) -> bool:
    """May a state record naming `record_id` arrive on `key`? On its sender's own key, or on an exact cell key
    (`fluidswarm/<run>/state/<cx>/<cy>`, the layout without per-process rights; under them the router refuses
    an agent's put on a cell key). Anything else — another id, a wildcard key (`.../state/*`: the router's
    deny rules cannot name every wildcard) — is a forgery."""
    chunks = key.split("/")
    if len(chunks) == 5 and chunks[0] == PREFIX and chunks[2] == "state":
        return bool(valid_run_name(chunks[1]) and _INT_RE.match(chunks[3]) and _INT_RE.match(chunks[4]))
    return state_sender(key) == record_id


def state_observed_expr(run: str, id_keys: bool) -> str:
    """Where passive observers (recorder, launcher) take every state of the run once: from the agents' id keys
    under per-process rights (the relay's copies on the cell keys would be the same states again), else from
    the cell keys. Never for agents."""
    return f"{PREFIX}/{run}/state/*" if id_keys else f"{PREFIX}/{run}/state/*/*"


def alive_key(run: str, agent_id: int) -> str:
    return f"{PREFIX}/{run}/alive/{id_chunk(agent_id)}"


def alive_expr(run: str) -> str:
    return f"{PREFIX}/{run}/alive/*"


def ctl_key(run: str, what: str) -> str:
    return f"{PREFIX}/{run}/ctl/{what}"


def ctl_expr(run: str) -> str:
    return f"{PREFIX}/{run}/ctl/*"


def final_key(run: str, agent_id: int) -> str:
    return f"{PREFIX}/{run}/final/{id_chunk(agent_id)}"


def final_expr(run: str) -> str:
    return f"{PREFIX}/{run}/final/*"


def event_key(run: str, agent_id: int) -> str:
    return f"{PREFIX}/{run}/event/{id_chunk(agent_id)}"


def event_expr(run: str) -> str:
    return f"{PREFIX}/{run}/event/*"


def command_key(run: str) -> str:
    return f"{PREFIX}/{run}/command"


def ctl_what(run: str, key: str) -> str | None:
    """`start`, `stop`, ... for exactly `fluidswarm/<run>/ctl/<what>`, else None (a wildcard key such as
    `fluidswarm/**` reaches a ctl subscriber too; only the launcher may put the exact keys)."""
    head = f"{PREFIX}/{run}/ctl/"
    what = key[len(head) :] if key.startswith(head) else ""
    return what if _CTL_RE.match(what) else None


def id_from_key(key: str) -> int | None:
    """The agent id the last chunk of a key writes (id_chunk), or None."""
    return id_of_chunk(key.rsplit("/", 1)[-1])
