"""Faults that must neither hang a run nor lose its record (issue 36): a killed router or recorder ends the run
in seconds, named in one line, with no process left and the record kept; frozen agents rejoin; ids beyond the
router's bound and an unwritable recording are one line before anything starts."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from agent.protocol.access import AGENT_CAPACITY
from agent.protocol.events import EventKind
from agent.sph.setups import spread_block
from fluidswarm.recording.reader import check, finished, load_run
from swarmhost.helpers import HelperLost
from swarmhost.launcher import Launcher, run_swarm
from swarmhost.router_host import free_port
from tests.swarm_helpers import children_of, is_running, wait_for_live_step, wait_until

V_SIGN = Path(__file__).resolve().parents[1] / "scenarios" / "inputs" / "digit2_IMG_1140.JPG"

pytestmark = pytest.mark.swarm  # starts agents, routers or the CLI (tests/conftest.py)


def descendants(pid: int) -> set[int]:
    out, todo = set(), [pid]
    while todo:
        for c in children_of(todo.pop()):
            if c not in out:
                out.add(c)
                todo.append(c)
    return out


def comm(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/comm") as f:
            return f.read().strip()
    except FileNotFoundError:
        return ""


def test_a_killed_router_ends_the_launch_within_5_s_naming_it_and_leaves_nothing(tmp_path):
    path = tmp_path / "run.mcap"
    port = free_port()
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "fluidswarm",
            "launch",
            "-n",
            "20",
            "--steps",
            "100000",
            "--record",
            str(path),
            "--live",
            f"127.0.0.1:{port}",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout.readline().startswith("run=")
        wait_for_live_step(port, 30)  # stepping, and being recorded
        family = descendants(proc.pid)
        routers = [p for p in family if comm(p).startswith("fluidswarm-rout")]
        assert len(routers) == 1 and len(family) >= 22  # 20 agents, the router, the recorder
        os.kill(routers[0], signal.SIGKILL)
        t0 = time.monotonic()
        proc.wait(30)
        took = time.monotonic() - t0
        err = [line for line in proc.stderr.read().strip().splitlines() if not line.startswith("live: ")]
    finally:
        if proc.poll() is None:
            proc.kill()
    print(f"exit {proc.returncode} {took:.2f} s after the router's kill: {err}")
    assert proc.returncode != 0 and took <= 5.0
    assert len(err) == 1 and "lost the embedded router (fluidswarm-router" in err[0] and "SIGKILL" in err[0]
    assert wait_until(lambda: not any(is_running(p) for p in family), 2.0), "a process of the run outlived it"
    complete, steps, missing = check(path)
    assert complete and missing == 0 and steps >= 30


def cmdline(pid: int) -> list[str]:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return f.read().decode(errors="replace").split("\0")
    except FileNotFoundError:
        return []


def test_a_hosts_router_that_dies_is_named_with_its_last_words(tmp_path):
    """`fluidswarm router` (a host's router, long-lived): when its fluidswarm-router ends, the one line names how
    and what it last said on stderr (a panic's message, say), which is otherwise gone with its private folder.
    The last words are written into the router's own stderr (/proc/PID/fd/2) by the test, then it is aborted."""
    port = free_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "fluidswarm", "router", "--listen", f"tcp/127.0.0.1:{port}"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout.readline().startswith("router=")
        routers = [p for p in descendants(proc.pid) if comm(p).startswith("fluidswarm-rout")]
        assert len(routers) == 1
        with open(f"/proc/{routers[0]}/fd/2", "a") as stderr:
            stderr.write("thread 'rx-0' panicked at src/relay.rs:1:1: a test's last words\n")
        os.kill(routers[0], signal.SIGABRT)
        proc.wait(10)
        err = proc.stderr.read().strip().splitlines()
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode != 0, err
    assert len(err) == 1 and f"(fluidswarm-router, pid {routers[0]}) was killed by signal 6 (SIGABRT)" in err[0], err
    assert err[0].endswith(": thread 'rx-0' panicked at src/relay.rs:1:1: a test's last words"), err


def test_a_coordinator_killed_mid_imitation_ends_it_naming_the_coordinator(tmp_path):
    port = free_port()
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "fluidswarm",
            "imitate",
            str(V_SIGN),
            "--agents",
            "16",
            "--steps",
            "100000",
            "--out",
            str(tmp_path),
            "--live",
            f"127.0.0.1:{port}",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        wait_for_live_step(port, 20, timeout=120)
        family = descendants(proc.pid)
        coordinators = [p for p in family if "coordinator" in cmdline(p)[1:3]]
        assert len(coordinators) == 1
        os.kill(coordinators[0], signal.SIGKILL)
        t0 = time.monotonic()
        proc.wait(30)
        took = time.monotonic() - t0
        err = [line for line in proc.stderr.read().strip().splitlines() if not line.startswith("live: ")]
    finally:
        if proc.poll() is None:
            proc.kill()
    print(f"exit {proc.returncode} {took:.2f} s after the coordinator's kill: {err}")
    assert proc.returncode != 0 and took <= 5.0
    assert len(err) == 1 and "lost the coordinator" in err[0]
    assert wait_until(lambda: not any(is_running(p) for p in family), 2.0), "a process of the run outlived it"


def test_a_killed_recorder_ends_the_run_and_its_file_keeps_every_step_older_than_1_s(tmp_path):
    setup = spread_block(30)
    path = tmp_path / "run.mcap"
    killed: dict[str, float] = {}
    with Launcher() as la:
        la.start_recorder(str(path), {"scenario": "recorder-kill", "agent_ids": list(range(30))}, setup.params.dt)
        la.track_progress()

        def kill(launcher):
            def go():
                time.sleep(5.0)
                killed["t"] = time.monotonic()
                os.kill(launcher.recorder.proc.pid, signal.SIGKILL)

            threading.Thread(target=go, daemon=True).start()

        with pytest.raises(HelperLost) as info:
            run_swarm(setup, 100000, launcher=la, on_started=kill, run_timeout=60)
        noticed = time.monotonic() - killed["t"]
        step_times = dict(la.pacer.step_times)
    message = str(info.value)
    print(f"{message} (noticed {noticed:.2f} s after the kill)")
    assert noticed <= 2.0 and "lost the recorder" in message and "SIGKILL" in message and "\n" not in message
    run = load_run(path, images=False)  # its writer died: read up to its last whole chunk
    assert run.truncated
    due = [s for s, t in step_times.items() if t <= killed["t"] - 1.0]
    assert due, "the swarm made no step in the first 4 s"
    kept = {f.step: len(f.ids) for f in run.frames}
    print(f"swarm at step {max(due)} 1 s before the kill; the file keeps steps 0..{max(kept)}")
    assert all(kept.get(s) == 30 for s in range(max(due) + 1))


def test_a_launch_whose_recorder_is_killed_names_it_and_leaves_its_file_finished(tmp_path):
    # The run's end rewrites a file left without its footer (recording/recover.py after_recorder): readable by
    # any MCAP tool, every step the recorder had flushed, and the kill named beside the lost helper.
    path = tmp_path / "run.mcap"
    port = free_port()
    cmd = [sys.executable, "-m", "fluidswarm", "launch", "-n", "20", "--steps", "100000", "--record", str(path)]
    proc = subprocess.Popen(
        [*cmd, "--live", f"127.0.0.1:{port}"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout.readline().startswith("run=")
        seen = wait_for_live_step(port, 200)  # > 1 s of steps: flushed to the file (writer.py FLUSH_SECONDS)
        recorders = [p for p in descendants(proc.pid) if "fluidswarm.recording.recorder" in cmdline(p)[1:3]]
        assert len(recorders) == 1
        os.kill(recorders[0], signal.SIGKILL)
        proc.wait(30)
        err = [line for line in proc.stderr.read().strip().splitlines() if not line.startswith("live: ")]
    finally:
        if proc.poll() is None:
            proc.kill()
    print(f"exit {proc.returncode}, live step {seen} before the kill: {err}")
    assert proc.returncode != 0 and any("lost the recorder" in line for line in err)
    said = [line for line in err if "was killed by signal 9 (SIGKILL) before finishing" in line]
    assert len(said) == 1 and str(path) in said[0] and "rewritten finished" in said[0]
    assert finished(path)
    run = load_run(path, images=False)
    assert not run.truncated and run.frames and run.frames[0].step == 0


def test_two_agents_frozen_for_3_s_rejoin_and_all_30_finish(tmp_path):
    setup = spread_block(30)
    path = tmp_path / "run.mcap"
    victims = (9, 20)
    with Launcher() as la:
        la.start_recorder(str(path), {"scenario": "freeze", "agent_ids": list(range(30))}, setup.params.dt)
        la.track_progress()

        def freeze(launcher):
            def go():
                launcher.wait_step(30, 60)
                for v in victims:
                    os.kill(launcher.swarm.procs[v].pid, signal.SIGSTOP)
                time.sleep(3.0)
                for v in victims:
                    os.kill(launcher.swarm.procs[v].pid, signal.SIGCONT)

                def rejoined() -> set[int]:
                    with launcher.swarm.changed:
                        return {e.id for e in launcher.swarm.events if e.kind is EventKind.REJOINED}

                wait_until(lambda: rejoined() >= set(victims), 30.0)
                launcher.end_at(launcher.max_step + 30)  # a few steps together after the rejoin, then the end

            threading.Thread(target=go, daemon=True).start()

        result = run_swarm(setup, 100000, launcher=la, on_started=freeze, run_timeout=90)
    done = {i for i, r in result.finals.items() if r.done}
    rejoins = [e for e in result.events if e.kind is EventKind.REJOINED]
    print(f"finished {len(done)}/30; rejoined: {[(e.id, e.from_step, e.step) for e in rejoins]}")
    assert done == set(range(30))
    assert {e.id for e in rejoins} == set(victims) and all(e.step > e.from_step + 5 for e in rejoins)
    run = load_run(path, images=False)
    recorded = {e.agent for e in run.events if e.kind == "rejoined"}
    assert recorded == set(victims)
    # every event says whose it is and when; finishing agents are not deaths
    assert all(e.agent is not None and e.step is not None for e in run.events)
    assert not [e for e in run.events if e.kind == "died" and e.agent not in victims]
    assert {e.agent for e in run.events if e.kind == "finished"} == set(range(30))
    complete, _steps, missing = check(path)
    assert complete and missing == 0


def test_ids_beyond_the_routers_bound_are_one_line_and_nothing_starts(tmp_path):
    t0 = time.monotonic()
    out = subprocess.run(
        [sys.executable, "-m", "fluidswarm", "launch", "-n", str(9000), "--steps", "5"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    err = out.stderr.strip().splitlines()
    assert out.returncode != 0 and len(err) == 1 and f"0..{AGENT_CAPACITY - 1}" in err[0], out.stderr
    assert "Traceback" not in out.stderr and time.monotonic() - t0 < 30
    bad = tmp_path / "no" / "such" / "x.mcap"
    out = subprocess.run(
        [sys.executable, "-m", "fluidswarm", "launch", "-n", "3", "--steps", "5", "--record", str(bad)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    err = out.stderr.strip().splitlines()
    assert out.returncode != 0 and len(err) == 1 and str(bad) in err[0] and "no such directory" in err[0], out.stderr
