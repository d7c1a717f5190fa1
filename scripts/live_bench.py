"""Does a live viewer slow the swarm? Steps/s of `fluidswarm launch --record` side by side: without `--live`,
with `--live` and a viewer that subscribes to the particles and never reads (a stuck viewer), and with a
viewer that reads everything. Runs alternate (A, B, C, A, B, C, ...) so a drift of the machine hits all three.

    flock /tmp/fluidswarm-cpu.lock .venv/bin/python scripts/live_bench.py [N] [STEPS] [REPEATS] \\
        > docs/benchmarks/live.md

Needs the `websockets` package (the test extra) for the viewers.
"""

from __future__ import annotations

import json
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from fluidswarm.recording.reader import check
from swarmhost.router_host import free_port

SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]


def viewer(url: str, reads: bool, seen: list, stop: threading.Event) -> None:
    """Connect, subscribe to the particles' channel; then read everything, or never read again."""
    host, port = url.removeprefix("ws://").rsplit(":", 1)
    deadline = time.monotonic() + 30
    while True:
        sock = socket.socket()
        if not reads:
            # A small receive buffer (no autotuning: loopback would grow it to 32 MB, a whole run) and
            # max_queue=1 (the client stops taking bytes off the socket once one frame waits unread): a viewer
            # that never reads really backs up into the server.
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        try:
            sock.connect((host, int(port)))
            ws = connect(
                url,
                sock=sock,
                subprotocols=SUBPROTOCOLS,
                open_timeout=2,
                max_queue=1,
                ping_interval=None,
                close_timeout=1,
            )
            break
        except OSError:
            sock.close()
            if time.monotonic() > deadline:
                return
            time.sleep(0.05)
    with ws:
        state = None
        while state is None:
            op = json.loads(ws.recv(timeout=10))
            if op["op"] == "advertise":
                state = next((c for c in op["channels"] if c["topic"].endswith("/state")), None)
        ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": state["id"]}]}))
        if not reads:
            stop.wait()  # stuck for the whole run; afterwards it reads what reached it (the rest was dropped)
        while True:
            try:
                msg = ws.recv(timeout=0.5 if not stop.is_set() else 1.0)
            except TimeoutError:
                if stop.is_set():
                    return
                continue
            except ConnectionClosed:
                return
            if isinstance(msg, bytes) and msg[0] == 1:
                seen.append(json.loads(msg[13:])["fluidswarm"]["step"])


def one_run(n: int, steps: int, mode: str, tmp: Path) -> dict:
    mcap = tmp / f"{mode}-{time.monotonic_ns()}.mcap"
    cmd = [
        sys.executable,
        "-m",
        "fluidswarm",
        "launch",
        "-n",
        str(n),
        "--steps",
        str(steps),
        "--record",
        str(mcap),
        "--json",
    ]
    stop, seen, thread = threading.Event(), [], None
    if mode != "without":
        port = free_port()
        cmd += ["--live", f"127.0.0.1:{port}"]
        thread = threading.Thread(target=viewer, args=(f"ws://127.0.0.1:{port}", mode == "reading viewer", seen, stop))
        thread.start()
    t0 = time.monotonic()
    try:
        res = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
        wall = time.monotonic() - t0
    finally:
        stop.set()
        if thread is not None:
            thread.join(10)
    if res.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed: {res.stderr.strip()}")
    sps = json.loads(res.stdout)["steps_per_second"]
    complete, recorded, missing = check(mcap)
    mcap.unlink()
    return {
        "steps_per_second": sps,
        "complete": complete and missing == 0,
        "recorded": recorded,
        "received": len(set(seen)),
        "wall": wall,
    }


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 64
    steps = int(sys.argv[2]) if len(sys.argv) > 2 else 400
    repeats = int(sys.argv[3]) if len(sys.argv) > 3 else 3
    modes = ("without", "stuck viewer", "reading viewer")
    runs: dict[str, list[dict]] = {m: [] for m in modes}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeats):
            for m in modes:
                runs[m].append(one_run(n, steps, m, Path(tmp)))
    base = statistics.median(r["steps_per_second"] for r in runs["without"])
    print("# Live view (`--live`) and the swarm's pace\n")
    print(
        f"`fluidswarm launch -n {n} --steps {steps} --record F.mcap`, lockstep, the compiled agent; {repeats} runs of "
        f"each kind, interleaved; measured {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} on this 2-core machine "
        f"with `scripts/live_bench.py {n} {steps} {repeats}`.\n"
    )
    print(
        "| run | steps/s (each run) | median | vs without | MCAP complete | steps received by the viewer (the stuck "
        "one reads after the run) | command wall s (median) |"
    )
    print("|---|---|---|---|---|---|---|")
    for m in modes:
        rs = runs[m]
        med = statistics.median(r["steps_per_second"] for r in rs)
        each = ", ".join(f"{r['steps_per_second']:.1f}" for r in rs)
        complete = "yes" if all(r["complete"] for r in rs) else "NO"
        got = "—" if m == "without" else ", ".join(f"{r['received']}/{r['recorded']}" for r in rs)
        wall = statistics.median(r["wall"] for r in rs)
        print(
            f"| {m if m == 'without' else '--live, ' + m} | {each} | {med:.1f} | {100 * (med / base - 1):+.1f} % "
            f"| {complete} | {got} | {wall:.1f} |"
        )


if __name__ == "__main__":
    main()
