"""Where the compiled programs are (agent/native, built by `make install` with cargo): the agent, and the
router that hosts the state relay at access level acl (agent/router_process.py)."""

from __future__ import annotations

import os
from pathlib import Path

NATIVE_DIR = Path(__file__).resolve().parent / "native"
ENV_OVERRIDE = "FLUIDSWARM_AGENT_BIN"
ROUTER_ENV_OVERRIDE = "FLUIDSWARM_ROUTER_BIN"


class AgentNotBuilt(RuntimeError):
    """A compiled program is missing: the user has to build it (one line, with the command that does)."""


def _program(path: Path, what: str) -> str:
    if not (path.is_file() and os.access(path, os.X_OK)):
        raise AgentNotBuilt(f"{what} program {path} is not built: run `make install` "
                            f"(cargo build --release --locked --manifest-path {NATIVE_DIR / 'Cargo.toml'})")
    return str(path)


def _agent_path() -> Path:
    override = os.environ.get(ENV_OVERRIDE)
    return Path(override) if override else NATIVE_DIR / "target" / "release" / "fluidswarm-agent"


def agent_executable() -> str:
    """The agent binary: $FLUIDSWARM_AGENT_BIN if set, else agent/native/target/release/fluidswarm-agent."""
    return _program(_agent_path(), "agent")


def router_executable() -> str:
    """The router binary: $FLUIDSWARM_ROUTER_BIN if set, else `fluidswarm-router` next to the agent binary
    (one cargo build makes both)."""
    override = os.environ.get(ROUTER_ENV_OVERRIDE)
    return _program(Path(override) if override else _agent_path().with_name("fluidswarm-router"), "router")
