"""Shared fixtures, and the line between unit tests and swarm tests.

A test that starts processes (the fluidswarm CLI, agents, routers, recorders) or opens a Zenoh session is
marked `swarm` (registered in pyproject.toml); `make test` runs the unit tests first (`-m "not swarm"`, in
seconds) and the swarm tests after. A unit test that starts such a process or session anyway fails here,
naming the marker, so the split cannot drift.

The shared data sets live next to the repository (../shared/datasets); a test that needs one fails (not
skips) when it is missing.
"""

from __future__ import annotations

import signal
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
import zenoh

REPO = Path(__file__).resolve().parents[1]

# A test run started as a background job of a non-interactive shell (`make test &`) inherits SIGINT ignored,
# and so would every process it starts: the tests that stop a launcher or a recorder with SIGINT then waited
# for it forever (an ignored signal stays ignored across exec, and Python installs no KeyboardInterrupt for
# it). Handled here, the children start with SIGINT at its default, as from a terminal.
if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
DATASETS = REPO.parent / "shared" / "datasets"
# Programs a unit test may not start: Python (the CLI, a coordinator, a recorder) and the compiled agent.
# Other programs (fc-list, started by matplotlib when it builds its font cache) are not the swarm's.
_SWARM_PROGRAMS = (Path(sys.executable).name, "python", "python3", "fluidswarm-agent", "zenohd")


def _dataset(name: str) -> Path:
    path = DATASETS / name
    if not path.is_dir():
        pytest.fail(f"this test needs the shared data set {name} at {path} (../shared next to the repository)")
    return path


@pytest.fixture(scope="session")
def weizmann() -> Path:
    """The Weizmann action clips (one PNG strip a person and action: wave2/person0.png, ...)."""
    return _dataset("weizmann-actions-64")


@pytest.fixture(scope="session")
def shared_hands() -> Path:
    """The Sign Language Digits hand set (one folder a class, 0..9)."""
    return _dataset("sign-language-digits")


@pytest.fixture(scope="session")
def shared_image(shared_hands: Path) -> Callable[[int], Path]:
    """The last image of a class of the shared hand set (a fixed, documented pick)."""
    return lambda cls: max((shared_hands / str(cls)).iterdir())


@pytest.fixture(autouse=True)
def _unit_tests_start_no_swarm(request, monkeypatch):
    """Fail a test not marked `swarm` that starts a swarm process or a Zenoh session."""
    if request.node.get_closest_marker("swarm"):
        return
    name = request.node.nodeid

    def no_session(*args, **kwargs):
        raise AssertionError(f"{name} opens a Zenoh session: mark it @pytest.mark.swarm")

    spawn = subprocess.Popen._execute_child

    def no_process(self, args, *rest, **kwargs):
        program = Path(str(args[0] if isinstance(args, (list, tuple)) else str(args).split()[0])).name
        if program in _SWARM_PROGRAMS:
            raise AssertionError(f"{name} starts {program}: mark it @pytest.mark.swarm")
        return spawn(self, args, *rest, **kwargs)

    monkeypatch.setattr(zenoh, "open", no_session)
    monkeypatch.setattr(subprocess.Popen, "_execute_child", no_process)
