"""`--live`: a running swarm streamed to a real Foxglove WebSocket client while the MCAP is recorded."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time

from websockets.exceptions import ConnectionClosed

from agent.launcher import free_port
from fluidswarm.recording.reader import check, load_run
from tests.foxglove_client import FoxgloveClient

FLUIDSWARM = [sys.executable, "-m", "fluidswarm"]


def test_live_client_sees_the_steps_as_they_happen_and_the_mcap_is_complete(tmp_path):
    port, steps = free_port(), 400
    mcap = tmp_path / "live.mcap"
    run = subprocess.Popen(FLUIDSWARM + ["launch", "-n", "16", "--steps", str(steps), "--record", str(mcap),
                                         "--live", f"127.0.0.1:{port}"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    received: dict[int, float] = {}  # step -> when it arrived
    try:
        client = FoxgloveClient(f"ws://127.0.0.1:{port}")
        state = client.channel("state")
        assert client.ws.subprotocol in ("foxglove.sdk.v1", "foxglove.websocket.v1")
        assert client.server_info is not None and client.server_info["name"].startswith("fluidswarm")
        assert state["schemaName"] == "foxglove.PointCloud" and state["encoding"] == "json"
        topics = {t.rsplit("/", 1)[-1] for t in client.channels}
        assert {"state", "scene", "command", "image", "event"} <= topics
        client.subscribe(state["id"], subscription_id=7)
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
            assert sub == 7
            msg = json.loads(data)
            received[msg["fluidswarm"]["step"]] = time.monotonic()
            assert msg["fluidswarm"]["count"] == 16 and log_time >= 0
        client.close()
        out, err = run.communicate(timeout=60)
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    assert run.returncode == 0, err
    assert f"ws://127.0.0.1:{port}" in err
    complete, recorded, missing = check(mcap)
    assert complete and missing == 0 and recorded >= steps
    share = len(received) / recorded
    print(f"live: {len(received)} of {recorded} steps received ({share:.0%})")
    assert share >= 0.9
    # as they happened, not in a burst at the end: the arrivals span most of the run's stepping time
    rate = float(next(line for line in out.splitlines() if line.startswith("steps_per_second=")).split("=")[1])
    arrivals = sorted(received.values())
    assert arrivals[-1] - arrivals[0] >= 0.5 * steps / rate
    # the same contents as the MCAP: the last received step holds the recorded positions
    last = max(received)
    frame = next(f for f in load_run(mcap, images=False).frames if f.step == last)
    assert len(frame.ids) == 16


def test_live_port_in_use_is_one_line_and_exit_1(tmp_path):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        res = subprocess.run(FLUIDSWARM + ["launch", "-n", "4", "--steps", "10", "--record", str(tmp_path / "x.mcap"),
                                           "--live", f"127.0.0.1:{port}"], capture_output=True, text=True, timeout=60)
    assert res.returncode == 1
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and f"--live 127.0.0.1:{port}: port in use" in lines[0], res.stderr
