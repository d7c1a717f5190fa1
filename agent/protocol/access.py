"""Who may open a session on a run's router, and what each process may do there (docs/security.md).

Every process of a run authenticates to its router with its own user name and password (Zenoh usrpwd), and
the router's access control (Zenoh ACL: default allow, ingress deny rules for everything a role must not do;
see acl_config) lets each user do only its role's part of the protocol (docs/protocol.md):

    agent-<id>    put its own state (`state/<id>`), event and final keys, its own alive token, query its own
                  final key; subscribe to states, ctl and the command
    launcher      put ctl/* and, its relay, cell keys (`state/<cx>/<cy>`); subscribe to states, events, finals,
                  alive tokens; query liveliness (a client of its router: at level acl, where the embedded
                  router is the compiled one, and in multi-host runs; at auth the embedded router is the
                  launcher's own session, no client)
    coordinator   put the command, its liveliness token; subscribe to ctl
    recorder      subscribe only (states, events, finals, command, alive tokens); its liveliness token
    router        another host's router: everything (it forwards its own clients, which it checks itself)

The rules name `fluidswarm/*/...`, not one run, so one users file serves any run on a multi-host router.
Passwords are derived from one run key (HMAC-SHA256 of the user name), so a launcher hands each process its
own password without a table; a process sees only its own.

Credentials travel in the environment of the process (`FLUIDSWARM_ZENOH_USER`, `FLUIDSWARM_ZENOH_PASSWORD`;
readable only by the same user, unlike the command line) and in the users file of the router (mode 0600, in
a private directory, deleted once the router has read it).
"""

from __future__ import annotations

import hashlib
import hmac
import os
import re
import secrets
import shutil
import tempfile
from dataclasses import dataclass

from agent.protocol import keys
from agent.protocol.acl import acl_config, agent_id_of
from agent.protocol.errors import UserError

USER_ENV = "FLUIDSWARM_ZENOH_USER"
PASSWORD_ENV = "FLUIDSWARM_ZENOH_PASSWORD"
# The embedded router's protection (docs/security.md): "acl" (default) fresh credentials per process and
# per-process rights (each agent publishes only under its own id, on its id key; the embedded router is the
# compiled one with the state relay, swarmhost/router_process.py: ~5 % fewer steps/s than an open router on the mean,
# docs/benchmarks/security.md); "auth" credentials only, so no outsider can open a session (the launcher's own
# zenoh-python session is the router); "none" an open router as before issue 18 (measurements only).
LEVEL_ENV = "FLUIDSWARM_ACCESS"
# A launcher that connects to a multi-host run's router reads its processes' credentials from this users file
# (the routers hold the same file; docs/multi-host.md)
AUTH_FILE_ENV = "FLUIDSWARM_AUTH_FILE"
LEVELS = ("acl", "auth", "none")

ROLES = ("launcher", "coordinator", "recorder", "router")
# Users provisioned on an embedded router: agent ids 0 .. AGENT_CAPACITY-1. The ACL is fixed when the router
# opens, before the launcher knows the swarm's size (late joiners come later still); 1280 users add
# ~0.16 s to its start (0.13 ms each, measured), so ids from 1280 up are refused (see Launcher.spawn).
AGENT_CAPACITY = 1280
_PASSWORD_RE = re.compile(r"^[!-~]{8,128}$")  # printable ASCII, no blanks, no ':' (checked apart)


@dataclass(frozen=True)
class Credential:
    """One process's Zenoh user name and password."""

    user: str
    password: str

    def env(self) -> dict[str, str]:
        """The environment variables that hand it to a child process (never its command line)."""
        return {USER_ENV: self.user, PASSWORD_ENV: self.password}


def agent_user(agent_id: int) -> str:
    return f"agent-{int(agent_id)}"


def credential_from_env(environ=os.environ) -> Credential | None:
    user = environ.get(USER_ENV, "")
    return Credential(user, environ.get(PASSWORD_ENV, "")) if user else None


def level() -> str:
    value = os.environ.get(LEVEL_ENV, "acl")
    if value not in LEVELS:
        raise ValueError(f"{LEVEL_ENV}={value!r}: expected one of {', '.join(LEVELS)}")
    return value


class RunKey:
    """Fresh credentials for one run: every password is HMAC-SHA256(run key, user name), 32 hex digits."""

    def __init__(self, key: bytes | None = None):
        self._key = key if key is not None else secrets.token_bytes(32)

    def credential(self, user: str) -> Credential:
        return Credential(user, hmac.new(self._key, user.encode(), hashlib.sha256).hexdigest()[:32])

    def agent(self, agent_id: int) -> Credential:
        return self.credential(agent_user(agent_id))

    def users(self, agents: int = AGENT_CAPACITY) -> list[Credential]:
        return [self.credential(r) for r in ROLES] + [self.agent(i) for i in range(agents)]


class UsersFile:
    """A usrpwd dictionary (`user:password` lines) in a private directory (0700, file 0600), removed by
    `remove()` once the router has read it."""

    def __init__(self, creds: list[Credential]):
        self.dir = tempfile.mkdtemp(prefix="fluidswarm-access-")  # mode 0700
        self.path = os.path.join(self.dir, "users.txt")
        fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with os.fdopen(fd, "w") as f:
            f.write(users_text(creds))

    def remove(self) -> None:
        shutil.rmtree(self.dir, ignore_errors=True)


class AuthFileError(UserError, ValueError):
    """A users file that cannot be used (the message names the file, the line and the problem)."""


def read_users_file(path: str) -> list[Credential]:
    """`user:password` lines (blank lines and `#` comments skipped). Users are roles: agent-<id>, launcher,
    coordinator, recorder, router. Every problem is one line naming the file and the line."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as exc:
        raise AuthFileError(f"{path}: cannot read ({exc.__class__.__name__}: {exc})") from None
    return parse_users(data, path)


def parse_users(data: bytes, path: str) -> list[Credential]:
    """`read_users_file` of the bytes of users file `path` (the fuzz target, fuzz/python_targets.py)."""
    try:
        lines = data.decode("utf-8").splitlines()
    except UnicodeDecodeError as exc:
        raise AuthFileError(f"{path}: cannot read ({exc.__class__.__name__}: {exc})") from None
    creds, seen = [], set()
    for n, line in enumerate(lines, 1):
        text = line.strip()
        if not text or text.startswith("#"):
            continue
        user, sep, password = text.partition(":")
        where = f"{path} line {n}"
        if not sep:
            raise AuthFileError(f"{where}: expected user:password")
        if user not in ROLES and agent_id_of(user) is None:
            raise AuthFileError(f"{where}: user {user!r} is not a role (agent-<id>, {', '.join(ROLES)})")
        if ":" in password or not _PASSWORD_RE.match(password):
            raise AuthFileError(f"{where}: the password must be 8-128 printable characters without ':' or blanks")
        if user in seen:
            raise AuthFileError(f"{where}: user {user!r} listed twice")
        seen.add(user)
        creds.append(Credential(user, password))
    if not creds:
        raise AuthFileError(f"{path}: no user:password line")
    return creds


def users_text(creds: list[Credential]) -> str:
    """The text of a users file: one `user:password` line each (what read_users_file reads)."""
    return "".join(f"{c.user}:{c.password}\n" for c in creds)


def write_users_file(path: str, creds: list[Credential]) -> None:
    """Write a users file for multi-host runs (mode 0600; refuses to overwrite: FileExistsError)."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "w") as f:
        f.write(users_text(creds))


@dataclass
class RouterAccess:
    """What a router needs: its users file (path) and, with `acl`, the access-control section."""

    users_file: str
    acl: dict | None


class LaunchAccess:
    """The credentials a launcher hands its processes (agents, recorder, coordinator), in their environment.

    `embedded()`: fresh for this run, for the launcher's own router (users file + ACL, per FLUIDSWARM_ACCESS).
    `client(...)`: a launcher connecting to a router of a multi-host run: with a users file (`users_file` or
    $FLUIDSWARM_AUTH_FILE), each process gets its role's line (the routers hold the same file); with only
    `user`/`password`, every process shares them (a router without per-process rights).
    """

    def __init__(
        self,
        credential_of,
        own: Credential | None = None,
        users_file: UsersFile | None = None,
        acl: dict | None = None,
        capacity: int | None = None,
        users_file_rights: bool = False,
    ):
        self._credential_of = credential_of  # user name -> Credential | None
        self.own = own
        self._file = users_file
        self.users_file = users_file.path if users_file else ""
        self.acl = acl
        self.capacity = capacity
        # Routers that enforce per-process rights (our embedded one at level acl; multi-host routers given a
        # users file) let an agent publish states only under its own id: agents put them on state/<id>, the
        # relay inside the router puts them on the cell keys (agent/native/src/relay.rs: the embedded router's,
        # or a host router's in a multi-host run).
        self.state_key_ids = acl is not None or users_file_rights

    @classmethod
    def embedded(cls, capacity: int = AGENT_CAPACITY) -> LaunchAccess:
        """An embedded router's access: agent ids 0..capacity-1 provisioned (a run that knows its swarm gives
        its size: the router's rules grow with the users, ~0.25 ms each at its start)."""
        lvl = level()
        if lvl == "none":
            return cls(lambda user: None)
        capacity = min(max(capacity, 1), AGENT_CAPACITY)
        key = RunKey()
        creds = key.users(capacity)
        acl = acl_config([c.user for c in creds]) if lvl == "acl" else None
        # `own`: at acl the launcher is a client of its (compiled) router, with the launcher's credentials
        return cls(
            key.credential,
            own=key.credential("launcher"),
            users_file=UsersFile(creds),
            acl=acl,
            capacity=capacity,
        )

    @classmethod
    def client(cls, user: str = "", password: str = "", users_file: str = "") -> LaunchAccess:
        source = "--auth-file" if users_file else AUTH_FILE_ENV
        users_file = users_file or os.environ.get(AUTH_FILE_ENV, "")
        if users_file:
            try:
                table = {c.user: c for c in read_users_file(users_file)}
            except AuthFileError as exc:
                raise AuthFileError(f"{source} {exc}") from None
            own = table.get("launcher")
            if own is None:
                raise AuthFileError(f"{users_file}: no 'launcher' user (this launcher's own credentials)")
            return cls(table.get, own=own, users_file_rights=True)
        if user:
            shared = Credential(user, password)
            return cls(lambda _user: shared, own=shared)
        return cls(lambda user: None)

    def opened(self) -> None:
        """The router has read the users file (or failed to): remove it."""
        if self._file is not None:
            self._file.remove()

    def env_for(self, role: str) -> dict[str, str]:
        cred = self._credential_of(role)
        return cred.env() if cred else {}

    def env_for_agent(self, agent_id: int) -> dict[str, str]:
        if not 0 <= agent_id < keys.MAX_AGENTS:
            raise ValueError(
                f"agent id {agent_id}: ids 0..{keys.MAX_AGENTS - 1} only (an agent's keys hold its id "
                f"in {keys.ID_BITS} bits, docs/protocol.md)"
            )
        if self.capacity is not None and not 0 <= agent_id < self.capacity:
            raise ValueError(f"agent id {agent_id}: this run's router knows ids 0..{self.capacity - 1} only")
        cred = self._credential_of(agent_user(agent_id))
        if cred is None and self.own is not None and self._credential_of("launcher") is not None:
            raise ValueError(f"agent id {agent_id}: no agent-{agent_id} line in the users file")
        return cred.env() if cred else {}
