"""One lockstep swarm of N native agents (`run_swarm(spread_block(N), STEPS)`), its figures on one line.

Used for the side-by-side Zenoh settings in docs/benchmarks/native.md, e.g.
    .venv/bin/python scripts/probe_swarm.py 100 300
Knobs (environment): FLUIDSWARM_AGENT_LINK=unix|tcp, FLUIDSWARM_ACCESS=none|auth|acl (at acl the compiled
router's CPU is printed too). The agent's own knobs (express, congestion control, runtime layout) are gone since
issue 35: their measured defaults are fixed.
"""

import os
import sys
import time

import numpy as np

from agent.sph.setups import spread_block
from swarmhost.launcher import Launcher, run_swarm


def cpu_seconds(pid: int) -> float:
    """user + system CPU of a running process (/proc/<pid>/stat fields 14 and 15)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main() -> None:
    n, steps = int(sys.argv[1]), int(sys.argv[2])
    setup = spread_block(n)
    t0 = time.process_time()
    with Launcher() as la:
        res = run_swarm(setup, steps, launcher=la)
        router = la.router.process
        router_cpu = f" router_cpu_s={cpu_seconds(router.proc.pid):.1f}" if router is not None else ""
    launcher_cpu = time.process_time() - t0
    f = list(res.finals.values())
    cpu = np.mean([(r.cpu_seconds - (r.cpu_seconds_at_start or 0.0)) / max(r.steps, 1) for r in f]) * 1e6
    print(
        f"n={n} done={sum(r.done for r in f)} steps_per_second={res.steps_per_second():.2f} "
        f"agent_cpu_us_per_step={cpu:.0f} rss_mb={np.mean([r.rss_mb for r in f]):.1f} "
        f"launcher_cpu_s={launcher_cpu:.1f} startup_s={res.startup_seconds:.2f} msgs={res.msgs_per_agent_step():.1f}"
        f"{router_cpu}"
    )


if __name__ == "__main__":
    main()
