"""The recorder process on real swarms: complete MCAP files after normal runs, kills, and SIGINT."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading

import pytest
from mcap.reader import make_reader

from agent.sph.setups import spread_block
from fluidswarm.recording.reader import check, load_run
from swarmhost.launcher import Launcher, run_swarm
from swarmhost.router_host import free_port
from tests.swarm_helpers import wait_for_live_step

pytestmark = pytest.mark.swarm  # starts agents, routers or the CLI (tests/conftest.py)

FOXGLOVE = {"foxglove.PointCloud", "foxglove.Log"}


def schemas_and_metadata(path):
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        names = {s.name for s in summary.schemas.values()}
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
    return names, meta


def test_recorder_complete_after_20_percent_killed(tmp_path):
    setup = spread_block(20)
    path = tmp_path / "run.mcap"
    victims = (2, 7, 11, 15)
    with Launcher() as la:
        la.start_recorder(str(path), {"scenario": "kill-test", "agent_ids": list(range(20))}, setup.params.dt)
        la.track_progress()

        def kill(l):
            def go():
                l.wait_step(30, 60)
                for v in victims:
                    os.kill(l.swarm.procs[v].pid, signal.SIGKILL)

            threading.Thread(target=go, daemon=True).start()

        run_swarm(setup, 90, launcher=la, on_started=kill)
    complete, steps, missing = check(path)
    assert (complete, missing) == (True, 0) and steps >= 90
    names, meta = schemas_and_metadata(path)
    assert FOXGLOVE <= names
    assert "kill-test" in meta["run"]["scenario"]
    run = load_run(path, images=False)
    # Victims die mid-run; everyone else leaves only after the last step.
    died_early = {e.agent for e in run.events if e.kind == "died" and e.step < 90}
    assert died_early == set(victims)
    # Every step before the kill holds all 20 agents; the victims vanish after their death event.
    assert len(run.frames[10].ids) == 20 and len(run.frames[-1].ids) == 16


def test_recorder_file_finished_after_sigint_to_launcher(tmp_path):
    path = tmp_path / "interrupted.mcap"
    port = free_port()
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "fluidswarm",
            "launch",
            "-n",
            "9",
            "--steps",
            "100000",
            "--record",
            str(path),
            "--live",
            f"127.0.0.1:{port}",
            "--progress",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout.readline().startswith("run=")
        seen = wait_for_live_step(port, 20)  # stepping, and the recorder has the states up to there
        proc.send_signal(signal.SIGINT)
        proc.wait(60)
    finally:
        if proc.poll() is None:
            proc.kill()
    # --progress: the line scripts/soak.py reads (step/total, steps/s; later draws add alive, failures), a new
    # line per draw into a pipe (every 5 s: this run is shorter, so its first draw is what there is)
    assert re.search(r"step \[[# ]+\] \d+/100000\s+[\d.]+ steps/s", proc.stderr.read())
    complete, steps, missing = check(path)
    print(f"SIGINT after step {seen} was streamed; the file holds {steps} steps")
    assert steps >= seen
    assert complete and missing == 0
