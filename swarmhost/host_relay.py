"""A launcher's relay on another host's router (a multi-host run): the relay inside that host's compiled router
(`fluidswarm router`, agent/native/src/relay.rs HostRelays), asked over Zenoh (docs/protocol.md "Key
expressions", docs/security.md).

At access level `acl` (and on multi-host routers with a users file) an agent puts its state on its own id key,
`state/<id>`, which the router's access control lets no other process use; agents hear states on cell keys,
`state/<cx>/<cy>`, which no agent may put. The relay joins the two inside the router: it takes each state from
its sender's id key, checks the record names that sender, and puts it again on the cell key of the record's
position. Each host's router relays the agents its own launchers add (the launcher is a client of exactly one
router, whose Zenoh id is in the request's key): so every state is relayed once, by the router its agent is
connected to, with no Python on the path (a Python relay on the launcher's session cost ~3 s of launcher CPU
per 200 steps at N = 300: docs/benchmarks/security.md).
"""

from __future__ import annotations

import zenoh

from agent.protocol import keys
from swarmhost.router_process import RouterFailed, rejected_counts

REQUEST_TIMEOUT = 10.0  # s; a router answers in milliseconds, a lost one never


class HostRelay:
    """The relay of the router `session` is a client of, for run `run`: `add` (before each agent starts),
    `rejected` (the counts by reason), `close`; the interface of router_process.py's CompiledRelay."""

    def __init__(self, session: zenoh.Session, run: str, endpoint: str):
        self.session, self.endpoint = session, endpoint
        routers = [str(z) for z in session.info.routers_zid()]
        if len(routers) != 1:
            raise RouterFailed(f"the router at {endpoint}: connected to {len(routers)} routers, expected its one")
        self.key = f"{keys.PREFIX}/{run}/relay/{routers[0]}"
        self._last_rejected: dict[str, int] = {}

    def _ask(self, request: str) -> str:
        answers = []
        for reply in self.session.get(self.key, payload=request, timeout=REQUEST_TIMEOUT):
            answer = reply.ok if reply.ok is not None else reply.err  # a reply is one or the other
            if answer is not None:
                answers.append(answer.payload.to_string())
        if not answers:
            raise RouterFailed(
                f"the router at {self.endpoint} does not relay states (no answer within {REQUEST_TIMEOUT:g} s): "
                "start it with `fluidswarm router`"
            )
        return answers[0]

    def add(self, agent_id: int, cell: float) -> None:
        """Relay agent `agent_id`'s states from now on (the router answers once its table holds it, so call this
        before the agent starts: none of its states is missed)."""
        answer = self._ask(f"add {int(agent_id)} {float(cell)!r}")
        if answer != "ok":
            raise ValueError(answer.removeprefix("error "))

    @property
    def rejected(self) -> dict[str, int]:
        """Reason -> states the router's relay dropped for this run so far (relay.rs REASONS); once this handle
        is closed, its last counts."""
        if self.session.is_closed():
            return dict(self._last_rejected)
        return rejected_counts(self._ask("rejected"), f"the router at {self.endpoint}")

    def close(self) -> None:
        """Keep the last counts (the router's relay goes on for other launchers of its host)."""
        try:
            self._last_rejected = self.rejected
        except (RouterFailed, zenoh.ZError):
            pass
