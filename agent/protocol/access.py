"""Who may open a session on a run's router, and what each process may do there (docs/security.md).

Every process of a run authenticates to its router with its own user name and password (Zenoh usrpwd), and
the router's access control (Zenoh ACL, default deny) lets each user do only its role's part of the
protocol (docs/protocol.md):

    agent-<id>    put its own state (`state/<cx>/<cy>/<id>`), event and final keys, its own alive token, query
                  its own final key; subscribe to states, ctl and the command
    launcher      put ctl/*; subscribe to states, events, finals, alive tokens; query liveliness (a launcher
                  that connects to another router; the embedded router's own session is not a client)
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

USER_ENV = "FLUIDSWARM_ZENOH_USER"
PASSWORD_ENV = "FLUIDSWARM_ZENOH_PASSWORD"
# The embedded router's protection (docs/security.md): "auth" (default) fresh credentials per process, so no
# outsider can open a session; "acl" also per-process rights (each agent publishes only under its own id;
# states then carry the id in their key: ~45 % fewer steps/s, docs/benchmarks/security.md); "none" an open
# router as before issue 18.
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
_AGENT_RE = re.compile(r"^agent-(0|[1-9][0-9]{0,9})$")
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
    value = os.environ.get(LEVEL_ENV, "auth")
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
            f.write("".join(f"{c.user}:{c.password}\n" for c in creds))

    def remove(self) -> None:
        shutil.rmtree(self.dir, ignore_errors=True)


class AuthFileError(ValueError):
    """A users file that cannot be used (the message names the file, the line and the problem)."""


def read_users_file(path: str) -> list[Credential]:
    """`user:password` lines (blank lines and `#` comments skipped). Users are roles: agent-<id>, launcher,
    coordinator, recorder, router. Every problem is one line naming the file and the line."""
    try:
        with open(path, encoding="utf-8") as f:
            lines = f.read().splitlines()
    except (OSError, UnicodeDecodeError) as exc:
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
        if user not in ROLES and not _AGENT_RE.match(user):
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


def write_users_file(path: str, creds: list[Credential]) -> None:
    """Write a users file for multi-host runs (mode 0600; refuses to overwrite)."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "w") as f:
        f.write("".join(f"{c.user}:{c.password}\n" for c in creds))


# ---- the router's access control -------------------------------------------------------------------
_ANY_RUN = f"{keys.PREFIX}/*"
_INGRESS = ["ingress"]


def _rule(rule_id: str, messages: list[str], key_exprs: list[str], flows=_INGRESS) -> dict:
    return {"id": rule_id, "messages": messages, "flows": list(flows), "permission": "allow", "key_exprs": key_exprs}


def _agent_rule(agent_id: int) -> dict:
    i = int(agent_id)
    own = [f"{_ANY_RUN}/state/*/*/{i}", f"{_ANY_RUN}/event/{i}", f"{_ANY_RUN}/final/{i}", f"{_ANY_RUN}/alive/{i}"]
    # put its state/event/final, its alive token, and the flush query on its own final key
    return _rule(f"agent-{i}", ["put", "liveliness_token", "query"], own)


def _agent_ids(users: list[str]) -> list[int]:
    return sorted(int(u[len("agent-"):]) for u in users if _AGENT_RE.match(u))


def acl_config(users: list[str]) -> dict:
    """Zenoh's `access_control` section for these users (roles above; others get nothing: default deny).

    Ingress rules say what each may send and declare; one egress rule lets every user receive anything under
    `fluidswarm/` (what reaches it is already limited by what it may subscribe to). Deny by default.
    """
    r = _ANY_RUN
    everything = ["put", "delete", "declare_subscriber", "query", "reply", "declare_queryable",
                  "liveliness_token", "liveliness_query", "declare_liveliness_subscriber"]
    rules = [
        _rule("receive", everything, [f"{keys.PREFIX}/**"], ["egress"]),
        _rule("agent-listens", ["declare_subscriber"], [f"{r}/state/**", f"{r}/ctl/*", f"{r}/command"]),
        _rule("launcher", ["put"], [f"{r}/ctl/*"]),
        _rule("launcher-listens", ["declare_subscriber", "declare_liveliness_subscriber", "liveliness_query"],
              [f"{r}/state/**", f"{r}/event/*", f"{r}/final/*", f"{r}/alive/*", f"{r}/recorder", f"{r}/coordinator"]),
        _rule("coordinator", ["put", "liveliness_token"], [f"{r}/command", f"{r}/coordinator"]),
        _rule("coordinator-listens", ["declare_subscriber"], [f"{r}/ctl/*"]),
        _rule("recorder", ["liveliness_token"], [f"{r}/recorder"]),
        _rule("recorder-listens", ["declare_subscriber", "declare_liveliness_subscriber"],
              [f"{r}/state/**", f"{r}/event/*", f"{r}/final/*", f"{r}/command", f"{r}/alive/*"]),
        _rule("router", everything, [f"{keys.PREFIX}/**"], ["ingress", "egress"]),
    ]
    role_rules = {"launcher": ["launcher", "launcher-listens"], "coordinator": ["coordinator", "coordinator-listens"],
                  "recorder": ["recorder", "recorder-listens"], "router": ["router"]}
    subjects, policies = [], []
    for role in ROLES:
        if role not in users:
            continue
        subjects.append({"id": role, "usernames": [role]})
        who = [role]
        if role == "router":
            # A router sees no user name on the link it opened to another router (only the accepting side
            # authenticates the other), so routers are also known by their link: mutual TLS, i.e. a
            # certificate of the swarm's CA (fluidswarm router --tls-*); agents and launchers use tcp.
            subjects.append({"id": "router-over-tls", "link_protocols": ["tls"]})
            who.append("router-over-tls")
        policies.append({"id": role, "rules": role_rules[role] + ["receive"], "subjects": who})
    for i in _agent_ids(users):
        rules.append(_agent_rule(i))
        subjects.append({"id": f"agent-{i}", "usernames": [f"agent-{i}"]})
        policies.append({"id": f"agent-{i}", "rules": [f"agent-{i}", "agent-listens", "receive"],
                         "subjects": [f"agent-{i}"]})
    return {"enabled": True, "default_permission": "deny", "rules": rules, "subjects": subjects,
            "policies": policies}


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

    def __init__(self, credential_of, own: Credential | None = None, users_file: UsersFile | None = None,
                 acl: dict | None = None, capacity: int | None = None, users_file_rights: bool = False):
        self._credential_of = credential_of  # user name -> Credential | None
        self.own = own
        self._file = users_file
        self.users_file = users_file.path if users_file else ""
        self.acl = acl
        self.capacity = capacity
        # Routers that enforce per-process rights (our embedded one at level acl; multi-host routers given a
        # users file) let an agent publish states only under its own id: agents must put the id in the key.
        self.state_key_ids = acl is not None or users_file_rights

    @classmethod
    def embedded(cls) -> "LaunchAccess":
        lvl = level()
        if lvl == "none":
            return cls(lambda user: None)
        key = RunKey()
        creds = key.users(AGENT_CAPACITY)
        acl = acl_config([c.user for c in creds]) if lvl == "acl" else None
        return cls(key.credential, users_file=UsersFile(creds), acl=acl, capacity=AGENT_CAPACITY)

    @classmethod
    def client(cls, user: str = "", password: str = "", users_file: str = "") -> "LaunchAccess":
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
        if self.capacity is not None and not 0 <= agent_id < self.capacity:
            raise ValueError(f"agent id {agent_id}: this run's router knows ids 0..{self.capacity - 1} only")
        cred = self._credential_of(agent_user(agent_id))
        if cred is None and self.own is not None and self._credential_of("launcher") is not None:
            raise ValueError(f"agent id {agent_id}: no agent-{agent_id} line in the users file")
        return cred.env() if cred else {}
