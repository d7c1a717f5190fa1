"""One run split between two launchers on one router (two "hosts" without network namespaces): the launcher
that finishes first must leave the other's agents alone (docs/multi-host.md). Its ctl/stop reaches every agent
of the run, so sending it at a normal end stopped the other host's last steps (CI, test_multihost: "agents did
not finish", each stopped one step before its end)."""

from __future__ import annotations

import json
import os
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


def test_region_shares_over_two_routers_joined_on_loopback_with_a_users_file_of_auth_file_stay_exact(tmp_path):
    """The multi-host set-up of docs/multi-host.md on one machine: `fluidswarm auth-file` makes the users file,
    two routers hold it (the second connected to the first), each `verify --share K/2` is a client of its own
    router: every state between the two regions crosses the router-to-router link, and the result is the
    single-host one. 36 agents are a 6 x 6 block, cut into its left and right halves (an id range would be its
    lower and upper rows)."""
    from agent.sph.regions import regions
    from agent.sph.setups import spread_block

    users = tmp_path / "users.txt"
    made = subprocess.run(FS + ["auth-file", "--agents", "36", "--out", str(users)], capture_output=True, text=True)
    assert made.returncode == 0, made.stderr
    assert oct(users.stat().st_mode & 0o777) == "0o600"
    halves = [sorted(r.tolist()) for r in regions(spread_block(36).states[:, :2], 2)]
    assert halves[0] == [k for k in range(36) if k % 6 < 3]  # the left half: not an id range
    p1, p2 = free_port(), free_port()
    a, b = f"tcp/127.0.0.1:{p1}", f"tcp/127.0.0.1:{p2}"
    auth = ["--auth-file", str(users)]
    kw = dict(stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    routers = [subprocess.Popen(FS + ["router", "--listen", a] + auth, **kw)]
    launchers: list[subprocess.Popen] = []
    try:
        assert routers[0].stdout.readline().startswith("router="), "router A did not come up"
        routers.append(subprocess.Popen(FS + ["router", "--listen", b, "--connect", a] + auth, **kw))
        assert routers[1].stdout.readline().startswith("router="), "router B did not come up"
        # (another file's launcher, the right name and another password, is locked out: the next test)
        common = ["verify", "--agents", "36", "--steps", "60", "--run", "regions", "--json"]
        pa = subprocess.Popen(FS + common + ["--share", "1/2", "--connect", a] + auth, **kw)
        env = dict(os.environ, FLUIDSWARM_AUTH_FILE=str(users))  # host B's launcher: the file from the environment
        pb = subprocess.Popen(FS + common + ["--share", "2/2", "--connect", b], env=env, **kw)
        launchers += [pa, pb]
        out_a, err_a = pa.communicate(timeout=240)
        out_b, err_b = pb.communicate(timeout=240)
        assert pa.returncode == 0 and pb.returncode == 0, err_a + err_b
        ra, rb = (json.loads(o.strip().splitlines()[-1]) for o in (out_a, out_b))
        print(ra["figures"], rb["figures"])
        assert ra["finished"] == 18 and rb["finished"] == 18
        assert ra["figures"]["max_position_error"] <= 1e-9 and rb["figures"]["max_position_error"] <= 1e-9
    finally:
        for p in launchers:
            stop_process(p, 15.0)
        for r in reversed(routers):
            r.terminate()
            r.wait(10)


def test_a_launcher_whose_users_file_the_router_does_not_hold_fails_in_one_line(tmp_path):
    """Credentials from another users file: zenoh retries for the launcher's 8 s (LAUNCHER_CONNECT_TIMEOUT_MS),
    then the launcher says so in one line naming the router and the user, exit 1, no agent started."""
    users, other = tmp_path / "users.txt", tmp_path / "other.txt"
    for path in (users, other):
        assert (
            subprocess.run(FS + ["auth-file", "--agents", "4", "--out", str(path)], capture_output=True).returncode == 0
        )
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = subprocess.Popen(
        FS + ["router", "--listen", endpoint, "--auth-file", str(users)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert router.stdout.readline().startswith("router="), "the router did not come up"
        cmd = ["launch", "-n", "4", "--share", "1/2", "--run", "stranger", "--connect", endpoint]
        t0 = time.monotonic()
        done = subprocess.run(FS + cmd + ["--auth-file", str(other)], capture_output=True, text=True, timeout=120)
        took = time.monotonic() - t0
        assert done.returncode == 1, done.stderr
        assert done.stderr.count("\n") == 1, done.stderr
        assert f"cannot open a session on the router at {endpoint}: none answered, or it refused 'launcher'" in (
            done.stderr
        )
        assert "run=" not in done.stdout  # nothing started
        assert took < 30, f"{took:.0f} s to say so"
    finally:
        router.terminate()
        router.wait(10)
