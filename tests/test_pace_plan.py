"""The launchers' own records of a run over hosts: the share clock (agent/protocol/pace.py, against
tests/vectors/pace.json) and the signed plan of a run with workers (agent/protocol/plan.py), and the routers'
rules for them (agent/protocol/acl.py): only launchers may put a share clock or serve a plan."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from agent.protocol.acl import acl_config
from agent.protocol.pace import Pace, decode_pace, pace_key
from agent.protocol.plan import (
    NONCE_SIZE,
    Plan,
    PlanError,
    command_key,
    open_reply,
    sign_reply,
    signing_key,
)
from agent.protocol.spec import AgentSpec

VECTORS = json.loads((Path(__file__).parent / "vectors" / "pace.json").read_text())


@pytest.mark.parametrize("v", VECTORS["vectors"], ids=lambda v: v["name"])
def test_a_share_clock_encodes_as_its_vector_and_decodes_back(v):
    pace = Pace(v["first"], v["agents"], v["step"], v["done"])
    assert pace.encode().hex() == v["payload_hex"]
    assert pace_key("r1", v["first"]) == v["key"]
    assert decode_pace(v["key"], bytes.fromhex(v["payload_hex"])) == pace


@pytest.mark.parametrize("v", VECTORS["malformed"], ids=lambda v: v["name"])
def test_a_malformed_share_clock_is_none(v):
    assert decode_pace(v["key"], bytes.fromhex(v["payload_hex"])) is None


def test_a_share_clock_out_of_range_is_not_encoded():
    for bad in (Pace(8192, 1, 0), Pace(0, 0, 0), Pace(0, 1, -1), Pace(0, 1, 2**32)):
        with pytest.raises(ValueError):
            bad.encode()


def _spec(i: int, run: str = "r1", **kw) -> AgentSpec:
    return AgentSpec(run=run, id=i, connect=["tcp/127.0.0.1:7447"], steps=10, initial=[0.0, 0.0, 0.0, 0.0], **kw)


def test_a_plan_reply_opens_only_for_its_own_nonce_key_and_run():
    key, nonce = signing_key("pw", "r1"), bytes(NONCE_SIZE)
    plan = Plan("r1", "share", (2, 3), 6, "ab" * 16, (_spec(3), _spec(4)))
    data = sign_reply(key, nonce, plan.body())
    got = open_reply(key, nonce, data, "r1")
    assert got.share == (2, 3) and [s.id for s in got.specs] == [3, 4] and got.salt == "ab" * 16
    with pytest.raises(PlanError, match="signature"):
        open_reply(key, b"\1" * NONCE_SIZE, data, "r1")  # an answer to another query (a replay)
    with pytest.raises(PlanError, match="signature"):
        open_reply(signing_key("other", "r1"), nonce, data, "r1")  # another users file
    with pytest.raises(PlanError, match="signature"):
        open_reply(key, nonce, data[:-1] + b" ", "r1")  # one byte changed
    with pytest.raises(PlanError, match="signature"):
        open_reply(signing_key("pw", "r2"), nonce, data, "r2")  # another run's key


_SHARE = b'{"version":1,"run":"r1","answer":"share","swarm":4,"salt":"' + b"a" * 32 + b'",'


@pytest.mark.parametrize(
    ("body", "why"),
    [
        (b"not json", "JSON"),
        (b'{"version":2,"run":"r1","answer":"full"}', "version"),
        (b'{"version":1,"run":"r2","answer":"full"}', "run"),
        (b'{"version":1,"run":"r1","answer":"maybe"}', "answer"),
        (_SHARE + b'"share":[1,2],"specs":[]}', "share"),
        (b'{"version":1,"run":"r1","answer":"share","share":[2,2],"swarm":4,"salt":"xyz","specs":[]}', "salt"),
        (_SHARE + b'"share":[2,2],"specs":[]}', "specs"),
        (_SHARE + b'"share":[2,2],"specs":[{"run":"r1"}]}', "specs\\[0\\]"),
    ],
)
def test_every_field_of_a_signed_plan_is_checked(body, why):
    key, nonce = signing_key("pw", "r1"), bytes(NONCE_SIZE)
    with pytest.raises(PlanError, match=why):
        open_reply(key, nonce, sign_reply(key, nonce, body), "r1")


def test_a_plan_spec_of_another_run_or_with_a_secret_or_twice_is_refused():
    key, nonce = signing_key("pw", "r1"), bytes(NONCE_SIZE)
    for specs in ((_spec(1, "r2"),), (_spec(1, secret="ab" * 32),), (_spec(9),), (_spec(1), _spec(1))):
        body = Plan("r1", "share", (2, 2), 4, "a" * 32, specs).body()
        with pytest.raises(PlanError, match="specs"):
            open_reply(key, nonce, sign_reply(key, nonce, body), "r1")


def test_the_command_key_is_fresh_per_salt_and_the_same_on_every_host():
    assert command_key("pw", "r1", "a" * 32) == command_key("pw", "r1", "a" * 32)
    assert command_key("pw", "r1", "a" * 32) != command_key("pw", "r1", "b" * 32)
    assert len(bytes.fromhex(command_key("pw", "r1", "a" * 32))) == 32


def test_only_launchers_may_put_share_clocks_and_serve_the_plan():
    cfg = acl_config(["launcher", "coordinator", "recorder", "agent-0"])
    rules = {r["id"]: r for r in cfg["rules"]}
    pol = {p["id"]: p["rules"] for p in cfg["policies"]}

    def denied(role: str, message: str, key: str) -> bool:
        # a rule denies a message when one of its expressions includes the key (the patterns here: `*` one chunk)
        def includes(expr: str, k: str) -> bool:
            e, c = expr.split("/"), k.split("/")
            if e and e[-1] == "**":
                return len(c) >= len(e) - 1 and all(a in ("*", b) for a, b in zip(e[:-1], c, strict=False))
            return len(e) == len(c) and all(a in ("*", b) for a, b in zip(e, c, strict=True))

        return any(
            message in rules[r]["messages"] and any(includes(x, key) for x in rules[r]["key_exprs"])
            for r in pol[role]
            if not r.startswith("not-bit")
        )

    pace, plan = "fluidswarm/r1/pace/acegikmoqsuwy", "fluidswarm/r1/plan"
    assert not denied("launcher", "put", pace)
    assert not denied("launcher", "declare_queryable", plan) and not denied("launcher", "reply", plan)
    assert denied("launcher", "declare_queryable", "fluidswarm/r1/command")
    assert denied("launcher", "reply", "fluidswarm/r1/relay/x")
    for role in ("agent-0", "coordinator", "recorder"):
        assert denied(role, "put", pace), role
        assert denied(role, "declare_queryable", plan) and denied(role, "reply", plan), role
    assert denied("agent-0", "query", plan)  # the plan names the command key's salt
