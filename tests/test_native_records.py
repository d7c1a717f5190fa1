"""The compiled boundary records, agent._native: its stub names what it has, and a source tree without it
says in one line how to build it."""

from __future__ import annotations

import ast
import importlib
import re
import sys
from pathlib import Path

import pytest

from agent import _native

REPO = Path(__file__).resolve().parents[1]


def test_the_stub_names_what_the_module_has():
    tree = ast.parse((REPO / "agent" / "_native.pyi").read_text())
    stub = {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    stub |= {n.target.id for n in tree.body if isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name)}
    stub = {name for name in stub if not name.startswith("_")}  # the stub's own type aliases
    have = {name for name in dir(_native) if not name.startswith("__")}
    assert stub == have


def test_a_tree_without_the_build_is_one_line(monkeypatch):
    """A source tree whose agent/ has no agent._native (never built): importing the records is a SystemExit
    with one line naming the missing module and how to build it (Python prints it and exits 1, no traceback)."""
    import agent

    monkeypatch.delattr(agent, "_native")
    monkeypatch.setitem(sys.modules, "agent._native", None)  # `import agent._native` raises ImportError
    monkeypatch.delitem(sys.modules, "agent.records", raising=False)
    with pytest.raises(SystemExit) as exc:
        importlib.import_module("agent.records")
    message = exc.value.code
    assert isinstance(message, str) and "\n" not in message
    assert "agent._native" in message and "make install" in message


def test_the_spec_is_checked_and_written_by_the_agents_own_decoder():
    """spec.py has no checks of its own: `to_json` is spec.rs's encoder over the launcher's fields (a bad one
    named as the agent names it), `from_json` the agent's decoder, and the optional fields' defaults are the
    crate's; a spec the launcher writes decodes to itself."""
    import json

    from agent.protocol.spec import AgentSpec

    spec = AgentSpec(
        run="r-1",
        id=7,
        connect=["tcp/127.0.0.1:7447"],
        steps=5,
        initial=[1, 2.000000000000001, 0.5, -1e-300],
        params={"h": 0.7, "domain": [0, 10, 0, 10], "border": "reflect"},
        control={"alpha": 0.5},
        neighbours=[[3, 1.5, 2.0]],
        robot={"kind": "unicycle", "radius": 0.3},
        radio={"loss": 0.1, "latency": 2, "noise": 0.05, "seed": 2**64 - 1},
        obstacles=[{"kind": "circle", "centre": [5, 5], "radius": 0.5}],
        state_key_ids=True,
        inbox=True,
    )
    text = spec.to_json()
    fields = json.loads(text)
    assert sorted(fields) == sorted(_native.SPEC_FIELDS)
    assert fields["initial"] == [1.0, 2.000000000000001, 0.5, -1e-300]  # shortest round trip, bit for bit
    assert fields["params"]["rho0"] > 0 and fields["control"]["beta"] > 0  # every default written out
    again = AgentSpec.from_json(text)
    assert again.to_json() == text and AgentSpec.from_json(again.to_json()) == again
    assert again.timeout == _native.SPEC_DEFAULT_TIMEOUT and again.rate == _native.SPEC_DEFAULT_RATE
    plain = json.loads(AgentSpec(run="r", id=0, connect=["tcp/h:1"], steps=0, initial=[0, 0, 0, 0]).to_json())
    assert plain["robot"] == {} and "radio" not in plain and "obstacles" not in plain  # the spec as before
    assert "inbox" not in plain  # written only when set: an older agent reads the spec
    for bad, named in (
        ({"id": 8192}, "id must be an integer in [0, 8192)"),
        ({"params": {"h": -1}}, "params.h must be > 0"),
        ({"control": {"beta": "stiff"}}, "control.beta must be a finite number"),
        ({"neighbours": [[8192, 0, 0]]}, "neighbours entry"),
        ({"initial": [0, 0, 0, float("nan")]}, "agent spec: not JSON: a float that is not finite"),
        ({"mode": "async"}, "lockstep only"),
    ):
        with pytest.raises(ValueError, match=re.escape(named)):
            AgentSpec(**{**spec.__dict__, **bad}).to_json()
