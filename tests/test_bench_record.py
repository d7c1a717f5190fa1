"""The bench's record (fluidswarm/orchestration/bench_record.py): results.json read and written back unchanged,
every field checked on reading (one error naming the key), the key=value lines printed from the record."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

import pytest

from fluidswarm.bench import print_lines
from fluidswarm.orchestration.bench_record import BenchRecord, BenchRecordError, FailedRun, Formation, LockstepRun

RESULTS = Path(__file__).resolve().parent.parent / "docs" / "benchmarks" / "results.json"


@pytest.fixture(scope="module")
def results() -> dict:
    return json.loads(RESULTS.read_text())


def test_the_committed_results_json_round_trips_byte_for_byte():
    record = BenchRecord.load(RESULTS)
    assert record.to_json(indent=2) + "\n" == RESULTS.read_text()
    assert all(isinstance(r, LockstepRun) for r in record.runs) and 1000 in [r.n for r in record.runs]
    assert all(isinstance(f, Formation) for f in record.gesture_imitation_formation.values())
    assert json.loads(record.to_json()) == json.loads(RESULTS.read_text())  # the one-line form of --json


def test_a_failed_run_and_missing_perception_are_kept(results):
    d = copy.deepcopy(results)
    d["runs"][-1] = {"n": 1000, "steps": 300, "error": "1000 agents not ready after 180 s"}
    d["perception_error"] = "../shared/datasets/sign-language-digits missing"
    d["eigen_training_seconds"] = None
    d["gesture_imitation_formation"]["cylindrical"] = None
    record = BenchRecord.from_dict(d)
    assert record.runs[-1] == FailedRun(1000, 300, "1000 agents not ready after 180 s")
    assert record.as_dict() == d


@pytest.mark.parametrize(
    "edit,key",
    [
        (lambda d: d["runs"][1].update(steps_per_second="fast"), "runs[1].steps_per_second"),
        (lambda d: d["runs"][0].pop("n"), "runs[0].n"),
        (lambda d: d["runs"][0].update(agents_finished=True), "runs[0].agents_finished"),
        (lambda d: d.update(runs={}), "runs"),
        (lambda d: d["machine"].update(cores="two"), "machine.cores"),
        (lambda d: d.pop("gesture_agents"), "gesture_agents"),
        (lambda d: d["gesture_imitation_seconds"].update(scissor="slow"), "gesture_imitation_seconds.scissor"),
        (
            lambda d: d["gesture_imitation_formation"]["pinching"].update(settled="yes"),
            "gesture_imitation_formation.pinching.settled",
        ),
        (lambda d: d.update(quick=1), "quick"),
    ],
)
def test_a_bad_record_is_refused_naming_the_key(results, edit, key):
    d = copy.deepcopy(results)
    edit(d)
    with pytest.raises(BenchRecordError, match=re.escape(f"key '{key}'")):
        BenchRecord.from_dict(d)


def test_a_file_that_is_not_a_record_names_the_file(tmp_path):
    bad = tmp_path / "results.json"
    bad.write_text("{not json")
    with pytest.raises(BenchRecordError, match="results.json: not JSON"):
        BenchRecord.load(bad)
    bad.write_text("[]")
    with pytest.raises(BenchRecordError, match="results.json: expected a JSON object"):
        BenchRecord.load(bad)


def test_the_printed_lines_come_from_the_record(capsys):
    record = BenchRecord.load(RESULTS)
    print_lines(record, RESULTS)
    lines = dict(line.split("=", 1) for line in capsys.readouterr().out.splitlines())
    assert float(lines["step_time_exponent"]) == record.step_time_exponent
    for g, v in record.gesture_imitation_seconds.items():
        assert float(lines[f"gesture_imitation_seconds[{g}]"]) == v
    assert float(lines["eigen_training_seconds"]) == record.eigen_training_seconds
    assert float(lines["region_controller_ms_per_video_frame"]) == record.region_controller_ms_per_video_frame
    assert lines["results"] == str(RESULTS)
