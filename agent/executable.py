"""Where the compiled agent program is (agent/native, built by `make install` with cargo)."""

from __future__ import annotations

import os
from pathlib import Path

NATIVE_DIR = Path(__file__).resolve().parent / "native"
ENV_OVERRIDE = "FLUIDSWARM_AGENT_BIN"


class AgentNotBuilt(RuntimeError):
    """The native agent is missing: the user has to build it (one line, with the command that does)."""


def agent_executable() -> str:
    """The agent binary: $FLUIDSWARM_AGENT_BIN if set, else agent/native/target/release/fluidswarm-agent."""
    override = os.environ.get(ENV_OVERRIDE)
    path = Path(override) if override else NATIVE_DIR / "target" / "release" / "fluidswarm-agent"
    if not (path.is_file() and os.access(path, os.X_OK)):
        raise AgentNotBuilt(f"agent program {path} is not built: run `make install` "
                            f"(cargo build --release --locked --manifest-path {NATIVE_DIR / 'Cargo.toml'})")
    return str(path)
