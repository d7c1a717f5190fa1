"""`fluidswarm bench --quick` produces every field tools rely on (figures are checked by reading them)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

pytestmark = pytest.mark.swarm  # starts agents, routers or the CLI (tests/conftest.py)


def test_bench_quick_writes_every_field(tmp_path):
    r = subprocess.run([sys.executable, "-m", "fluidswarm", "bench", "--quick", "--ns", "4,9", "--steps", "15",
                        "--gesture-agents", "8", "--out", str(tmp_path)], capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    res = json.loads((tmp_path / "results.json").read_text())
    for key in ("date", "machine", "runs", "step_time_exponent", "gesture_imitation_seconds", "eigen_training_seconds"):
        assert key in res
    assert res["machine"]["cores"] >= 1 and res["machine"]["memory_mb"] > 0
    assert [run["n"] for run in res["runs"]] == [4, 9]
    for run in res["runs"]:
        for key in ("steps_per_second", "msgs_per_agent_step", "rss_mb_per_agent", "centralised_steps_per_second",
                    "decentralisation_ratio"):
            assert isinstance(run[key], (int, float)) and run[key] > 0, (key, run[key])
    assert set(res["gesture_imitation_seconds"]) == {"scissor", "cylindrical", "pinching"}
    assert all(isinstance(v, float) and v > 0 for v in res["gesture_imitation_seconds"].values())
    assert isinstance(res["eigen_training_seconds"], float) and res["eigen_training_seconds"] > 0
    assert (tmp_path / "results.md").stat().st_size > 0 and (tmp_path / "results.png").stat().st_size > 0
    assert all(isinstance(v, float) and 0 <= v <= 1 for v in res["gesture_imitation_fidelity_iou"].values())
    assert all(v["seconds"] > 0 and isinstance(v["settled"], bool) for v in res["gesture_imitation_formation"].values())
    for key in ("region_controller_ms_per_video_frame", "region_controller_ms_per_hand_photo"):
        assert isinstance(res[key], float) and res[key] > 0, key
    # agents report their own peak RSS (VmHWM): the compiled agent, a few MB (issue 14: <= 15), not the parent's
    assert all(1 < run["rss_mb_per_agent"] <= 15 for run in res["runs"])
