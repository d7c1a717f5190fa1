#!/usr/bin/env python3
"""State messages between hosts in an imitation split over three hosts, counted by the compiled routers:
id-range shares, regions of the start layout and regions of the formation ahead (the default), the same run
each (issue 37 item 2, docs/multi-host.md).

One machine, three routers on loopback (B and C connected to A over tcp/, as tests/test_workers_netns.py's
hosts), each started with `fluidswarm router --count-traffic`: zenoh's own statistics count every message put
on a state key that a router sends to or receives from another router (agent/native/src/traffic.rs). The main
host runs `imitate PHOTO --workers 2 --shares S` on A, a `fluidswarm worker` on B and on C. When the run has
ended each router is stopped and says `router_traffic sent=N received=N links=N`; the sum of `sent` over the
three routers is every state message that crossed a router-to-router link (one through A from B to C crosses
twice). Divided by the steps of the run: state messages between hosts per step. The two kinds alternate.

    python scripts/imitation_traffic.py --agents 180 --rounds 2
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

from fluidswarm.recording.reader import load_run
from swarmhost.router_host import free_port

FS = [sys.executable, "-m", "fluidswarm"]
PHOTO = Path(__file__).resolve().parents[1] / "scenarios" / "inputs" / "digit2_IMG_1140.JPG"
KW = dict(stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _traffic(out: str) -> dict[str, int]:
    for line in out.splitlines():
        if line.startswith("router_traffic "):
            return {k: int(v) for k, v in (w.split("=", 1) for w in line.split()[1:])}
    raise RuntimeError(f"no router_traffic line in {out!r}")


def run_once(agents: int, shares: str, users: Path, out: Path, photo: Path) -> dict:
    eps = [f"tcp/127.0.0.1:{free_port()}" for _ in range(3)]
    auth = ["--auth-file", str(users), "--count-traffic"]
    env = dict(os.environ, FLUIDSWARM_AUTH_FILE=str(users))
    routers: list[subprocess.Popen] = []
    procs: list[subprocess.Popen] = []
    run = f"traffic-{shares}-{os.getpid()}"
    try:
        for k, ep in enumerate(eps):
            routers.append(
                subprocess.Popen(FS + ["router", "--listen", ep, *(["--connect", eps[0]] if k else []), *auth], **KW)
            )
            assert routers[-1].stdout.readline().startswith("router="), f"router {k + 1} did not come up"
        main = subprocess.Popen(
            FS
            + ["imitate", str(photo), "--agents", str(agents), "--out", str(out), "--json"]
            + ["--connect", eps[0], "--run", run, "--workers", "2", "--shares", shares],
            env=env,
            **KW,
        )
        procs.append(main)
        procs += [subprocess.Popen(FS + ["worker", "--connect", ep, "--run", run], env=env, **KW) for ep in eps[1:]]
        outs = [p.communicate(timeout=900) for p in procs]
        for p, (_o, e) in zip(procs, outs, strict=True):
            assert p.returncode == 0, e[-2000:]
        record = json.loads(outs[0][0].strip().splitlines()[-1])
        counts = []
        for r in routers:
            r.send_signal(signal.SIGINT)
            o, _e = r.communicate(timeout=30)
            counts.append(_traffic(o))
        # the steps the swarm ran (an imitation ends once its formation settled, before its planned steps)
        steps = int(load_run(record["mcap"], images=False).timing["steps_seen"])
        sent = sum(c["sent"] for c in counts)
        return {
            "shares": shares,
            "sent": sent,
            "per_router": [c["sent"] for c in counts],
            "steps": steps,
            "per_step": sent / steps,
            "finished": record.get("finished"),
            "iou": (record.get("fidelity") or {}).get("iou"),
        }
    finally:
        for p in procs + routers:
            if p.poll() is None:
                p.kill()
                p.wait()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--agents", type=int, default=180)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--photo", type=Path, default=PHOTO)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        users = Path(tmp) / "users.txt"
        subprocess.run(FS + ["auth-file", "--agents", str(args.agents), "--out", str(users)], check=True, **KW)
        for k in range(args.rounds):
            for shares in ("ids", "start", "formation"):
                r = run_once(args.agents, shares, users, Path(tmp) / f"out-{shares}-{k}", args.photo)
                print(
                    f"{shares}: agents={args.agents} hosts=3 state_messages_between_hosts={r['sent']} "
                    f"(A,B,C sent {r['per_router']}) steps={r['steps']} per_step={r['per_step']:.1f} "
                    f"finished={r['finished']} iou={r['iou']}",
                    flush=True,
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
