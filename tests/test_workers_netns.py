"""The main job over three hosts (issue 37's network-namespace acceptance): hosts A, B, C (tests/netns.py), each
its own compiled router, B and C joined to A over QUIC with mutual TLS, one users file made by `fluidswarm
auth-file`; `imitate PHOTO --workers 2` on host A, `fluidswarm worker` on B and C. A whole run: every agent of
the three hosts finishes in host A's record, the formation scores IoU >= 0.75 against the silhouette, the MCAP
is complete. Then host C's router is killed mid-run: A and B finish, and the record, the MCAP and `replay
--check` name the agents lost with host C (docs/multi-host.md "A lost worker host")."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from fluidswarm.recording.reader import load_run
from tests.netns import Hosts, NetnsUnavailable
from tests.swarm_helpers import wait_recorded_steps
from tests.test_multihost import PORT, QUIC_PORT, make_certificates

pytestmark = pytest.mark.swarm  # starts routers, agents and the CLI (tests/conftest.py)

FS = [sys.executable, "-m", "fluidswarm"]
PHOTO = Path(__file__).resolve().parents[1] / "scenarios" / "inputs" / "digit2_IMG_1140.JPG"  # a hand, in the repo
# The figure is 180 agents (measured by hand, docs/multi-host.md); make test runs the same runs at 90,
# which hold every mechanism (three regions, TLS links, a lost host) in a third of the time.
AGENTS = int(os.environ.get("FLUIDSWARM_NETNS_AGENTS", "90"))
KW = dict(stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _ready(proc: subprocess.Popen, what: str) -> None:
    line = proc.stdout.readline()
    assert line.startswith("router="), f"router {what} did not come up: {line!r}"


@pytest.fixture
def three(tmp_path):
    """Hosts A, B, C with a router each (B and C connect to A over QUIC, mutual TLS) and one users file."""
    try:
        h = Hosts()
    except NetnsUnavailable as exc:
        pytest.fail(f"multi-host tests need network namespaces: {exc}")
    try:
        a_b, b = h.addr[("a", "b")], h.addr[("b", "a")]
        a_c, c = h.addr[("a", "c")], h.addr[("c", "a")]
        # router A answers on both of its links: one certificate naming both addresses
        certs = make_certificates(tmp_path, {"a": f"{a_b},IP:{a_c}", "b": b, "c": c})
        ca = str(tmp_path / "ca.pem")

        def tls(name: str) -> list[str]:
            return ["--tls-ca", ca, "--tls-cert", certs[name][0], "--tls-key", certs[name][1]]

        users = tmp_path / "users.txt"
        made = subprocess.run(FS + ["auth-file", "--agents", str(AGENTS), "--out", str(users)], **KW)
        assert made.returncode == 0, made.stderr
        auth = ["--auth-file", str(users)]
        listen_a = ["--listen", f"tcp/{a_b}:{PORT}", "--listen", f"quic/{a_b}:{QUIC_PORT}"]
        listen_a += ["--listen", f"quic/{a_c}:{QUIC_PORT}"]
        routers = {"a": h.popen("a", FS + ["router", *listen_a, *auth, *tls("a")], stdout=subprocess.PIPE, text=True)}
        for name, own, hub in (("b", b, a_b), ("c", c, a_c)):
            cmd = ["router", "--listen", f"tcp/{own}:{PORT}", "--connect", f"quic/{hub}:{QUIC_PORT}", *auth]
            routers[name] = h.popen(name, FS + cmd + tls(name), stdout=subprocess.PIPE, text=True)
        for name, proc in routers.items():
            _ready(proc, name)
        h.routers = routers
        h.endpoint = {"a": f"tcp/{a_b}:{PORT}", "b": f"tcp/{b}:{PORT}", "c": f"tcp/{c}:{PORT}"}
        h.env = dict(os.environ, FLUIDSWARM_AUTH_FILE=str(users))
        yield h
    finally:
        h.close()


def _start(three, tmp_path: Path, run: str, steps: tuple[str, ...] = ()):
    """imitate on A with two workers, B's and C's (`steps`: imitate's --steps, if given): (main, {host: worker})."""
    out = tmp_path / run
    main = three.popen(
        "a",
        FS
        + ["imitate", str(PHOTO), "--agents", str(AGENTS), "--out", str(out), "--json", *steps]
        + ["--connect", three.endpoint["a"], "--run", run, "--workers", "2"],
        env=three.env,
        **KW,
    )
    workers = {
        host: three.popen(host, FS + ["worker", "--connect", three.endpoint[host], "--run", run], env=three.env, **KW)
        for host in "bc"
    }
    return main, workers, out


def _shares(workers) -> dict[str, tuple[int, int]]:
    """Each worker's first line, `run=R share=K/M agents=N ...`: {host: (share, agents)}."""
    out = {}
    for host, proc in workers.items():
        line = proc.stdout.readline()
        words = dict(w.split("=", 1) for w in line.split() if "=" in w)
        assert "share" in words, f"worker {host}: {line!r} {proc.stderr.read() if proc.poll() is not None else ''}"
        out[host] = (int(words["share"].split("/")[0]), int(words["agents"]))
    return out


def _check(path: Path) -> subprocess.CompletedProcess:
    return subprocess.run(FS + ["replay", str(path), "--check"], timeout=120, **KW)


def test_an_imitation_over_three_hosts_finishes_every_agent_then_survives_losing_one(three, tmp_path):
    # A whole run: every agent of every host finishes in the main record.
    main, workers, _out = _start(three, tmp_path, "whole")
    shares = _shares(workers)
    out_m, err_m = main.communicate(timeout=400)
    done = {host: p.communicate(timeout=60) for host, p in workers.items()}
    assert main.returncode == 0, err_m[-3000:]
    for host, p in workers.items():
        assert p.returncode == 0, done[host][1][-2000:]
        assert f"finished={shares[host][1]}" in done[host][0].split(), done[host][0][-2000:]
    record = json.loads(out_m.strip().splitlines()[-1])
    print({k: record[k] for k in ("agents", "finished", "steps_per_second", "startup_seconds")}, record["fidelity"])
    assert sorted(s for s, _n in shares.values()) == [2, 3]
    assert record["agents"] == AGENTS and record["finished"] == AGENTS
    assert record["fidelity"]["iou"] >= 0.75
    assert record["lost_hosts"] == []
    checked = _check(Path(record["mcap"]))
    assert checked.returncode == 0 and "complete=true" in checked.stdout, checked.stdout + checked.stderr

    # Host C's router killed once the swarm steps: A and B finish, the loss named with C's agents. 250 steps, not
    # the imitation's 700: the swarm cannot step past C's held clock before C is dropped (PACE_SILENCE, 5 s; seen
    # at step 71), and what it forms after that is not this run's question (700 steps: ~8 s more, same asserts).
    main, workers, out = _start(three, tmp_path, "cut", ("--steps", "250"))
    shares = _shares(workers)

    wait_recorded_steps(lambda: next(out.glob("*.mcap"), None), 40, main, 240)
    three.routers["c"].kill()
    out_m, err_m = main.communicate(timeout=400)
    out_b, err_b = workers["b"].communicate(timeout=120)
    workers["c"].kill()  # its router gone, it waits for agents that cannot report: not this test's side
    assert main.returncode == 0, err_m[-3000:]
    assert workers["b"].returncode == 0, err_b[-2000:]
    assert f"finished={shares['b'][1]}" in out_b.split(), out_b[-2000:]
    record = json.loads(out_m.strip().splitlines()[-1])
    c_agents = shares["c"][1]
    print({k: record[k] for k in ("finished", "lost_hosts", "notes")}, record["fidelity"])
    assert record["finished"] == AGENTS - c_agents  # A's and B's
    [lost] = record["lost_hosts"]
    assert lost["agents"] == c_agents and len(lost["ids"]) == c_agents
    assert record["fidelity"]["iou"] > 0.0  # scored on the agents that finished
    events = [e for e in load_run(Path(record["mcap"]), images=False).events if e.kind == "host_lost"]
    assert len(events) == 1 and events[0].name == "launcher", events
    assert f"agents {lost['ids'][0]}" in events[0].message
    checked = _check(Path(record["mcap"]))
    assert "lost_host t=" in checked.stdout and events[0].message in checked.stdout, checked.stdout + checked.stderr
