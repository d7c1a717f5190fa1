"""One run split between two launchers on one router (two "hosts" without network namespaces): the launcher
that finishes first must leave the other's agents alone (docs/multi-host.md). Its ctl/stop reaches every agent
of the run, so sending it at a normal end stopped the other host's last steps (CI, test_multihost: "agents did
not finish", each stopped one step before its end)."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import pytest

from swarmhost.router_host import free_port
from swarmhost.supervisor import stop_process

pytestmark = pytest.mark.swarm  # starts a router and the CLI (tests/conftest.py)

FS = [sys.executable, "-m", "fluidswarm"]


def test_the_launcher_that_finishes_first_stops_none_of_the_other_hosts_agents():
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = subprocess.Popen(FS + ["router", "--listen", endpoint], stdout=subprocess.PIPE, text=True)
    launchers: list[subprocess.Popen] = []
    try:
        assert router.stdout.readline().startswith("router="), "the router did not come up"
        common = ["launch", "-n", "24", "--run", "split", "--connect", endpoint, "--timeout", "1.0", "--json"]
        kw = dict(stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        # Host A ends at step 40 while host B's agents go on to step 160 (its neighbours of A dropped after the
        # 1 s timeout): A's launcher closes with B's agents mid-run.
        pa = subprocess.Popen(FS + common + ["--ids", "0-11", "--steps", "40"], **kw)
        pb = subprocess.Popen(FS + common + ["--ids", "12-23", "--steps", "160"], **kw)
        launchers += [pa, pb]
        out_a, err_a = pa.communicate(timeout=240)
        t_a = time.monotonic()
        out_b, err_b = pb.communicate(timeout=240)
        assert pa.returncode == 0 and pb.returncode == 0, err_a + err_b
        ra, rb = (json.loads(o.strip().splitlines()[-1]) for o in (out_a, out_b))
        print(ra["finished"], rb["finished"], f"B ended {time.monotonic() - t_a:.1f} s after A")
        assert ra["finished"] == 12
        assert rb["finished"] == 12, err_b
    finally:
        for p in launchers:  # still running after a failed assertion: SIGTERM unwinds like Ctrl-C (its agents too)
            stop_process(p, 15.0)
        router.terminate()
        router.wait(10)
