"""Bytes on the router-to-router links of a split run, region shares against id ranges (docs/multi-host.md).

One machine, M routers on loopback in a star (routers 2..M connected to router 1 over tcp/), one users file
(`fluidswarm auth-file`), M `fluidswarm verify` launchers, launcher k a client of router k, each given either
`--share k/M` or the k-th id range of the same block. Once every launcher has ended, the kernel's counters of
each spoke router's TCP connection to the hub (`ss -tinp`: bytes_acked sent, bytes_received) are the link's
traffic both ways: every zenoh message between two hosts (states, ctl, liveliness, declarations), counted
outside zenoh. Two step counts give the traffic per step (the difference over the extra steps: start-up and
declarations cancel).

    python scripts/cross_host_traffic.py --agents 64 --hosts 4 --steps 60 260
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from swarmhost.router_host import free_port

FS = [sys.executable, "-m", "fluidswarm"]


def _children(pid: int) -> list[int]:
    out = subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout.split()
    return [int(p) for p in out]


def _link_bytes(router_pids: list[int], hub_port: int) -> int:
    """Bytes both ways on the connections these router processes hold to the hub's port."""
    text = subprocess.run(
        ["ss", "-tinpH", "state", "established", "dst", f"127.0.0.1:{hub_port}"], capture_output=True, text=True
    ).stdout
    total = 0
    # ss prints a socket's line, then its tcp_info on the next (indented) line
    blocks = re.split(r"\n(?=\S)", text.strip())
    for block in blocks:
        if not any(f"pid={p}," in block for p in router_pids):
            continue
        sent = re.search(r"bytes_acked:(\d+)", block)
        got = re.search(r"bytes_received:(\d+)", block)
        total += int(sent.group(1) if sent else 0) + int(got.group(1) if got else 0)
    return total


def run_once(agents: int, hosts: int, steps: int, how: str, users: Path) -> dict:
    ports = [free_port() for _ in range(hosts)]
    eps = [f"tcp/127.0.0.1:{p}" for p in ports]
    auth = ["--auth-file", str(users)]
    kw = dict(stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    routers: list[subprocess.Popen] = []
    launchers: list[subprocess.Popen] = []
    try:
        for k, ep in enumerate(eps):
            extra = ["--connect", eps[0]] if k else []
            routers.append(subprocess.Popen(FS + ["router", "--listen", ep, *extra, *auth], **kw))
            line = routers[-1].stdout.readline()
            assert line.startswith("router="), f"router {k + 1} did not come up: {line!r}"
        ranges = np.array_split(np.arange(agents), hosts)
        run = f"traffic-{how}-{os.getpid()}-{steps}"
        for k in range(hosts):
            part = ["--share", f"{k + 1}/{hosts}"] if how == "regions" else ["--ids", f"{ranges[k][0]}-{ranges[k][-1]}"]
            cmd = ["verify", "--agents", str(agents), "--steps", str(steps), "--run", run, "--json", *part]
            launchers.append(subprocess.Popen(FS + cmd + ["--connect", eps[k], *auth], **kw))
        records = []
        for p in launchers:
            out, err = p.communicate(timeout=600)
            assert p.returncode == 0, err[-2000:]
            records.append(json.loads(out.strip().splitlines()[-1]))
        spokes = [c for r in routers[1:] for c in _children(r.pid)]
        return {
            "bytes": _link_bytes(spokes, ports[0]),
            "finished": sum(r["finished"] for r in records),
            "error": max(r["figures"]["max_position_error"] for r in records),
        }
    finally:
        for p in launchers:
            if p.poll() is None:
                p.kill()
                p.wait()
        for r in reversed(routers):
            r.terminate()
            r.wait(15)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--agents", type=int, default=64)
    ap.add_argument("--hosts", type=int, default=4)
    ap.add_argument("--steps", type=int, nargs=2, default=[60, 260])
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        users = Path(tmp) / "users.txt"
        subprocess.run(FS + ["auth-file", "--agents", str(args.agents), "--out", str(users)], check=True)
        lo, hi = args.steps
        for how in ("ids", "regions"):
            a = run_once(args.agents, args.hosts, lo, how, users)
            b = run_once(args.agents, args.hosts, hi, how, users)
            per_step = (b["bytes"] - a["bytes"]) / (hi - lo)
            error = max(a["error"], b["error"])
            print(
                f"{how}: agents={args.agents} hosts={args.hosts} link_bytes_per_step={per_step:.0f} "
                f"(= {per_step / 104:.1f} state records of 104 bytes) link_bytes={a['bytes']}@{lo} "
                f"{b['bytes']}@{hi} finished={a['finished']},{b['finished']} max_error={error:.1e}",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
