"""The bare lockstep exchange of docs/benchmarks/realtime.md ("The floor"): N compiled processes
(agent/native/examples/bare_exchange.rs) on a lattice, one per cell of side h = 1, each putting one 104-byte
state record per round and waiting for those of every agent in the cells within RADIUS, through the
production router (fluidswarm-router) with the launcher's configuration at the access level of
$FLUIDSWARM_ACCESS (default acl: users file, access-control rules, the relay re-putting each state on its cell).
No physics, no protocol, no launcher pacing, no recorder: what the traffic alone costs.

    .venv/bin/python scripts/bare_exchange_launch.py N ROUNDS RADIUS [--agent-set 'path=json5;...'] [--router-set JSON]

--agent-set: extra Zenoh settings of every agent (e.g. 'transport/link/tx/queue/batching/enabled=false');
--router-set: extra router settings as a JSON object of path -> value (e.g.
'{"transport/unicast/lowlatency": true}'); --router-runtime: the router's ZENOH_RUNTIME. Prints one line:
rounds/s, CPU and context switches per agent-step of the agents and of the router (from /proc), records
received per agent-step. The binary: $BARE_EXCHANGE_BIN, else the source tree's target/release/examples.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import threading
import time
import uuid
from dataclasses import astuple
from pathlib import Path

import zenoh

from agent.protocol import keys
from agent.protocol.access import LaunchAccess
from agent.protocol.session import client_config, router_config_dict
from swarmhost.router_host import free_port
from swarmhost.router_process import RouterProcess

ROOT = Path(__file__).resolve().parent.parent


def proc_cpu(pid: int) -> float:
    """user + system CPU seconds of a live process (/proc/PID/stat fields 14 and 15)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def proc_switches(pid: int) -> int:
    """Context switches (voluntary + involuntary) of every thread of a live process (/proc/PID/task/*/status)."""
    total = 0
    for task in os.listdir(f"/proc/{pid}/task"):
        try:
            with open(f"/proc/{pid}/task/{task}/status") as f:
                total += sum(int(line.split()[1]) for line in f if "ctxt_switches:" in line)
        except OSError:
            pass
    return total


def nest(settings: dict, path: str, value: object) -> None:
    *parents, leaf = path.split("/")
    for name in parents:
        settings = settings.setdefault(name, {})
    settings[leaf] = value


def run(
    n: int, rounds: int, radius: float, agent_set: str = "", router_set: dict | None = None, router_runtime: str = ""
) -> dict:
    binary = os.environ.get("BARE_EXCHANGE_BIN") or str(
        Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "agent/native/target")) / "release/examples/bare_exchange"
    )
    name = f"bare-{uuid.uuid4().hex[:8]}"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    access = LaunchAccess.embedded()
    settings = router_config_dict([endpoint], dictionary_file=access.users_file, acl=access.acl)
    for path, value in (router_set or {}).items():
        nest(settings, path, value)
    saved = os.environ.get("ZENOH_RUNTIME")
    if router_runtime:
        os.environ["ZENOH_RUNTIME"] = router_runtime  # the router's threads (it reads the layout from there)
    try:
        router = RouterProcess(name, settings)
    finally:
        os.environ.pop("ZENOH_RUNTIME", None)
        if saved is not None:
            os.environ["ZENOH_RUNTIME"] = saved
    procs: list[subprocess.Popen] = []
    try:
        own = astuple(access.own) if access.own else ()
        session = zenoh.open(client_config([endpoint], *own))
        access.opened()
        if access.state_key_ids:
            for i in range(n):
                router.relay.add(i, 1.0)
        alive: set[str] = set()
        seen = threading.Event()

        def on_token(sample: zenoh.Sample) -> None:
            alive.add(str(sample.key_expr))
            if len(alive) == n:
                seen.set()

        tokens = session.liveliness().declare_subscriber(keys.alive_expr(name), on_token, history=True)
        idkeys = "1" if access.state_key_ids else "0"
        for i in range(n):
            env = dict(os.environ, **access.env_for_agent(i), BARE_ZENOH_SET=agent_set)
            args = [binary, endpoint, name, str(i), str(n), str(radius), str(rounds), idkeys]
            procs.append(subprocess.Popen(args, env=env, stdout=subprocess.PIPE, text=True))
        if not seen.wait(120):
            raise RuntimeError(f"{len(alive)} of {n} agents came up")
        cpu0, sw0, t0 = proc_cpu(router.proc.pid), proc_switches(router.proc.pid), time.monotonic()
        session.put(keys.ctl_key(name, "start"), b"", congestion_control=zenoh.CongestionControl.BLOCK)
        lines = [p.communicate(timeout=600)[0] for p in procs]
        wall = time.monotonic() - t0
        router_cpu = proc_cpu(router.proc.pid) - cpu0
        router_sw = proc_switches(router.proc.pid) - sw0
        tokens.undeclare()
        session.close()
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()
        router.close()
    figures = [dict(w.split("=") for w in line.split()) for line in lines if line.strip()]
    if len(figures) != n:
        raise RuntimeError(f"{n - len(figures)} of {n} agents did not finish")
    steps = n * rounds
    agents_cpu = sum(float(f["cpu_us"]) for f in figures)
    # the swarm's rate: the slowest agent's rounds over its own wall time (the start put reaches all within ms)
    rate = rounds / max(float(f["wall_s"]) for f in figures)
    return {
        "n": n,
        "rounds": rounds,
        "radius": radius,
        "rounds_per_s": round(rate, 2),
        "wall_s": round(wall, 2),
        "received_per_agent_step": round(sum(int(f["received"]) for f in figures) / steps, 2),
        "agents_cpu_us_per_agent_step": round(agents_cpu / steps, 1),
        "router_cpu_us_per_agent_step": round(router_cpu * 1e6 / steps, 1),
        "all_cpu_us_per_agent_step": round((agents_cpu + router_cpu * 1e6) / steps, 1),
        "agent_switches_per_step": round(sum(int(f["switches"]) for f in figures) / steps, 2),
        "router_switches_per_agent_step": round(router_sw / steps, 2),
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("n", type=int)
    p.add_argument("rounds", type=int)
    p.add_argument("radius", type=float)
    p.add_argument("--agent-set", default="")
    p.add_argument("--router-set", default="{}")
    p.add_argument("--router-runtime", default="", help="the router's ZENOH_RUNTIME layout (default: zenoh's)")
    a = p.parse_args()
    res = run(a.n, a.rounds, a.radius, a.agent_set, json.loads(a.router_set), a.router_runtime)
    print(" ".join(f"{k}={v}" for k, v in res.items()))


if __name__ == "__main__":
    main()
