"""The router's access-control rules (Zenoh's `access_control` section) for a run's users: what each role may
not do (docs/security.md "What each process may do"); access.py hands the section to the router.

Default allow with ingress deny rules: zenoh 1.10's `default_permission: deny` also filters every message a
router forwards on the way out, which cost 19-24 % of the steps/s (docs/benchmarks/security.md).
"""

from __future__ import annotations

import re

from agent.protocol import keys

_AGENT_RE = re.compile(r"^agent-(0|[1-9][0-9]{0,9})$")

# Deny rules say everything a role must not do. Deny wins over allow and a rule matches a message when the
# rule's key expression *includes* the message's, so:
#   - "every agent's keys but mine" is one pattern per id bit (keys.py: id_chunk): `**/$*<letter>$*` with the
#     letter of the bit agent i does not have; each agent id chunk but i's own holds at least one of them;
#   - a message key with wildcards (`fluidswarm/**`, `.../state/*`) is included by no pattern narrower than
#     `**`, so it passes the router; every receiver checks keys exactly (keys.state_key_vouches, ctl_what,
#     id_from_key), and such a key names no agent id and no ctl message.
_ANY_RUN = f"{keys.PREFIX}/*"
_EVERYTHING = ["**"]
_ADMIN = ["@/**"]  # the router's admin space
# batch: the routers' relays' batches of states for the recorder (agent/native/src/relay.rs), no client's to put;
# inbox: the relay's one message per step to an agent, no client's to put (relay/inboxes.rs); watch: the cells an
# agent names to the relay, its own key only (watch.rs); imitation/plan: the launcher's plan for its coordinator,
# imitation/note: the coordinator's notes for its launcher and recorder (agent/protocol/imitation.py), each the
# one role's to put
_KINDS = (
    "state",
    "event",
    "final",
    "alive",
    "ctl",
    "command",
    "recorder",
    "coordinator",
    "relay",
    "pace",
    "plan",
    "batch",
    "inbox",
    "watch",
    "imitation/plan",
    "imitation/note",
)
# one key per run, no chunk after the kind
_LEAVES = ("command", "recorder", "coordinator", "plan", "imitation/plan", "imitation/note")


def _deny(rule_id: str, messages: list[str], key_exprs: list[str]) -> dict:
    return {"id": rule_id, "messages": messages, "flows": ["ingress"], "permission": "deny", "key_exprs": key_exprs}


def _kinds_but(*mine: str) -> list[str]:
    """Key expressions of every kind of key of the protocol except `mine` (any run)."""
    out = []
    for kind in _KINDS:
        if kind in mine:
            continue
        out.append(f"{_ANY_RUN}/{kind}" if kind in _LEAVES else f"{_ANY_RUN}/{kind}/**")
    return out


def _bit_rule(k: int, bit: int) -> str:
    return f"not-bit{k}-{bit}"


def _inbox_rule(k: int, bit: int) -> str:
    return f"inbox-not-bit{k}-{bit}"


def agent_id_of(user: str) -> int | None:
    """The id of user `agent-<id>`, None for any other name."""
    return int(user[len("agent-") :]) if _AGENT_RE.match(user) else None


def _agent_ids(users: list[str]) -> list[int]:
    return sorted(i for i in map(agent_id_of, users) if i is not None)


def acl_config(users: list[str]) -> dict:
    """Zenoh's `access_control` section for these users (roles above). Default allow; ingress deny rules.

    An agent may put its state, event, final and watch keys, declare its alive token, query (the flush on its
    own final key) and subscribe (another agent's inbox excepted); it may not put or declare another agent's keys
    (the bit rules), ctl, the inboxes, the
    command, cell keys (`state/<cx>/<cy>`: only the relay puts there) or the recorder's or
    coordinator's tokens, and it may never delete, reply, declare a queryable or query liveliness. The other
    roles likewise
    (docs/security.md has the table); the `router` role (another host's router) may do everything.
    """
    never = ["delete", "reply", "declare_queryable"]
    rules = [
        _deny("never", never, _EVERYTHING),
        _deny("no-admin", ["put", "query", "liveliness_token"], _ADMIN),
        # agents
        _deny("agent-never", ["liveliness_query"], _EVERYTHING),
        # a host router's relay requests (relay/<zid>: add an agent to relay) and the run's plan (it names the
        # salt of the command key) are the launchers' only
        _deny("agent-query", ["query"], [f"{_ANY_RUN}/relay/**", f"{_ANY_RUN}/plan"]),
        _deny("agent-put", ["put"], _kinds_but("state", "event", "final", "watch") + [f"{_ANY_RUN}/state/*/*/**"]),
        _deny("agent-token", ["liveliness_token"], _kinds_but("alive")),
        # launcher (a client of its router): ctl, its host's share clock (pace) and an imitation's plan only; the
        # relay that puts on the cell keys is inside the routers (agent/native/src/relay.rs), so no state key at
        # all, an agent's or a cell's; the main host of a run with workers serves its plan (a queryable on
        # `plan`, the one reply)
        _deny("launcher-never", ["delete"], _EVERYTHING),
        _deny("launcher-serve", ["reply", "declare_queryable"], _kinds_but("plan") + _ADMIN),
        _deny("launcher-put", ["put"], _kinds_but("ctl", "pace", "imitation/plan")),
        _deny("launcher-token", ["liveliness_token"], _EVERYTHING),
        # coordinator
        _deny("coordinator-never", ["query", "liveliness_query", "declare_liveliness_subscriber"], _EVERYTHING),
        _deny("coordinator-put", ["put"], _kinds_but("command", "imitation/note")),
        _deny("coordinator-token", ["liveliness_token"], _kinds_but("coordinator")),
        # recorder
        _deny("recorder-never", ["put", "query", "liveliness_query"], _EVERYTHING),
        _deny("recorder-token", ["liveliness_token"], _kinds_but("recorder")),
    ]
    # "bit k is not b": agent ids whose bit k is 1-b may not use keys whose last chunk holds letter (k, b), nor
    # hear another agent's inbox (its exact key; a wildcard subscription names no agent: docs/security.md)
    for k in range(keys.ID_BITS):
        for bit in (0, 1):
            letter = keys.bit_letter(k, bit)
            rules.append(_deny(_bit_rule(k, bit), ["put", "liveliness_token", "query"], [f"**/$*{letter}$*"]))
            rules.append(_deny(_inbox_rule(k, bit), ["declare_subscriber"], [f"{_ANY_RUN}/inbox/$*{letter}$*"]))
    role_rules = {
        "launcher": ["launcher-never", "launcher-serve", "no-admin", "launcher-put", "launcher-token"],
        "coordinator": ["never", "no-admin", "coordinator-never", "coordinator-put", "coordinator-token"],
        "recorder": ["never", "no-admin", "recorder-never", "recorder-token"],
    }
    subjects, policies = [], []
    for role, denied in role_rules.items():
        # `router` (another host's router) gets no rule: it may do everything (it checks its own clients
        # itself), and so may the other end of a router-to-router link, where no user name is seen (only the
        # accepting side authenticates): that link is mutual TLS with a certificate of the swarm's CA.
        if role in users:
            subjects.append({"id": role, "usernames": [role]})
            policies.append({"id": role, "rules": denied, "subjects": [role]})
    for i in _agent_ids(users):
        if i >= keys.MAX_AGENTS:
            raise ValueError(f"agent-{i}: ids 0..{keys.MAX_AGENTS - 1} only (keys.ID_BITS)")
        subjects.append({"id": f"agent-{i}", "usernames": [f"agent-{i}"]})
        bits = [r(k, 1 - ((i >> k) & 1)) for k in range(keys.ID_BITS) for r in (_bit_rule, _inbox_rule)]
        policies.append(
            {
                "id": f"agent-{i}",
                "rules": ["never", "no-admin", "agent-never", "agent-query", "agent-put", "agent-token"] + bits,
                "subjects": [f"agent-{i}"],
            }
        )
    return {"enabled": True, "default_permission": "allow", "rules": rules, "subjects": subjects, "policies": policies}
