"""Zenoh session configurations for agents (clients) and routers, in one place."""

from __future__ import annotations

import json
import os

import zenoh

from agent.protocol.access import PASSWORD_ENV, USER_ENV

# A launcher joining another host's router is one process, not hundreds at once: it need not outlast a flooded
# accept queue, and a router that refuses its credentials looks to zenoh like one that is absent (it retries
# both alike), so its user hears of either after this long, not after the agents' 2 minutes.
LAUNCHER_CONNECT_TIMEOUT_MS = 8000


def client_config(
    endpoints: list[str],
    user: str = "",
    password: str = "",
    tls: TlsFiles | None = None,
    timeout_ms: int = 120000,
) -> zenoh.Config:
    """A client that keeps retrying its router: 200 processes starting at once overwhelm a router's
    accept queue (../shared/notes: 1 in 6 failed) unless connect/timeout_ms lets them retry.

    Without `user`, the credentials its launcher handed it in the environment (FLUIDSWARM_ZENOH_USER and
    FLUIDSWARM_ZENOH_PASSWORD, agent/protocol/access.py), if any: never on the command line."""
    if not user:
        user, password = os.environ.get(USER_ENV, ""), os.environ.get(PASSWORD_ENV, "")
    conf = zenoh.Config()
    conf.insert_json5("mode", '"client"')
    conf.insert_json5("connect/endpoints", json.dumps(endpoints))
    # Retry for up to 2 minutes, not forever: a process still connecting when its launcher (and router)
    # died blocks inside zenoh.open, where no signal handler runs, and would be left behind.
    conf.insert_json5("connect/timeout_ms", str(int(timeout_ms)))
    conf.insert_json5("scouting/multicast/enabled", "false")
    if user:
        conf.insert_json5("transport/auth/usrpwd/user", json.dumps(user))
        conf.insert_json5("transport/auth/usrpwd/password", json.dumps(password))
    if tls is not None:
        tls.apply(conf)
    return conf


MAX_SESSIONS = 20000
ACCEPT_PENDING = 2000


def router_settings(
    listen: list[str],
    connect: list[str] | None = None,
    dictionary_file: str = "",
    user: str = "",
    password: str = "",
    acl: dict | None = None,
    tls: TlsFiles | None = None,
) -> dict[str, object]:
    """A router's settings (config path -> value) for the compiled router (swarmhost/router_process.py writes
    them as a JSON file: router_config_dict).

    `dictionary_file`: usrpwd users (`user:password` lines), required of every session; `acl`: Zenoh's
    `access_control` section (agent/protocol/access.py: acl_config); `user`/`password`: this router's own
    credentials towards the routers it connects to; `tls`: certificates for `tls/` endpoints."""
    settings: dict[str, object] = {
        "mode": "router",
        "listen/endpoints": list(listen),
        "connect/endpoints": list(connect or []),
        "scouting/multicast/enabled": False,
        # zenoh's defaults (1000 sessions, 100 handshakes pending) cap a swarm below 1000 agents: every agent,
        # the recorder and the coordinator are sessions of this router, and they all connect at once.
        "transport/unicast/max_sessions": MAX_SESSIONS,
        "transport/unicast/accept_pending": ACCEPT_PENDING,
    }
    if not connect:
        # zenoh's router sleeps scouting/delay (500 ms by default) at the end of zenoh::open, whatever it has to
        # discover (zenoh/src/net/runtime/orchestrator.rs start_router): time for routers it connects to to
        # exchange their routes before its clients arrive. A router that connects to none (every launcher's
        # embedded router, a host's first router) has nothing to wait for: ready in 6 ms instead of 510.
        settings["scouting/delay"] = 0
    if dictionary_file:
        settings["transport/auth/usrpwd/dictionary_file"] = dictionary_file
        if user:
            settings["transport/auth/usrpwd/user"] = user
            settings["transport/auth/usrpwd/password"] = password
    if acl is not None:
        settings["access_control"] = acl
    if tls is not None:
        settings.update(tls.settings())
    return settings


def router_config_dict(*args, **kwargs) -> dict:
    """The same settings as one nested dict: a Zenoh configuration file (JSON is JSON5)."""
    out: dict = {}
    for path, value in router_settings(*args, **kwargs).items():
        *parents, leaf = path.split("/")
        node = out
        for name in parents:
            node = node.setdefault(name, {})
        node[leaf] = value
    return out


class TlsFiles:
    """PEM files of a `tls/` link: the CA that signed the peers' certificates, this node's certificate and key.

    Both sides present a certificate and check the other's against the CA (mutual TLS), so only nodes holding
    a certificate of the swarm's CA open a link (docs/multi-host.md)."""

    def __init__(self, ca: str, cert: str, key: str):
        for name, path in (("--tls-ca", ca), ("--tls-cert", cert), ("--tls-key", key)):
            if not os.path.isfile(path):
                raise ValueError(f"{name} {path}: no such file")
        self.ca, self.cert, self.key = ca, cert, key

    def settings(self) -> dict[str, object]:
        tls = {
            "root_ca_certificate": self.ca,
            "listen_certificate": self.cert,
            "listen_private_key": self.key,
            "connect_certificate": self.cert,
            "connect_private_key": self.key,
            "enable_mtls": True,
            "verify_name_on_connect": False,
        }
        return {f"transport/link/tls/{k}": v for k, v in tls.items()}

    def apply(self, conf: zenoh.Config) -> None:
        for path, value in self.settings().items():
            conf.insert_json5(path, json.dumps(value))
