"""The launcher's state relay (agent/relay.py) with real Zenoh sessions: a router, the relay on its own session,
a client that puts on an agent's id key and listens on the cell keys, as agents do under per-process rights."""

import time

import numpy as np
import pytest
import zenoh

from agent.protocol import keys
from agent.protocol.session import client_config, router_config
from agent.protocol.wire import decode_state, encode_state, peek_id_position
from agent.relay import StateRelay
from agent.sph.particle import NFIELDS
from agent.router_host import free_port
from tests.swarm_helpers import wait_until

RUN = "r"


def record(agent_id: int, x: float, y: float, step: int = 0) -> bytes:
    state = np.zeros(NFIELDS)
    state[[0, 1, 4]] = x, y, 1000.0  # position and a density (a record needs a positive one)
    return encode_state(agent_id, step, state)


@pytest.mark.swarm
def test_the_relay_puts_each_record_of_its_agents_on_its_cell_and_drops_the_rest():
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = zenoh.open(router_config([endpoint]))
    relay = StateRelay(router, RUN)
    relay.add(3, cell=0.5)
    client = zenoh.open(client_config([endpoint]))
    heard: list[tuple[str, bytes]] = []
    sub = client.declare_subscriber(f"{keys.PREFIX}/{RUN}/state/*/*",
                                    lambda s: heard.append((str(s.key_expr), s.payload.to_bytes())))
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
    finally:
        sub.undeclare()
        client.close()
        relay.close()
        router.close()
    # x = 1.2, y = -0.1 in cells of 0.5: cell (2, -1), as keys.cell_of and the agents' keys.rs compute it
    assert heard == [(keys.cell_key(RUN, 2, -1), good)]
    assert relay.rejected == {"id": 1, "key": 1, "length": 1, "value": 1}


def test_the_relays_peek_rejects_what_decode_state_rejects_for_the_header_and_position():
    good = record(7, 1.0, 2.0, step=4)
    assert peek_id_position(good) == ((7, 1.0, 2.0), None)
    bad = {"length": good[:-3], "version": bytes([9]) + good[1:], "value": record(7, float("inf"), 2.0)}
    for reason, data in bad.items():
        assert peek_id_position(data) == (None, reason)
        assert decode_state(data) == (None, reason)
