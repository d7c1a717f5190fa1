"""Agents on several "hosts" (network namespaces) joined by Zenoh routers; auth keeps rogues out."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest

from fluidswarm.recording.reader import load_run
from tests.netns import Hosts, NetnsUnavailable

pytestmark = pytest.mark.swarm  # starts agents, routers or the CLI (tests/conftest.py)

FS = [sys.executable, "-m", "fluidswarm"]
PORT = 7447


@pytest.fixture
def hosts(tmp_path):
    try:
        h = Hosts()
    except NetnsUnavailable as exc:
        pytest.fail(f"multi-host tests need network namespaces: {exc}")
    auth = tmp_path / "users.txt"
    auth.write_text("swarm:s3cret\n")
    a, b = h.addr[("a", "b")], h.addr[("b", "a")]
    a_c = h.addr[("a", "c")]
    cred = ["--user", "swarm", "--password", "s3cret"]
    h.popen("a", FS + ["router", "--listen", f"tcp/{a}:{PORT}", "--listen", f"tcp/{a_c}:{PORT}",
                       "--auth-file", str(auth)] + cred, stdout=subprocess.PIPE, text=True)
    h.popen("b", FS + ["router", "--listen", f"tcp/{b}:{PORT}", "--connect", f"tcp/{a}:{PORT}",
                       "--auth-file", str(auth)] + cred, stdout=subprocess.PIPE, text=True)
    time.sleep(2.0)
    h.cred = cred
    try:
        yield h
    finally:
        h.close()


def figures(text: str) -> dict:
    return dict(line.split("=", 1) for line in text.split() if "=" in line)


def test_split_swarm_reproduces_single_host_result_and_rogue_is_locked_out(hosts):
    a, b = hosts.addr[("a", "b")], hosts.addr[("b", "a")]
    rogue_target = hosts.addr[("a", "c")]
    common = ["verify", "--agents", "40", "--steps", "120", "--run", "split"] + hosts.cred
    pa = hosts.popen("a", FS + common + ["--ids", "0-19", "--connect", f"tcp/{a}:{PORT}"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    pb = hosts.popen("b", FS + common + ["--ids", "20-39", "--connect", f"tcp/{b}:{PORT}"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    rogue = hosts.popen("c", [sys.executable, "-c", ROGUE, f"tcp/{rogue_target}:{PORT}"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    out_a, err_a = pa.communicate(timeout=300)
    out_b, err_b = pb.communicate(timeout=300)
    r_out, r_err = rogue.communicate(timeout=60)
    fa, fb = figures(out_a), figures(out_b)
    print(fa, fb, r_out.strip())
    assert pa.returncode == 0 and pb.returncode == 0, err_a + err_b
    assert float(fa["max_position_error"]) <= 1e-9 and float(fb["max_position_error"]) <= 1e-9
    assert "rogue=locked_out" in r_out, r_out + r_err


def test_losing_one_hosts_router_the_other_host_completes_and_logs_the_loss(hosts, tmp_path):
    a, b = hosts.addr[("a", "b")], hosts.addr[("b", "a")]
    mcap = tmp_path / "a.mcap"
    # Enough steps that the cut comes mid-run (the compiled agents do 500 steps in well under the 9 s below).
    steps = 4000
    common = ["launch", "-n", "40", "--steps", str(steps), "--run", "cut", "--timeout", "1.0"] + hosts.cred
    pa = hosts.popen("a", FS + common + ["--ids", "0-19", "--connect", f"tcp/{a}:{PORT}", "--record", str(mcap)],
                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    pb = hosts.popen("b", FS + common + ["--ids", "20-39", "--connect", f"tcp/{b}:{PORT}"],
                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(9.0)  # start-up, then some lockstep steps with both hosts
    router_b = hosts.procs[1]
    router_b.kill()
    out_a, err_a = pa.communicate(timeout=300)
    pb.terminate()
    fa = figures(out_a)
    print(fa)
    assert pa.returncode == 0, err_a
    assert fa["finished"] == "20"
    run = load_run(mcap, images=False)
    lost = {e.agent for e in run.events if e.kind == "died" and e.agent is not None and e.agent >= 20 and e.step < steps}
    assert len(lost) >= 10


ROGUE = r'''
import json, sys, zenoh
conf = zenoh.Config()
conf.insert_json5("mode", '"client"')
conf.insert_json5("connect/endpoints", json.dumps([sys.argv[1]]))
conf.insert_json5("connect/timeout_ms", "5000")
conf.insert_json5("scouting/multicast/enabled", "false")
try:
    s = zenoh.open(conf)
except Exception as exc:
    print("rogue=locked_out", str(exc).splitlines()[0][:80])
    sys.exit(0)
import time
for k in range(200):
    s.put("fluidswarm/split/state/0/0", b"x" * 88)
    s.put("fluidswarm/split/command", b"{}")
    time.sleep(0.02)
print("rogue=connected")
'''
