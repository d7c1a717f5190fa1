"""Zenoh key expressions of a run (protocol v1, docs/protocol.md): the agent crate's keys.rs (through
agent._native) writes and reads the ids and the keys both sides use; the observers' expressions are here.

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

import re

from agent.records import native

PREFIX = native.KEYS_PREFIX
_INT_RE = re.compile(r"^-?(0|[1-9][0-9]{0,9})$")
ID_BITS = native.KEYS_ID_BITS
MAX_AGENTS = native.KEYS_MAX_AGENTS  # ids 0 .. 8191 have a key


def bit_letter(k: int, bit: int) -> str:
    """The letter that writes bit `bit` (0 or 1) at position `k` of an id chunk (access control's patterns)."""
    return chr(ord("a") + 2 * k + bit)


def id_chunk(agent_id: int) -> str:
    """The key chunk of an agent id (see the module's docstring); ValueError outside 0..MAX_AGENTS - 1."""
    return native.keys_id_chunk(int(agent_id))


# The id an id chunk writes, or None for anything else (a wildcard, a partial or foreign chunk).
id_of_chunk = native.keys_id_of_chunk

# Run names become one key chunk: letters, digits, '-' and '_' only (no '/', '*', '$'), 1 to 64 of them.
valid_run_name = native.keys_valid_run_name

# The cell (floor(x / cell), floor(y / cell)) of a position.
cell_of = native.keys_cell_of

# The states of the agents in cell (cx, cy), the id only in the record: what agents hear on, one exact key per
# cell, the cheapest for zenoh. Put by the agents without per-process rights, else by the relay (docs/protocol.md).
cell_key = native.keys_cell_key


def state_key(run: str, agent_id: int) -> str:
    """Agent `agent_id`'s states under per-process rights (level acl): one exact key carrying its id, so the
    router's access control lets each agent publish only its own states (docs/security.md)."""
    return native.keys_state_key(run, int(agent_id))


def inbox_key(run: str, agent_id: int) -> str:
    """Where the embedded router's relay hands agent `agent_id` its neighbours' states, one message per
    lockstep step (agent/native/src/relay/inboxes.rs); only the router puts there (docs/security.md)."""
    return f"{PREFIX}/{run}/inbox/{id_chunk(agent_id)}"


def watch_key(run: str, agent_id: int) -> str:
    """Where agent `agent_id` names the cells it hears to the relay (agent/native/src/watch.rs)."""
    return f"{PREFIX}/{run}/watch/{id_chunk(agent_id)}"


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


_ZID_RE = re.compile(r"^[0-9a-f]{1,32}$")


def batch_expr(run: str) -> str:
    """The routers' relays' batches of the run's states, for the recorder (docs/protocol.md "State batches";
    agent/native/src/keys.rs batch_key puts them on `fluidswarm/<run>/batch/<router zid>`)."""
    return f"{PREFIX}/{run}/batch/*"


def is_batch_key(run: str, key: str) -> bool:
    """Is `key` exactly a router's batch key of `run` (no wildcard: only routers may put there, the access
    rules deny every other role `batch/**`, agent/protocol/acl.py)?"""
    chunks = key.split("/")
    return len(chunks) == 4 and chunks[:3] == [PREFIX, run, "batch"] and bool(_ZID_RE.match(chunks[3]))


def state_observed_expr(run: str, id_keys: bool) -> str:
    """Where passive observers (recorder, launcher) take every state of the run once: from the agents' id keys
    under per-process rights (the relay's copies on the cell keys would be the same states again), else from
    the cell keys. Never for agents."""
    return f"{PREFIX}/{run}/state/*" if id_keys else f"{PREFIX}/{run}/state/*/*"


def alive_key(run: str, agent_id: int) -> str:
    return native.keys_alive_key(run, int(agent_id))


def alive_expr(run: str) -> str:
    return f"{PREFIX}/{run}/alive/*"


def ctl_key(run: str, what: str) -> str:
    return f"{PREFIX}/{run}/ctl/{what}"


ctl_expr = native.keys_ctl_expr


def final_key(run: str, agent_id: int) -> str:
    return native.keys_final_key(run, int(agent_id))


def final_expr(run: str) -> str:
    return f"{PREFIX}/{run}/final/*"


def event_key(run: str, agent_id: int) -> str:
    return native.keys_event_key(run, int(agent_id))


def event_expr(run: str) -> str:
    return f"{PREFIX}/{run}/event/*"


command_key = native.keys_command_key

# `start`, `stop`, ... for exactly `fluidswarm/<run>/ctl/<what>`, else None (a wildcard key such as
# `fluidswarm/**` reaches a ctl subscriber too; only the launcher may put the exact keys).
ctl_what = native.keys_ctl_what

# The agent id the last chunk of a key writes (id_chunk), or None.
id_from_key = native.keys_id_from_key
