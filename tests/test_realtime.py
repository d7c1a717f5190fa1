"""`--realtime` offered to the commands that otherwise run as fast as they can (issue 32 item 3): a small swarm
held to the wall clock reports the factor it kept, in the record and in the MCAP (the recorder's own
measure, `replay --check` prints it); without it the same swarm runs faster than the wall clock."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from fluidswarm.recording.reader import load_run

pytestmark = pytest.mark.swarm  # starts agents (tests/conftest.py)

FS = [sys.executable, "-m", "fluidswarm"]


def _launch(tmp_path, *extra: str) -> tuple[dict, object]:
    mcap = tmp_path / f"run{len(extra)}.mcap"
    cmd = FS + ["launch", "-n", "9", "--steps", "150", "--record", str(mcap), "--json", *extra]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=180)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1]), mcap


def test_launch_realtime_keeps_the_wall_clock_and_records_the_factor(tmp_path):
    paced, mcap = _launch(tmp_path, "--realtime")
    free, free_mcap = _launch(tmp_path)
    print(paced["realtime_factor"], free["realtime_factor"], paced["wall_seconds"], free["wall_seconds"])
    # never faster than the wall clock, and 9 agents keep up with it (the clock is held CLOCK_LEAD + 1 steps back)
    assert 0.85 <= paced["realtime_factor"] <= 1.02
    # as fast as it can: ahead of real time (9 agents step ~150 times a simulated second of 100 steps here)
    assert free["realtime_factor"] > 1.1
    recorded = load_run(mcap, images=False).timing
    assert recorded["steps_seen"] >= 140 and abs(recorded["realtime_factor"] - paced["realtime_factor"]) < 0.1
    assert load_run(free_mcap, images=False).timing["realtime_factor"] > 1.1
    checked = subprocess.run(FS + ["replay", str(mcap), "--check"], capture_output=True, text=True, timeout=60)
    assert f"recorded_realtime_factor={recorded['realtime_factor']:.4f}" in checked.stdout.split(), checked.stdout
