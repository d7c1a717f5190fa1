"""`fluidswarm bench --quick --json` produces every field tools rely on, as one typed record on stdout that is
also results.json (figures are checked by reading them)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from fluidswarm.orchestration.bench_record import BenchRecord, FailedRun, LockstepRun

pytestmark = pytest.mark.swarm  # starts agents, routers or the CLI (tests/conftest.py)


def test_bench_quick_writes_every_field(tmp_path):
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "fluidswarm",
            "bench",
            "--quick",
            "--ns",
            "4,9",
            "--steps",
            "15",
            "--gesture-agents",
            "8",
            "--out",
            str(tmp_path),
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    printed = BenchRecord.from_dict(json.loads(r.stdout))  # the whole of stdout: one JSON object
    res = BenchRecord.load(tmp_path / "results.json")
    assert printed == res
    assert "n=4 steps_per_second=" in r.stderr  # the per-N lines still show, on stderr
    assert res.machine.cores >= 1 and res.machine.memory_mb > 0 and res.quick
    assert [run.n for run in res.runs] == [4, 9]
    assert not any(isinstance(run, FailedRun) for run in res.runs), res.runs
    for run in res.runs:
        assert isinstance(run, LockstepRun) and run.steps == 15 and run.agents_finished == run.n
        for key in (
            "steps_per_second",
            "msgs_per_agent_step",
            "rss_mb_per_agent",
            "pss_mb_per_agent",
            "centralised_steps_per_second",
            "decentralisation_ratio",
        ):
            assert getattr(run, key) is not None and getattr(run, key) > 0, (key, run)
    assert res.step_time_exponent is not None
    assert res.gesture_agents == 8
    assert set(res.gesture_imitation_seconds) == {"scissor", "cylindrical", "pinching"}
    assert all(v is not None and v > 0 for v in res.gesture_imitation_seconds.values())
    assert res.eigen_training_seconds is not None and res.eigen_training_seconds > 0
    assert (tmp_path / "results.md").stat().st_size > 0 and (tmp_path / "results.png").stat().st_size > 0
    assert all(v is not None and 0 <= v <= 1 for v in res.gesture_imitation_fidelity_iou.values())
    assert all(v is not None and v.seconds > 0 for v in res.gesture_imitation_formation.values())
    for v in (res.region_controller_ms_per_video_frame, res.region_controller_ms_per_hand_photo):
        assert v is not None and v > 0
    # agents report their own peak RSS (VmHWM): the compiled agent, a few MB (issue 14: <= 15), not the parent's
    assert all(1 < run.rss_mb_per_agent <= 15 for run in res.runs)
    # Pss shares the program's pages among the agents: well below RSS with 9 agents mapping one binary
    assert all(0 < run.pss_mb_per_agent < 0.6 * run.rss_mb_per_agent for run in res.runs)
    # every process of the run while it steps (issue 32): the router, the recorder and the launcher beside the agents
    for run in res.runs:
        helpers = run.helpers_cpu_us_per_agent_step
        assert helpers is not None and set(helpers) == {"router", "recorder", "launcher"}, run
        assert helpers["router"] > 0 and helpers["launcher"] > 0, helpers  # both handle every state
        total = run.cpu_us_per_agent_step + sum(helpers.values())
        assert abs(run.all_cpu_us_per_agent_step - total) <= 0.5, run
