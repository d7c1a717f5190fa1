"""Where the compiled programs are: the agent, and the router that hosts the state relay at access level acl
(swarmhost/router_process.py). Both are built from agent/native by cargo.

Looked up in this order: $FLUIDSWARM_AGENT_BIN / $FLUIDSWARM_ROUTER_BIN; the source tree's cargo build
(agent/native/target/release, what `make install` keeps fresh in a checkout or an editable install); where
`pip install` put them (the wheel carries them as scripts, setuptools-rust `RustBin`, pyproject.toml): the
environment's scripts folder, the base interpreter's, the user scheme's, and the `--prefix`/`--target` layouts
next to the installed package — the places astral-sh/uv's `_find_uv.py` looks for its own program.
"""

from __future__ import annotations

import fnmatch
import os
import sys
import sysconfig
from pathlib import Path

from agent.protocol.errors import UserError

PACKAGE_DIR = Path(__file__).resolve().parent
# the agent crate of a source checkout (agent/native beside this package); absent in an installed package
NATIVE_DIR = PACKAGE_DIR.parent / "agent" / "native"
ENV_OVERRIDE = "FLUIDSWARM_AGENT_BIN"
ROUTER_ENV_OVERRIDE = "FLUIDSWARM_ROUTER_BIN"
AGENT = "fluidswarm-agent"
ROUTER = "fluidswarm-router"
ROUTER_TRAFFIC = "fluidswarm-router-traffic"  # the router that counts what crosses to other routers


class AgentNotBuilt(UserError, RuntimeError):
    """A compiled program is missing: the user has to build or install it (one line saying how)."""


def _runnable(path: Path) -> bool:
    return path.is_file() and os.access(path, os.X_OK)


def _parent_above(path: Path, pattern: str) -> Path | None:
    """`path` with the trailing parts matching `pattern` (`/`-separated, `*` wildcards) cut off, else None:
    the prefix of a `pip install --prefix` (…/lib/python3.X/site-packages/swarmhost) or `--target` (…/swarmhost)."""
    want = pattern.split("/")
    parts = path.parts
    if len(parts) <= len(want) or not all(fnmatch.fnmatch(p, w) for p, w in zip(reversed(parts), reversed(want))):
        return None
    return Path(*parts[: -len(want)])


def installed_dirs() -> list[Path]:
    """The folders where pip may have put the programs, most likely first, each once."""
    scripts = [
        sysconfig.get_path("scripts"),  # this environment's (a venv's bin/)
        sysconfig.get_path("scripts", vars={"base": sys.base_prefix}),  # the base interpreter's
        sysconfig.get_path("scripts", scheme=sysconfig.get_preferred_scheme("user")),  # pip install --user
    ]
    prefixes = [
        _parent_above(PACKAGE_DIR, "lib/python*/site-packages/swarmhost"),  # pip install --prefix P: P/bin
        _parent_above(PACKAGE_DIR, "swarmhost"),  # pip install --target T: T/bin
    ]
    out: list[Path] = []
    for d in [Path(s) for s in scripts] + [p / "bin" for p in prefixes if p is not None]:
        if d not in out:
            out.append(d)
    return out


def _find(name: str, what: str) -> str:
    exe = name + (sysconfig.get_config_var("EXE") or "")
    built = NATIVE_DIR / "target" / "release" / exe
    candidates = ([built] if NATIVE_DIR.is_dir() else []) + [d / exe for d in installed_dirs()]
    for path in candidates:
        if _runnable(path):
            return str(path)
    if NATIVE_DIR.is_dir():  # a source checkout: cargo builds it
        raise AgentNotBuilt(
            f"{what} program {built} is not built: run `make install` "
            f"(cargo build --release --locked --manifest-path {NATIVE_DIR / 'Cargo.toml'})"
        )
    raise AgentNotBuilt(
        f"{what} program {exe} is not installed (not in {candidates[0].parent}): reinstall "
        f"fluidswarm with a Rust toolchain on PATH (https://rustup.rs), `pip install "
        f"--force-reinstall fluidswarm`, or set ${ENV_OVERRIDE if name == AGENT else ROUTER_ENV_OVERRIDE}"
    )


def _override(env: str, what: str) -> str | None:
    value = os.environ.get(env)
    if not value:
        return None
    if not _runnable(Path(value)):
        raise AgentNotBuilt(f"${env}={value}: no {what} program there (not an executable file)")
    return value


def agent_executable() -> str:
    """The agent binary: $FLUIDSWARM_AGENT_BIN if set, else the source tree's build, else the installed one."""
    return _override(ENV_OVERRIDE, "agent") or _find(AGENT, "agent")


def router_executable() -> str:
    """The router binary: $FLUIDSWARM_ROUTER_BIN if set; else, when $FLUIDSWARM_AGENT_BIN is set,
    `fluidswarm-router` next to it (one cargo build makes both); else found as the agent is."""
    given = _override(ROUTER_ENV_OVERRIDE, "router")
    if given:
        return given
    agent = os.environ.get(ENV_OVERRIDE)
    if agent:
        sibling = Path(agent).with_name(ROUTER + (sysconfig.get_config_var("EXE") or ""))
        if not _runnable(sibling):
            raise AgentNotBuilt(
                f"router program {sibling} (next to ${ENV_OVERRIDE}) is not built: "
                f"build it there, or set ${ROUTER_ENV_OVERRIDE}"
            )
        return str(sibling)
    return _find(ROUTER, "router")


def router_traffic_executable() -> str:
    """The counting router (`fluidswarm router --count-traffic`): `fluidswarm-router-traffic` next to the router
    binary. Not in the default build (zenoh's statistics cost every message; agent/native/Cargo.toml): one line
    saying how to build it when it is not there."""
    router = Path(router_executable())
    sibling = router.with_name(ROUTER_TRAFFIC + (sysconfig.get_config_var("EXE") or ""))
    if not _runnable(sibling):
        raise AgentNotBuilt(
            f"--count-traffic needs {sibling} (the router with zenoh's statistics), which is not built: "
            "make router-traffic"
        )
    return str(sibling)
