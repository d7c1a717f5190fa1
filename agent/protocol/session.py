"""Zenoh session configurations for agents (clients) and routers, in one place."""

from __future__ import annotations

import json

import zenoh


def client_config(endpoints: list[str], user: str = "", password: str = "") -> zenoh.Config:
    """A client that keeps retrying its router: 200 processes starting at once overwhelm a router's
    accept queue (../shared/notes: 1 in 6 failed) unless connect/timeout_ms lets them retry."""
    conf = zenoh.Config()
    conf.insert_json5("mode", '"client"')
    conf.insert_json5("connect/endpoints", json.dumps(endpoints))
    # Retry for up to 2 minutes, not forever: a process still connecting when its launcher (and router)
    # died blocks inside zenoh.open, where no signal handler runs, and would be left behind.
    conf.insert_json5("connect/timeout_ms", "120000")
    conf.insert_json5("scouting/multicast/enabled", "false")
    if user:
        conf.insert_json5("transport/auth/usrpwd/user", json.dumps(user))
        conf.insert_json5("transport/auth/usrpwd/password", json.dumps(password))
    return conf


MAX_SESSIONS = 20000
ACCEPT_PENDING = 2000


def router_config(listen: list[str], connect: list[str] | None = None, dictionary_file: str = "",
                  user: str = "", password: str = "") -> zenoh.Config:
    """An in-process router (mode "router"): no external daemon needed."""
    conf = zenoh.Config()
    conf.insert_json5("mode", '"router"')
    conf.insert_json5("listen/endpoints", json.dumps(listen))
    conf.insert_json5("connect/endpoints", json.dumps(connect or []))
    conf.insert_json5("scouting/multicast/enabled", "false")
    # zenoh's defaults (1000 sessions, 100 handshakes pending) cap a swarm below 1000 agents: every agent,
    # the recorder and the coordinator are sessions of this router, and they all connect at once.
    conf.insert_json5("transport/unicast/max_sessions", str(MAX_SESSIONS))
    conf.insert_json5("transport/unicast/accept_pending", str(ACCEPT_PENDING))
    if dictionary_file:
        conf.insert_json5("transport/auth/usrpwd/dictionary_file", json.dumps(dictionary_file))
        if user:
            conf.insert_json5("transport/auth/usrpwd/user", json.dumps(user))
            conf.insert_json5("transport/auth/usrpwd/password", json.dumps(password))
    return conf
