"""The state relay of the compiled router with real Zenoh sessions — a launcher's embedded router (asked over its
stdin, swarmhost/router_process.py) and a host's router of a multi-host run (`fluidswarm router`: asked over
Zenoh by the launcher that is its client, swarmhost/host_relay.py) — and a client that puts on an agent's id key and
listens on the cell keys, as agents do under per-process rights."""

import contextlib
import os
import tempfile
import time

import numpy as np
import pytest
import zenoh

from agent.protocol import keys
from agent.protocol.session import client_config, router_config_dict
from agent.protocol.wire import decode_state, encode_state, peek_id_position
from agent.sph.particle import NFIELDS
from swarmhost.host_relay import HostRelay
from swarmhost.router_host import free_port
from swarmhost.router_process import RouterFailed, RouterProcess
from tests.swarm_helpers import wait_until

RUN = "r"


def record(agent_id: int, x: float, y: float, step: int = 0) -> bytes:
    state = np.zeros(NFIELDS)
    state[[0, 1, 4]] = x, y, 1000.0  # position and a density (a record needs a positive one)
    return encode_state(agent_id, step, state)


@contextlib.contextmanager
def host_relay(endpoint: str):
    router = RouterProcess(None, router_config_dict([endpoint]))
    launcher = zenoh.open(client_config([endpoint]))
    try:
        relay = HostRelay(launcher, RUN, endpoint)
        assert relay.key == f"{keys.PREFIX}/{RUN}/relay/{router.zid}"
        yield relay
        relay.close()
    finally:
        launcher.close()
        router.close()
        assert router.proc.returncode == 0  # it closed when its stdin did


@contextlib.contextmanager
def compiled_relay(endpoint: str):
    router = RouterProcess(RUN, router_config_dict([endpoint]))
    try:
        yield router.relay
    finally:
        router.close()
        assert router.proc.returncode == 0  # it closed when its stdin did


@pytest.mark.swarm
@pytest.mark.parametrize("make_relay", [host_relay, compiled_relay], ids=["host", "embedded"])
def test_the_relay_puts_each_record_of_its_agents_on_its_cell_and_drops_the_rest(make_relay):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    heard: list[tuple[str, bytes]] = []
    with make_relay(endpoint) as relay:
        relay.add(3, cell=0.5)
        with pytest.raises(ValueError, match="smoothing length"):
            relay.add(4, cell=0.25)  # agents hear each other on cells of one size
        client = zenoh.open(client_config([endpoint]))
        sub = client.declare_subscriber(
            f"{keys.PREFIX}/{RUN}/state/*/*", lambda s: heard.append((str(s.key_expr), s.payload.to_bytes()))
        )
        try:
            time.sleep(0.3)  # the subscription reaches the router before anything is put (pub/sub is not durable)
            good = record(3, 1.2, -0.1)
            client.put(keys.state_key(RUN, 3), good)
            client.put(keys.state_key(RUN, 3), record(4, 1.2, -0.1))  # another agent's record under 3's key
            client.put(f"{keys.PREFIX}/{RUN}/state/*", record(3, 5.0, 5.0))  # a wildcard key names nobody
            client.put(keys.state_key(RUN, 3), good[:-1])  # not a record
            client.put(keys.state_key(RUN, 3), record(3, float("nan"), 0.0))  # no position to route by
            client.put(keys.state_key(RUN, 5), record(5, 1.2, -0.1))  # not an agent of this launcher's
            assert wait_until(lambda: sum(relay.rejected.values()) == 4, 10), relay.rejected
            time.sleep(0.3)
            rejected = {k: v for k, v in relay.rejected.items() if v}
        finally:
            sub.undeclare()
            client.close()
    # x = 1.2, y = -0.1 in cells of 0.5: cell (2, -1), as keys.cell_of and the agents' keys.rs compute it
    assert heard == [(keys.cell_key(RUN, 2, -1), good)]
    assert rejected == {"id": 1, "key": 1, "length": 1, "value": 1}


@pytest.mark.swarm
def test_the_compiled_router_says_why_it_cannot_start_in_one_line_and_keeps_no_configuration():
    port = free_port()
    with compiled_relay(f"tcp/127.0.0.1:{port}"), pytest.raises(RouterFailed) as failed:  # the port is taken
        RouterProcess(RUN, router_config_dict([f"tcp/127.0.0.1:{port}"]))
    message = str(failed.value)
    assert "fluidswarm router: error: cannot open the router" in message and "\n" not in message
    with pytest.raises(RouterFailed, match="router.json: JSON error.*AclConfig"):
        RouterProcess(RUN, {**router_config_dict([f"tcp/127.0.0.1:{free_port()}"]), "access_control": 5})
    leftovers = [d for d in os.listdir(tempfile.gettempdir()) if d.startswith("fluidswarm-router-")]
    assert leftovers == []  # its configuration (it names the users file, holds the rules) is removed


@pytest.mark.swarm
def test_a_host_router_answers_only_its_own_clients_runs_and_a_plain_router_is_named():
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with host_relay(endpoint) as relay:
        relay.add(1, 0.5)  # its run is known once one of its agents is added
        assert relay._ask("rejected") == "rejected length=0 version=0 value=0 id=0 key=0"
        assert relay._ask("delete 3").startswith("error unknown request")
        other = HostRelay(relay.session, "other-run", endpoint)
        assert other._ask("rejected") == "error run other-run: no agent of it is relayed here"
        # a request on a wildcard key (any run, any router) is answered by no relay
        replies = list(relay.session.get(f"{keys.PREFIX}/*/relay/*", payload="add 2 0.5", timeout=2))
        assert [r.err.payload.to_string() for r in replies if r.err] and not [r for r in replies if r.ok]
    plain_endpoint = f"tcp/127.0.0.1:{free_port()}"
    plain = zenoh.open(_plain_router_config(plain_endpoint))  # a Zenoh router that is not fluidswarm's
    launcher = zenoh.open(client_config([plain_endpoint]))
    try:
        from swarmhost import host_relay as relay_module

        relay_module.REQUEST_TIMEOUT, timeout = 1.0, relay_module.REQUEST_TIMEOUT
        try:
            with pytest.raises(RouterFailed, match="does not relay states.*fluidswarm router"):
                HostRelay(launcher, RUN, plain_endpoint).add(0, 0.5)
        finally:
            relay_module.REQUEST_TIMEOUT = timeout
    finally:
        launcher.close()
        plain.close()


def _plain_router_config(endpoint: str) -> zenoh.Config:
    conf = zenoh.Config()
    conf.insert_json5("mode", '"router"')
    conf.insert_json5("listen/endpoints", f'["{endpoint}"]')
    conf.insert_json5("scouting/multicast/enabled", "false")
    return conf


def test_a_router_that_never_says_ready_is_killed_and_named(tmp_path, monkeypatch):
    from swarmhost import router_process

    hung = tmp_path / "hung-router"  # stands in for a router stuck opening: it never reads its stdin
    hung.write_text("#!/bin/sh\nexec sleep 30\n")
    hung.chmod(0o755)
    monkeypatch.setenv("FLUIDSWARM_ROUTER_BIN", str(hung))
    monkeypatch.setattr(router_process, "START_TIMEOUT", 0.5)
    spawned = []
    real_popen = router_process.subprocess.Popen
    monkeypatch.setattr(
        router_process.subprocess, "Popen", lambda *a, **k: spawned.append(real_popen(*a, **k)) or spawned[-1]
    )
    t = time.monotonic()
    with pytest.raises(RouterFailed, match="did not say ready within 0.5 s"):
        RouterProcess(RUN, router_config_dict([f"tcp/127.0.0.1:{free_port()}"]))
    assert time.monotonic() - t < 5
    assert spawned and spawned[0].poll() is not None  # killed, not left behind


def test_the_relays_peek_rejects_what_decode_state_rejects_for_the_header_and_position():
    good = record(7, 1.0, 2.0, step=4)
    assert peek_id_position(good) == ((7, 1.0, 2.0), None)
    bad = {"length": good[:-3], "version": bytes([9]) + good[1:], "value": record(7, float("inf"), 2.0)}
    for reason, data in bad.items():
        assert peek_id_position(data) == (None, reason)
        assert decode_state(data) == (None, reason)


def test_a_tls_link_is_refused_in_one_line_naming_the_upstream_bug_and_quic_needs_certificates(capsys):
    from fluidswarm.cli import main

    for argv, said in (
        (["router", "--listen", "tls/127.0.0.1:7448"], "eclipse-zenoh/zenoh#2557"),
        (["router", "--connect", "tls/10.0.0.1:7448"], "use quic/HOST:PORT"),
        (["router", "--listen", "quic/127.0.0.1:7448"], "quic/ endpoints need --tls-ca"),
        (["router", "--listen", "udp/127.0.0.1:7448"], "expected tcp/HOST:PORT or quic/HOST:PORT"),
    ):
        assert main(argv) == 1
        err = capsys.readouterr().err
        assert said in err and err.count("\n") == 1 and "Traceback" not in err


def test_only_a_router_that_connects_to_others_waits_for_their_routes():
    """zenoh's router sleeps scouting/delay (500 ms) at the end of its open, for the routers it connects to:
    one connecting to none is configured not to (agent/protocol/session.py router_settings)."""
    alone = router_config_dict(["tcp/127.0.0.1:7447"])
    joined = router_config_dict(["tcp/127.0.0.1:7447"], connect=["tcp/10.0.0.2:7447"])
    assert alone["scouting"]["delay"] == 0
    assert "delay" not in joined["scouting"]
