"""The compiled router counts the state messages that cross to other routers (`fluidswarm router
--count-traffic`, agent/native/src/traffic.rs: zenoh's own per-key statistics): two routers on loopback, a real
Zenoh client on each, states put on one host and heard on the other; each router says what it sent and received
over its router link when it stops (issue 37 item 2, docs/multi-host.md)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest
import zenoh

from agent.protocol import keys
from swarmhost.router_host import free_port
from tests.swarm_helpers import wait_until

pytestmark = pytest.mark.swarm  # starts routers and Zenoh sessions (tests/conftest.py)

FS = [sys.executable, "-m", "fluidswarm"]
KW = dict(stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _client(endpoint: str) -> zenoh.Session:
    conf = zenoh.Config()
    conf.insert_json5("mode", '"client"')
    conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
    return zenoh.open(conf)


def _stop(router: subprocess.Popen) -> tuple[str, str]:
    router.send_signal(signal.SIGINT)
    return router.communicate(timeout=30)


def _traffic(out: str) -> dict[str, int]:
    lines = [line for line in out.splitlines() if line.startswith("router_traffic ")]
    assert len(lines) == 1, out
    return {k: int(v) for k, v in (w.split("=", 1) for w in lines[0].split()[1:])}


@pytest.mark.parametrize("count", [True, False])
def test_each_router_counts_the_states_it_sent_to_and_got_from_the_other(count):
    a, b = f"tcp/127.0.0.1:{free_port()}", f"tcp/127.0.0.1:{free_port()}"
    flag = ["--count-traffic"] if count else []
    routers = [subprocess.Popen(FS + ["router", "--listen", a, *flag], **KW)]
    sessions: list[zenoh.Session] = []
    try:
        assert routers[0].stdout.readline().startswith("router=")
        routers.append(subprocess.Popen(FS + ["router", "--listen", b, "--connect", a, *flag], **KW))
        assert routers[1].stdout.readline().startswith("router=")
        on_a, on_b = _client(a), _client(b)
        sessions += [on_a, on_b]
        heard: list[str] = []
        sub = on_a.declare_subscriber(f"{keys.PREFIX}/t/**", lambda s: heard.append(str(s.key_expr)))
        time.sleep(1.0)  # the subscription reaches router B
        for i in range(40):  # states on an id key and on a cell key: both are states
            on_b.put(keys.state_key("t", i % 4), b"s" * 104)
            on_b.put(f"{keys.PREFIX}/t/state/3/4", b"s" * 104)
        for _ in range(7):  # not a state: not counted
            on_b.put(keys.ctl_key("t", "clock"), b"c")
        assert wait_until(lambda: len(heard) == 87, 10.0), len(heard)
        sub.undeclare()
        for s in sessions:
            s.close()
        sessions.clear()
        # B first: A's link to it is then gone, and still counted (zenoh keeps a lost link's counts 60 s)
        out_b, err_b = _stop(routers[1])
        out_a, err_a = _stop(routers[0])
        assert routers[0].returncode == 0 and routers[1].returncode == 0, err_a + err_b
        if count:
            assert _traffic(out_b) == {"sent": 80, "received": 0, "links": 1}
            assert _traffic(out_a) == {"sent": 0, "received": 80, "links": 1}
        else:
            assert "router_traffic" not in out_a + out_b
    finally:
        for s in sessions:
            s.close()
        for r in routers:
            if r.poll() is None:
                r.kill()
                r.wait()


def test_counting_without_the_counting_router_built_is_one_line(tmp_path):
    """A router binary with no fluidswarm-router-traffic beside it (a build without `make router-traffic`)."""
    from swarmhost.executable import router_executable

    alone = tmp_path / "fluidswarm-router"
    alone.symlink_to(router_executable())
    env = dict(os.environ, FLUIDSWARM_ROUTER_BIN=str(alone))
    done = subprocess.run(
        FS + ["router", "--listen", f"tcp/127.0.0.1:{free_port()}", "--count-traffic"], env=env, timeout=60, **KW
    )
    assert done.returncode == 1
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr, done.stderr
    assert "make router-traffic" in done.stderr and done.stdout == "", done.stderr
