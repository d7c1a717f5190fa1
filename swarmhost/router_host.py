"""The run's Zenoh session: an embedded router on this host, or a client of a router elsewhere.

With an embedded router the local agents link to it over TCP loopback or a unix socket (AGENT_LINK), and
the router gets the run's fresh credentials and per-process rights (agent/protocol/access.py,
docs/security.md); as a client the launcher uses the credentials it was given. The embedded router is the
compiled one (swarmhost/router_process.py) at every access level, and the launcher is its client; under
per-process rights (level acl, the default) its relay puts each state on its cell. A launcher that is a
client of another host's router (`fluidswarm router`) asks that router's relay (swarmhost/host_relay.py).
"""

from __future__ import annotations

import os
import shutil
import socket
import tempfile
from dataclasses import astuple

import zenoh

from agent.protocol.access import AGENT_CAPACITY, LaunchAccess
from agent.protocol.errors import SwarmFailed
from agent.protocol.session import LAUNCHER_CONNECT_TIMEOUT_MS, client_config, router_config_dict
from swarmhost.host_relay import HostRelay
from swarmhost.router_process import CompiledRelay, RouterProcess

# How local agents reach the embedded router: "unix" (a unix socket) or "tcp" (loopback).
AGENT_LINK = os.environ.get("FLUIDSWARM_AGENT_LINK", "tcp")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class RouterHost:
    """`endpoint`: where other processes and hosts connect; `agent_endpoint`: where this host's agents
    connect; `access`: the credentials handed to each process; `session`: the launcher's own session;
    `relay`: the state relay under per-process rights (the embedded router's, or the host router's when a
    client), None without them."""

    def __init__(
        self,
        run: str,
        connect: str | None = None,
        listen: str | None = None,
        user: str = "",
        password: str = "",
        auth_file: str = "",
        capacity: int = AGENT_CAPACITY,
    ):
        """`capacity`: an embedded router provisions agent ids 0..capacity-1 (LaunchAccess.embedded)."""
        self._socket_dir = None
        self.process: RouterProcess | None = None  # the compiled embedded router (per-process rights)
        if connect:
            self.endpoint = self.agent_endpoint = connect
            self.access = LaunchAccess.client(user, password, auth_file)  # docs/security.md
            user, password = (self.access.own.user, self.access.own.password) if self.access.own else ("", "")
            conf = client_config([connect], user, password, timeout_ms=LAUNCHER_CONNECT_TIMEOUT_MS)
        else:
            self.endpoint = listen or f"tcp/127.0.0.1:{free_port()}"
            listeners = [self.endpoint]
            self.agent_endpoint = self.endpoint
            if AGENT_LINK == "unix":
                # The local agents reach the embedded router over a unix socket (measured against TCP
                # loopback in docs/benchmarks/native.md); other processes and hosts use the TCP endpoint.
                self._socket_dir = tempfile.mkdtemp(prefix="fluidswarm-")
                self.agent_endpoint = f"unixsock-stream/{self._socket_dir}/router.sock"
                listeners.append(self.agent_endpoint)
            self.access = LaunchAccess.embedded(capacity)  # fresh credentials and per-process rights (docs/security.md)
        try:
            if not connect:
                # The compiled router, the launcher its client: under per-process rights every state passes
                # its relay (swarmhost/router_process.py).
                self.process = RouterProcess(
                    run, router_config_dict(listeners, dictionary_file=self.access.users_file, acl=self.access.acl)
                )
                conf = client_config([self.endpoint], *(astuple(self.access.own) if self.access.own else ()))
            self.session = zenoh.open(conf)
        except zenoh.ZError as exc:
            self.close_process()
            if not connect:
                raise
            # zenoh retries for connect/timeout_ms, then tells an absent router and refused credentials alike
            who = f"'{self.access.own.user}'" if self.access.own else "no credentials"
            raise SwarmFailed(
                f"cannot open a session on the router at {connect}: none answered, or it refused {who} "
                f"({str(exc).split(' at ')[0]})"
            ) from None
        except BaseException:
            self.close_process()
            raise
        finally:
            self.access.opened()  # the router has read the users file (or failed to)
        # Under per-process rights agents put their states on their id keys and the relay puts them on the
        # cells: the embedded router's, else (a client of another host's router) that router's.
        self.relay: CompiledRelay | HostRelay | None = None
        if self.access.state_key_ids:
            try:
                host = self.process
                self.relay = host.relay if host is not None else HostRelay(self.session, run, connect or "")
            except BaseException:
                self.close()
                raise

    def close_process(self) -> None:
        if self.process is not None:
            self.process.close()

    def close(self) -> None:
        try:
            self.session.close()
        except zenoh.ZError:  # the router's close can time out with many links still open; nothing is lost
            pass
        self.close_process()
        if self._socket_dir:
            shutil.rmtree(self._socket_dir, ignore_errors=True)
