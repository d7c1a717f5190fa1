"""The compiled boundary records, agent._native: its stub names what it has, and a source tree without it
says in one line how to build it."""

from __future__ import annotations

import ast
import importlib
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
