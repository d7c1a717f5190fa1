"""`--live`: a running swarm streamed to a real Foxglove WebSocket client while the MCAP is recorded."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from websockets.exceptions import ConnectionClosed

from fluidswarm.recording.reader import check, load_run
from swarmhost.router_host import free_port
from tests.foxglove_client import FoxgloveClient

FLUIDSWARM = [sys.executable, "-m", "fluidswarm"]
V_SIGN = Path(__file__).resolve().parents[1] / "scenarios" / "inputs" / "digit2_IMG_1140.JPG"


@pytest.mark.swarm
def test_live_client_sees_the_steps_as_they_happen_and_the_mcap_is_complete(tmp_path):
    """An imitation of the V-sign photograph with 16 agents, watched by a client that subscribes to every channel."""
    port = free_port()
    run = subprocess.Popen(
        FLUIDSWARM
        + [
            "imitate",
            str(V_SIGN),
            "--agents",
            "16",
            "--steps",
            "400",
            "--out",
            str(tmp_path),
            "--live",
            f"127.0.0.1:{port}",
            "--json",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    received: dict[int, float] = {}  # step -> when it arrived
    other: dict[str, list[dict]] = {}  # leaf -> messages
    try:
        client = FoxgloveClient(f"ws://127.0.0.1:{port}")
        state = client.channel("state")
        assert client.ws.subprotocol in ("foxglove.sdk.v1", "foxglove.websocket.v1")
        assert client.server_info is not None and client.server_info["name"].startswith("fluidswarm")
        assert state["schemaName"] == "foxglove.PointCloud" and state["encoding"] == "json"
        leaves = {t.rsplit("/", 1)[-1]: ch for t, ch in client.channels.items()}
        assert {"state", "scene", "command", "image", "event"} <= set(leaves)
        assert leaves["image"]["schemaName"] == "foxglove.CompressedImage"
        client.subscribe(state["id"], subscription_id=0)
        subscribed = {0: "state"}
        for k, leaf in enumerate(("scene", "image", "command"), start=1):
            client.subscribe(leaves[leaf]["id"], subscription_id=k)
            subscribed[k] = leaf
        while True:
            try:
                got = client.message(timeout=0.5)
            except TimeoutError:
                if run.poll() is not None:
                    break  # the run has ended
                continue
            except ConnectionClosed:  # the recorder stopped its server at the end of the run
                break
            if got is None:
                continue
            sub, log_time, data = got
            msg = json.loads(data)
            if subscribed[sub] == "state":
                received[msg["fluidswarm"]["step"]] = time.monotonic()
                assert msg["fluidswarm"]["count"] == 16 and log_time >= 0, (msg["fluidswarm"], sorted(received)[-3:])
            else:
                other.setdefault(subscribed[sub], []).append(msg)
        client.close()
        out, err = run.communicate(timeout=60)
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    assert run.returncode == 0, err
    assert f"ws://127.0.0.1:{port}" in err
    record = json.loads(out)  # --json: the run's record, the whole of stdout
    mcap = Path(record["mcap"])
    complete, recorded, missing = check(mcap)
    assert complete and missing == 0 and recorded >= 100
    share = len(received) / recorded
    print(f"live: {len(received)} of {recorded} steps received ({share:.0%})")
    assert share >= 0.9
    # as they happened, not in a burst at the end: the arrivals span most of the run's stepping time
    rate = record["steps_per_second"]
    arrivals = sorted(received.values())
    assert arrivals[-1] - arrivals[0] >= 0.5 * recorded / rate
    # the other channels, as in the MCAP: the photograph, the target's outline (both written before the
    # client subscribed, sent again to it), the gesture command
    assert other["image"][0]["format"] == "jpeg" and other["image"][0]["data"]
    assert any(e["id"] == "target" for m in other["scene"] for e in m["entities"])
    recorded_command = load_run(mcap, images=False).commands[0][1]
    assert other["command"][0] == recorded_command


@pytest.mark.swarm
def test_live_port_in_use_is_one_line_and_exit_1(tmp_path):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        res = subprocess.run(
            FLUIDSWARM
            + [
                "launch",
                "-n",
                "4",
                "--steps",
                "10",
                "--record",
                str(tmp_path / "x.mcap"),
                "--live",
                f"127.0.0.1:{port}",
            ],
            capture_output=True,
            text=True,
            timeout=60,
        )
    assert res.returncode == 1
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and f"--live 127.0.0.1:{port}: port in use" in lines[0], res.stderr


def test_a_viewer_connecting_mid_run_gets_the_picture_and_the_target():
    """Written once at the start, kept by the live server and sent again to whoever subscribes later."""
    from fluidswarm.recording import schemas as sc
    from fluidswarm.recording.live import LiveAddress, LiveServer

    port = free_port()
    live = LiveServer(LiveAddress("127.0.0.1", port), "latched")
    try:
        live.publish(sc.IMAGE, b'{"format":"jpeg"}', 0, latch="image/camera")
        live.publish(sc.EVENTS, b'{"message":"not kept"}', 10)
        client = FoxgloveClient(f"ws://127.0.0.1:{port}")
        client.subscribe(client.channel("image")["id"], 3)
        client.subscribe(client.channel("event")["id"], 4)
        assert client.message(timeout=5) == (3, 0, b'{"format":"jpeg"}')
        later = []  # the picture may come again (each subscription resends what is kept); the event never
        with pytest.raises(TimeoutError):
            while True:
                later.append(client.message(timeout=0.5))
        assert all(m == (3, 0, b'{"format":"jpeg"}') for m in later)
        client.close()
    finally:
        assert live.close()
