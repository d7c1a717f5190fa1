"""What `--ros2` costs the swarm: recorded launches with and without it, alternating (docs/ros2.md "Cost").

    .venv/bin/python scripts/ros2_side_by_side.py N STEPS ROUNDS [OUT.json]

One plain Zenoh router stands in for rmw_zenohd (tests/ros2_peer.py), and one subscriber process takes every
topic the bridge publishes (as RViz or `ros2 bag record` would: a ROS 2 side that listens). Each round runs
`fluidswarm launch -n N --steps STEPS --record` once without and once with `--ros2` (alternating which goes
first), and keeps steps/s as the launch reports it. Run it under the CPU lock.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

LISTENER = """
import sys, time, zenoh
c = zenoh.Config()
c.insert_json5("mode", '"client"')
c.insert_json5("connect/endpoints", '["' + sys.argv[1] + '"]')
c.insert_json5("scouting/multicast/enabled", "false")
s = zenoh.open(c)
n = [0]
sub = s.declare_subscriber("0/**", lambda sample: n.__setitem__(0, n[0] + 1))
print("up", flush=True)
sys.stdin.read()
print(n[0], flush=True)
import os
os._exit(0)  # a zenoh-python session with a subscriber can hang the interpreter's exit
"""


def cpu_seconds(pid: int) -> float:
    """User + system CPU of a live process so far (/proc/PID/stat)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def launch(n: int, steps: int, folder: str, ros2: str) -> dict:
    cmd = [sys.executable, "-m", "fluidswarm", "launch", "-n", str(n), "--steps", str(steps), "--json"]
    cmd += ["--record", str(Path(folder) / f"run-{'ros2' if ros2 else 'plain'}.mcap")]
    if ros2:
        cmd += ["--ros2", "--ros2-router", ros2]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=900, cwd=REPO)
    if done.returncode != 0:
        raise SystemExit(f"launch failed: {done.stderr[-500:]}")
    return json.loads(done.stdout)


def main() -> int:
    from swarmhost.router_host import free_port
    from tests.ros2_peer import start_router, stop_router

    n, steps, rounds = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
    out = sys.argv[4] if len(sys.argv) > 4 else ""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = start_router(endpoint)
    listener = subprocess.Popen(
        [sys.executable, "-c", LISTENER, endpoint], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    assert listener.stdout is not None and listener.stdout.readline().strip() == "up"
    rows = []
    try:
        with tempfile.TemporaryDirectory() as folder:
            for r in range(rounds):
                order = ("", endpoint) if r % 2 == 0 else (endpoint, "")
                for ros2 in order:
                    side = cpu_seconds(router.pid) + cpu_seconds(listener.pid)
                    rec = launch(n, steps, folder, ros2)
                    side = cpu_seconds(router.pid) + cpu_seconds(listener.pid) - side
                    row = {
                        "round": r,
                        "ros2": bool(ros2),
                        "steps_per_second": rec["steps_per_second"],
                        # the stand-in ROS 2 side's CPU during the run (router + listener): on this machine too
                        "ros2_side_cpu_s": round(side, 2),
                        "wall_s": rec.get("wall_seconds"),
                    }
                    rows.append(row)
                    print(json.dumps(row), flush=True)
    finally:
        listener.stdin.close()  # type: ignore[union-attr]
        samples = listener.stdout.readline().strip()
        try:
            listener.wait(10)
        except subprocess.TimeoutExpired:
            listener.kill()
        stop_router(router)
    plain = [x["steps_per_second"] for x in rows if not x["ros2"]]
    ros2 = [x["steps_per_second"] for x in rows if x["ros2"]]
    ratios = [w / p for w, p in zip(ros2, plain, strict=True)]
    summary = {
        "n": n,
        "steps": steps,
        "rounds": rows,
        "plain_mean": statistics.mean(plain),
        "ros2_mean": statistics.mean(ros2),
        "ratio_mean": statistics.mean(ratios),
        "ratios": ratios,
        "samples_received": int(samples or 0),
        "ros_domain": os.environ.get("ROS_DOMAIN_ID", "0"),
    }
    print(json.dumps({k: v for k, v in summary.items() if k != "rounds"}))
    if out:
        Path(out).write_text(json.dumps(summary, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
