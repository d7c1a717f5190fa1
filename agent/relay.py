"""The launcher's state relay under per-process rights (docs/protocol.md "Key expressions", docs/security.md).

At access level `acl` (and on multi-host routers with a users file) an agent puts its state on its own id key,
`state/<id>`, which the router's access control lets no other process use. Agents hear states on cell keys,
`state/<cx>/<cy>`, which no agent may put there. The relay joins the two: it takes each state from its
sender's id key, checks the record names that sender, and puts it again on the cell key of the record's
position. So every state an agent receives was vouched for by the router (the sender's key) and the relay
(the record's id), and the agents keep the cell layout's cheap exact routes and its causal exactness argument
with no discovery traffic (what the id layout's `where` tokens cost: docs/benchmarks/security.md).

It runs on the launcher's session: on the router's own session when the launcher embeds the router (no extra
hop: the relay's puts are routed in-process), as a client of its host's router in a multi-host run. It relays
only the agents its launcher started (an exact subscription per id), so each host's launcher relays its own
agents once.
"""

from __future__ import annotations

import threading

import zenoh

from agent.protocol import keys
from agent.protocol.wire import decode_state

REJECT_ID = "id"  # a record naming another agent than its key's: the key's owner forged it
REJECT_KEY = "key"  # not exactly an agent's id key (a wildcard put)


class StateRelay:
    """Puts each state of the agents `add`ed, checked, on its cell's key (`cell`: the cell side, m = h)."""

    def __init__(self, session: zenoh.Session, run: str):
        self.session, self.run = session, run
        self.cell: float | None = None
        self._subs: dict[int, object] = {}
        self._cell_keys: dict[tuple[int, int], zenoh.KeyExpr] = {}
        self._lock = threading.Lock()
        self.rejected: dict[str, int] = {}

    def add(self, agent_id: int, cell: float) -> None:
        """Relay agent `agent_id`'s states from now on (before it starts: none of its states is missed)."""
        if self.cell is None:
            self.cell = cell
        elif cell != self.cell:
            raise ValueError(f"agent {agent_id}: smoothing length {cell} differs from the run's {self.cell} "
                             "(agents hear each other on cells of one size)")
        if agent_id in self._subs:
            return
        exact = keys.state_key(self.run, agent_id)
        key = self.session.declare_keyexpr(exact)
        # A callback, not a channel: the relay is on every state's path from sender to neighbours, and a
        # channel's consumer thread would add a thread wake-up to each (measured: docs/benchmarks/security.md).
        self._subs[agent_id] = self.session.declare_subscriber(key, lambda sample: self._relay(agent_id, exact, sample))

    def _relay(self, agent_id: int, exact: str, sample) -> None:
        if str(sample.key_expr) != exact:
            # A put on a wildcard key (`…/state/*`, `fluidswarm/**`) reaches this subscriber too and passes the
            # router (its deny rules cannot name every wildcard): it vouches for no agent.
            self._reject(REJECT_KEY)
            return
        data = sample.payload.to_bytes()
        decoded, reason = decode_state(data)
        if decoded is None:
            self._reject(reason)
            return
        if decoded[0] != agent_id:
            self._reject(REJECT_ID)
            return
        values = decoded[3]
        c = keys.cell_of(values[0], values[1], self.cell)
        key = self._cell_keys.get(c)
        if key is None:
            key = self._cell_keys.setdefault(c, self.session.declare_keyexpr(keys.cell_key(self.run, *c)))
        # REMOTE: the launcher's own observers (pacer) already took the state from its id key. BLOCK, as the
        # agents put their states: a neighbour's full queue delays a state, never drops it.
        self.session.put(key, data, congestion_control=zenoh.CongestionControl.BLOCK,
                         allowed_destination=zenoh.Locality.REMOTE)

    def _reject(self, reason: str) -> None:
        with self._lock:
            self.rejected[reason] = self.rejected.get(reason, 0) + 1

    def close(self) -> None:
        for sub in self._subs.values():
            try:
                sub.undeclare()
            except Exception:
                pass  # the session is already closed
        self._subs.clear()
