"""An imitation over two hosts on one machine (issue 37's loopback acceptance, small): `fluidswarm auth-file`,
two routers on loopback holding it (B connected to A), `imitate PHOTO --connect A --run R --workers 1` and
`fluidswarm worker --connect B --run R`: the worker fetches its region of the signed plan, starts its agents,
and their reports reach the main host's record; the bad inputs of a worker and of a main host are one line
each (docs/multi-host.md "Workers")."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from swarmhost.router_host import free_port
from swarmhost.supervisor import stop_process

pytestmark = pytest.mark.swarm  # starts routers and the CLI (tests/conftest.py)

FS = [sys.executable, "-m", "fluidswarm"]
PHOTO = Path(__file__).resolve().parents[1] / "scenarios" / "inputs" / "digit2_IMG_1140.JPG"  # a hand, in the repo
KW = dict(stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _routers(users: Path):
    a, b = f"tcp/127.0.0.1:{free_port()}", f"tcp/127.0.0.1:{free_port()}"
    auth = ["--auth-file", str(users)]
    routers = [subprocess.Popen(FS + ["router", "--listen", a] + auth, **KW)]
    assert routers[0].stdout.readline().startswith("router="), "router A did not come up"
    routers.append(subprocess.Popen(FS + ["router", "--listen", b, "--connect", a] + auth, **KW))
    assert routers[1].stdout.readline().startswith("router="), "router B did not come up"
    return a, b, routers


def _users(tmp_path: Path, agents: int) -> Path:
    users = tmp_path / "users.txt"
    made = subprocess.run(FS + ["auth-file", "--agents", str(agents), "--out", str(users)], **KW)
    assert made.returncode == 0, made.stderr
    return users


def _one_error_line(err: str, what: str) -> None:
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert what in err, err


def test_an_imitation_with_one_worker_finishes_every_agent_and_refuses_bad_workers(tmp_path):
    agents = 30
    users = _users(tmp_path, agents)
    a, b, routers = _routers(users)
    env = dict(os.environ, FLUIDSWARM_AUTH_FILE=str(users))
    procs: list[subprocess.Popen] = []
    try:
        # a worker of a run nobody serves: one line, nothing started
        lost = subprocess.run(FS + ["worker", "--connect", b, "--run", "nosuch", "--wait", "1"], env=env, **KW)
        assert lost.returncode == 1
        _one_error_line(lost.stderr, "run nosuch: no main host served its plan")
        assert "share=" not in lost.stdout
        main = subprocess.Popen(
            FS
            + ["imitate", str(PHOTO), "--agents", str(agents), "--out", str(tmp_path / "out"), "--json"]
            + ["--connect", a, "--run", "pair", "--workers", "1"],
            env=env,
            **KW,
        )
        procs.append(main)
        worker = subprocess.Popen(FS + ["worker", "--connect", b, "--run", "pair"], env=env, **KW)
        procs.append(worker)
        line = worker.stdout.readline()
        assert line.startswith("run=pair share=2/2 agents=15 "), line + worker.stderr.read()
        # a second worker: the run's one share is taken (or the run has started): one line, nothing started
        late = subprocess.run(FS + ["worker", "--connect", b, "--run", "pair"], env=env, timeout=60, **KW)
        assert late.returncode == 1
        assert late.stderr.count("\n") == 1 and "nothing was started" in late.stderr, late.stderr
        assert "every share already has its worker" in late.stderr or "already started" in late.stderr
        out_w, err_w = worker.communicate(timeout=120)
        out_m, err_m = main.communicate(timeout=120)
        assert worker.returncode == 0, err_w
        assert main.returncode == 0, err_m
        assert "finished=15" in out_w.split()
        record = json.loads(out_m.strip().splitlines()[-1])
        print(record["finished"], record["fidelity"], record["steps_per_second"])
        assert record["agents"] == agents and record["finished"] == agents  # the worker's 15 in the main record
        assert record["fidelity"]["iou"] >= 0.6
        assert Path(record["mcap"]).stat().st_size > 0
    finally:
        for p in procs:
            stop_process(p, 15.0)
        for r in reversed(routers):
            r.terminate()
            r.wait(10)


def test_a_main_host_whose_workers_do_not_come_says_how_many_came_in_one_line(tmp_path):
    users = _users(tmp_path, 8)
    a, _b, routers = _routers(users)
    try:
        cmd = ["imitate", str(PHOTO), "--agents", "8", "--out", str(tmp_path / "out"), "--connect", a]
        done = subprocess.run(
            FS + cmd + ["--run", "alone", "--workers", "2", "--workers-timeout", "2", "--auth-file", str(users)],
            timeout=120,
            **KW,
        )
        assert done.returncode == 1
        _one_error_line(done.stderr, "0 of 2 workers came in 2 s")
    finally:
        for r in reversed(routers):
            r.terminate()
            r.wait(10)


def test_a_scenario_runs_with_a_worker_and_one_with_failures_is_refused(tmp_path):
    users = _users(tmp_path, 60)
    a, b, routers = _routers(users)
    env = dict(os.environ, FLUIDSWARM_AUTH_FILE=str(users))
    procs: list[subprocess.Popen] = []
    try:
        # failures are injected by one launcher on its own agents: refused before anything starts
        refused = subprocess.run(
            FS + ["run", "hand_failures_kill20", "--connect", a, "--run", "kill", "--workers", "1"],
            env=env,
            timeout=60,
            **KW,
        )
        assert refused.returncode == 1
        _one_error_line(refused.stderr, "--workers: ")
        assert "injects failures" in refused.stderr
        main = subprocess.Popen(
            FS
            + ["run", "demo_v_sign", "--out", str(tmp_path / "demo"), "--json"]
            + ["--connect", a, "--run", "scene", "--workers", "1"],
            env=env,
            **KW,
        )
        procs.append(main)
        worker = subprocess.Popen(FS + ["worker", "--connect", b, "--run", "scene"], env=env, **KW)
        procs.append(worker)
        out_w, err_w = worker.communicate(timeout=180)
        out_m, err_m = main.communicate(timeout=180)
        assert worker.returncode == 0, err_w
        record = json.loads(out_m.strip().splitlines()[-1])
        print(record["finished"], record["fidelity"], record["passed"], record["why"])
        assert main.returncode == 0 and record["passed"], err_m[-2000:]  # the shipped scenario's own criteria
        assert record["agents"] == 60 and record["finished"] == 60 and "finished=30" in out_w.split()
    finally:
        for p in procs:
            stop_process(p, 15.0)
        for r in reversed(routers):
            r.terminate()
            r.wait(10)
