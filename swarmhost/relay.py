"""A launcher's state relay under per-process rights (docs/protocol.md "Key expressions", docs/security.md).

At access level `acl` (and on multi-host routers with a users file) an agent puts its state on its own id key,
`state/<id>`, which the router's access control lets no other process use. Agents hear states on cell keys,
`state/<cx>/<cy>`, which no agent may put there. The relay joins the two: it takes each state from its
sender's id key, checks the record names that sender, and puts it again on the cell key of the record's
position. So every state an agent receives was vouched for by the router (the sender's key) and the relay
(the record's id), and the agents keep the cell layout's cheap exact routes and its causal exactness argument
with no discovery traffic (finding neighbours through liveliness tokens cost most of the steps/s that
per-process rights took before: docs/benchmarks/security.md).

This one runs on a launcher's session when the launcher is a client of its host's router (a multi-host run):
each host's launcher relays only the agents it started (`add`), once. A launcher's embedded router at level
`acl` is the compiled `fluidswarm-router`, whose relay (agent/native/src/relay.rs) does the same on the
router's own session without Python (swarmhost/router_process.py; the Python relay there cost ~3 s of launcher
CPU per 200 steps at N = 300, docs/benchmarks/security.md). tests/test_relay.py runs one test on both.
"""

from __future__ import annotations

import zenoh

from agent.protocol import keys
from agent.protocol.wire import peek_id_position

REJECT_ID = "id"  # a record naming another agent than its key's: the key's owner forged it
REJECT_KEY = "key"  # not exactly an agent's id key (a wildcard put)


class StateRelay:
    """Puts each state of the agents `add`ed, checked, on its cell's key (`cell`: the cell side, m = h)."""

    def __init__(self, session: zenoh.Session, run: str):
        self.session, self.run = session, run
        self.cell: float | None = None
        self._ids: dict[str, int] = {}  # exact id key -> the agent id it belongs to, for the agents relayed
        self._cell_keys: dict[tuple[int, int], zenoh.KeyExpr] = {}
        self.rejected: dict[str, int] = {}  # reason -> records dropped (written by the callback's thread only)
        # One subscriber on every id key (the launcher's pacer subscribes to them anyway: a client launcher
        # gets each state once for both), its callback on one Python thread of its own (zenoh-python's
        # default; so the callback never runs twice at once): measured against one subscriber per agent (a
        # thread each) and against the callback on zenoh's receiving threads (they then contend for the GIL
        # while routing), docs/benchmarks/security.md.
        self._sub = session.declare_subscriber(keys.state_observed_expr(run, id_keys=True), self._relay)

    def add(self, agent_id: int, cell: float) -> None:
        """Relay agent `agent_id`'s states from now on (before it starts: none of its states is missed)."""
        if self.cell is None:
            self.cell = cell
        elif cell != self.cell:
            raise ValueError(
                f"agent {agent_id}: smoothing length {cell} differs from the run's {self.cell} "
                "(agents hear each other on cells of one size)"
            )
        self._ids[keys.state_key(self.run, agent_id)] = agent_id

    def _relay(self, sample) -> None:
        key = str(sample.key_expr)
        agent_id = self._ids.get(key)
        if agent_id is None:
            if "*" in key:
                # A put on a wildcard key (`…/state/*`) reaches this subscriber too and passes the router (its
                # deny rules cannot name every wildcard): it vouches for no agent.
                self._reject(REJECT_KEY)
            return  # another launcher's agent (a multi-host run): its own launcher relays it
        data = sample.payload.to_bytes()
        peek, reason = peek_id_position(data)
        if peek is None:
            self._reject(str(reason))  # a reason whenever peek is None
            return
        if peek[0] != agent_id:
            self._reject(REJECT_ID)
            return
        assert self.cell is not None  # set by add(), before any agent's id key is known
        c = keys.cell_of(peek[1], peek[2], self.cell)
        cell_key = self._cell_keys.get(c)
        if cell_key is None:
            cell_key = self._cell_keys[c] = self.session.declare_keyexpr(keys.cell_key(self.run, *c))
        # REMOTE: the launcher's own observers (pacer) already took the state from its id key. BLOCK, as the
        # agents put their states: a neighbour's full queue delays a state, never drops it.
        self.session.put(
            cell_key, data, congestion_control=zenoh.CongestionControl.BLOCK, allowed_destination=zenoh.Locality.REMOTE
        )

    def _reject(self, reason: str) -> None:
        self.rejected[reason] = self.rejected.get(reason, 0) + 1

    def close(self) -> None:
        try:
            self._sub.undeclare()
        except zenoh.ZError:
            pass  # the session is already closed
