"""A run's plan for its workers (`fluidswarm/<run>/plan`, docs/protocol.md "The plan of a run with workers"):
the main host of `imitate|run --workers M` serves it on a queryable, each `fluidswarm worker` fetches its share.
Launchers only (no agent reads it), so it has no Rust twin.

The query's payload is the worker's nonce (NONCE_SIZE random bytes). The reply is MAC (32 bytes) then the body
(UTF-8 JSON): MAC = HMAC-SHA256(plan key, b"fluidswarm-plan-1\\0" + nonce + body), where the plan key is derived
from the `launcher` password of the run's users file (every host holds the file, no agent has that line):
a reply is checked against the worker's own nonce before its body is parsed (sign bytes, not parses), so a
reply to another query, an old one, or one made without the file is refused.

The body: {"version": 1, "run": R, "answer": "share" | "started" | "full", ...}; a share adds "share": [K, M]
(region K of M, K >= 2: the main host runs region 1), "swarm": N (agents of the whole run), "salt": 32 hex
digits (with the plan key's password and R: the run's command key, `command_key`, which never crosses the
network), and "specs": the share's agent specs (agent/protocol/spec.py, each read by the agent's own decoder).
"""

from __future__ import annotations

import hashlib
import hmac
import json
import re
from dataclasses import dataclass

from agent.protocol import keys
from agent.protocol.errors import SwarmError
from agent.protocol.spec import AgentSpec

VERSION = 1
NONCE_SIZE = 16
MAC_SIZE = 32
MAX_BODY = 16 << 20  # bytes: a share of 8192 agents' specs fits many times over
ANSWERS = ("share", "started", "full")
_DOMAIN = b"fluidswarm-plan-1\0"
_SALT_RE = re.compile(r"^[0-9a-f]{32}$")


class PlanError(SwarmError, ValueError):
    """A reply that is not a valid plan of this run for this query (the message says what is wrong)."""


def plan_key(run: str) -> str:
    return f"{keys.PREFIX}/{run}/plan"


def _derive(password: str, purpose: str, run: str, salt: str = "") -> bytes:
    return hmac.new(password.encode(), f"fluidswarm {purpose}\0{run}\0{salt}".encode(), hashlib.sha256).digest()


def signing_key(launcher_password: str, run: str) -> bytes:
    """The key of run `run`'s plan replies, from the users file's `launcher` password."""
    return _derive(launcher_password, "plan key", run)


def command_key(launcher_password: str, run: str, salt: str) -> str:
    """The run's command key (hex, as FLUIDSWARM_SECRET): the same on every host that holds the users file and
    was told the run's `salt`; a fresh salt per run makes a fresh key."""
    return _derive(launcher_password, "command key", run, salt).hex()


@dataclass(frozen=True)
class Plan:
    """One reply: `answer` "share" (then `share` (K, M), `swarm`, `salt`, `specs`), "started" (the run has
    begun: too late) or "full" (every share has its worker)."""

    run: str
    answer: str
    share: tuple[int, int] = (0, 0)
    swarm: int = 0
    salt: str = ""
    specs: tuple[AgentSpec, ...] = ()

    def body(self) -> bytes:
        d: dict = {"version": VERSION, "run": self.run, "answer": self.answer}
        if self.answer == "share":
            d.update(
                share=list(self.share),
                swarm=self.swarm,
                salt=self.salt,
                specs=[json.loads(s.to_json()) for s in self.specs],
            )
        return json.dumps(d, separators=(",", ":")).encode()


def sign_reply(key: bytes, nonce: bytes, body: bytes) -> bytes:
    return hmac.new(key, _DOMAIN + nonce + body, hashlib.sha256).digest() + body


def check_nonce(data: bytes | None) -> bytes | None:
    """A query's nonce, or None if its payload is not exactly NONCE_SIZE bytes."""
    return bytes(data) if data is not None and len(data) == NONCE_SIZE else None


def open_reply(key: bytes, nonce: bytes, data: bytes, run: str) -> Plan:
    """The plan in reply `data` to the query of `nonce`: PlanError naming what is wrong (the signature first,
    then every field; each spec through the agent's own decoder, for this run, without a secret)."""
    data = bytes(data)
    if len(data) <= MAC_SIZE or len(data) > MAC_SIZE + MAX_BODY:
        raise PlanError(f"a reply of {len(data)} bytes")
    mac, body = data[:MAC_SIZE], data[MAC_SIZE:]
    if not hmac.compare_digest(mac, hmac.new(key, _DOMAIN + nonce + body, hashlib.sha256).digest()):
        raise PlanError("its signature does not verify (another users file, or not an answer to this query)")
    try:
        d = json.loads(body.decode())
    except (UnicodeDecodeError, ValueError):
        raise PlanError("its body is not JSON") from None
    if not isinstance(d, dict) or d.get("version") != VERSION:
        raise PlanError(f"version {d.get('version') if isinstance(d, dict) else None!r}, expected {VERSION}")
    if d.get("run") != run:
        raise PlanError(f"a plan of run {d.get('run')!r}")
    answer = d.get("answer")
    if answer not in ANSWERS:
        raise PlanError(f"answer {answer!r}")
    if answer != "share":
        return Plan(run, answer)
    share, swarm, salt, specs = d.get("share"), d.get("swarm"), d.get("salt"), d.get("specs")
    if not (isinstance(share, list) and len(share) == 2 and all(type(v) is int for v in share)):
        raise PlanError(f"share {share!r}: expected [K, M], 2 <= K <= M")
    if not 2 <= share[0] <= share[1] <= keys.MAX_AGENTS:
        raise PlanError(f"share {share!r}: expected [K, M], 2 <= K <= M")
    if type(swarm) is not int or not 1 <= swarm <= keys.MAX_AGENTS:
        raise PlanError(f"swarm {swarm!r}")
    if not isinstance(salt, str) or not _SALT_RE.match(salt):
        raise PlanError("salt: expected 32 hex digits")
    if not isinstance(specs, list) or not 1 <= len(specs) <= swarm:
        raise PlanError(f"specs: expected 1..{swarm} agent specs")
    out = []
    for k, s in enumerate(specs):
        try:
            spec = AgentSpec.from_json(json.dumps(s))
        except (ValueError, TypeError) as exc:
            raise PlanError(f"specs[{k}]: {exc}") from None
        if spec.run != run or spec.secret or not 0 <= spec.id < swarm:
            raise PlanError(f"specs[{k}]: agent {spec.id} of run {spec.run!r} (with a secret: {bool(spec.secret)})")
        out.append(spec)
    if len({s.id for s in out}) != len(out):
        raise PlanError("specs: an agent id twice")
    return Plan(run, answer, (share[0], share[1]), swarm, salt, tuple(out))
