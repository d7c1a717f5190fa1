"""One base for the project's errors (agent/protocol/errors.py): every exception class of the five packages
derives from FluidswarmError, which the command line prints as one line (fluidswarm/cli.py)."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

from agent.protocol.errors import FluidswarmError

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("agent", "swarmhost", "coordinator", "perception", "ros2link", "fluidswarm", "research")
NOT_YET: set[str] = set()


def exception_classes() -> list[str]:
    """module.Class of every class whose bases name an Error, Exception, Rejected or Lost (read with ast)."""
    found = []
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            if "native" in path.relative_to(REPO).parts:
                continue
            module = ".".join(path.relative_to(REPO).with_suffix("").parts).removesuffix(".__init__")
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.ClassDef) and any(
                    isinstance(b, ast.Name) and b.id.endswith(("Error", "Exception", "Rejected", "Lost", "Failed"))
                    for b in node.bases
                ):
                    found.append(f"{module}.{node.name}")
    return found


def test_every_exception_class_has_the_one_base():
    names = exception_classes()
    assert len(names) >= 15  # the walk found them (InputError, HelperLost, CommandRejected, ...)
    orphans = []
    for name in names:
        module, _, cls = name.rpartition(".")
        if name not in NOT_YET and not issubclass(getattr(importlib.import_module(module), cls), FluidswarmError):
            orphans.append(name)
    assert not orphans, f"exception classes without FluidswarmError as a base: {orphans}"
