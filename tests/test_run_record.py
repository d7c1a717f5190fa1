"""The typed records of a run, without processes: an agent's final report is decoded and validated once
(agent/protocol/report.py), and a run's record (fluidswarm/orchestration/run.py) prints as key=value lines and as one
JSON object with the same figures."""

from __future__ import annotations

import json
import math

import pytest

from agent.protocol.report import FinalReport, Status, decode_report
from coordinator.control.fidelity import Fidelity
from fluidswarm.imitate_commands import print_lines
from fluidswarm.orchestration.run import RunRecord
from fluidswarm.scenario_commands import print_summary

# the fields the native agent sends (agent/native/src/final_report.rs), a follower's included
NATIVE = {
    "v": 1,
    "id": 7,
    "status": "done",
    "steps": 120,
    "state": [1.5, -2.0, 0.1, 0.0, 1.0, 0.5, 0, 0, 0, 0],
    "msgs_received": 900,
    "neighbours": 700,
    "rejected": {"length": 2, "command_replay": 1},
    "timeouts": 0,
    "deaths_seen": 1,
    "stale": 3,
    "dropped_out": 0,
    "lost": 0,
    "t_start": 1.79e9,
    "t_end": 1.79e9 + 2.5,
    "session_opened_at": 1.79e9 - 0.3,
    "rss_mb": 3.2,
    "cpu_seconds": 0.41,
    "cpu_seconds_at_start": None,
    "agent": "native",
    "commands_accepted": 2,
    "particle_class": 1,
    "waypoint_index": -1,
    "command_seq": 2,
    "first_command_at": None,
    "a_field_from_a_newer_agent": [1, 2],
}


def encoded(**changes) -> bytes:
    msg = {**NATIVE, **changes}
    return json.dumps({k: v for k, v in msg.items() if v is not ...}).encode()


def test_a_native_report_decodes_into_typed_fields():
    r = decode_report(encoded())
    assert isinstance(r, FinalReport) and r.done and r.status is Status.DONE
    assert (r.id, r.steps, r.state[:2], r.rejected) == (7, 120, (1.5, -2.0), {"length": 2, "command_replay": 1})
    assert (r.particle_class, r.command_seq, r.cpu_seconds_at_start, r.t_end - r.t_start) == (1, 2, None, 2.5)
    assert decode_report(encoded(status="fell_behind")).status is Status.FELL_BEHIND
    # a plain (non-following) agent sends no command fields: their defaults
    plain = {
        k: v
        for k, v in NATIVE.items()
        if k not in ("commands_accepted", "particle_class", "waypoint_index", "command_seq", "first_command_at")
    }
    assert decode_report(json.dumps(plain).encode()).particle_class == 0


@pytest.mark.parametrize(
    "bad",
    [
        encoded(state=[math.nan] + NATIVE["state"][1:]),
        encoded(state=[1e300] + NATIVE["state"][1:]),
        encoded(state=NATIVE["state"][:3]),
        encoded(status="finished"),
        encoded(id=True),
        encoded(id=-1),
        encoded(steps=-5),
        encoded(steps=1.5),
        encoded(rejected={"length": "many"}),
        encoded(rejected=[1]),
        encoded(msgs_received=-1),
        encoded(t_end="later"),
        encoded(v=2),
        encoded(state=...),
        b"[1, 2, 3]",
        b"not json",
        b"{" + b" " * 70_000 + b"}",
    ],
)
def test_a_malformed_report_is_refused(bad):
    assert decode_report(bad) is None


def record() -> RunRecord:
    return RunRecord(
        name="hand_x",
        kind="imitation",
        agents=30,
        steps=700,
        sync="async",
        finished=28,
        steps_per_second=41.25,
        longest_stall_seconds=1.7,
        neighbour_timeout_seconds=1.5,
        failures=["step 100: SIGKILL agents [3, 8]"],
        failures_killed=2,
        mcap="out/x/hand_x.mcap",
        pictures=["out/x/hand_x_formation.png", "out/x/formation.gif"],
        fidelity=Fidelity(iou=0.8125, inside=0.9375, coverage=0.75, nn_cv=0.1875),
        formation_seconds=6.5,
        formation_wall_seconds=9.25,
        formation_settled=True,
        figures={"finished_share": 1.0, "mcap_complete": True, "mcap_missing_states": 0, "fidelity_ratio": math.inf},
        passed=False,
        why=["fidelity_ratio inf < 0.8"],
        finals={7: decode_report(encoded())},
    )


def lines(text: str) -> dict[str, str]:
    return dict(line.split("=", 1) for line in text.splitlines() if "=" in line and not line.startswith(" "))


def test_the_record_prints_as_one_json_object_without_the_reports():
    text = record().to_json()
    assert "\n" not in text
    d = json.loads(text)
    assert "finals" not in d and d["fidelity"] == {"iou": 0.8125, "inside": 0.9375, "coverage": 0.75, "nn_cv": 0.1875}
    assert d["figures"]["fidelity_ratio"] is None  # JSON has no infinity
    assert (d["finished"], d["failures"], d["figures"]["mcap_complete"], d["passed"]) == (
        28,
        ["step 100: SIGKILL agents [3, 8]"],
        True,
        False,
    )


def test_run_lines_and_json_say_the_same(capsys):
    print_summary(record())
    f = lines(capsys.readouterr().out)
    d = json.loads(record().to_json())
    assert (f["scenario"], f["sync"], f["agents"], f["finished"], f["steps"]) == ("hand_x", "async", "30", "28", "700")
    assert float(f["fidelity_iou"]) == d["fidelity"]["iou"] and float(f["nn_cv"]) == d["fidelity"]["nn_cv"]
    assert float(f["formation_seconds"]) == d["formation_seconds"]
    assert float(f["longest_stall_seconds"]) == d["longest_stall_seconds"]
    assert float(f["neighbour_timeout_seconds"]) == d["neighbour_timeout_seconds"]
    assert (f["mcap_complete"], f["failures_injected"], f["failures_survived"]) == ("true", "1", "true")
    assert f["mcap"] == d["mcap"] and f["passed"].startswith("false")


def test_imitate_lines_and_json_say_the_same(capsys):
    print_lines(record())
    f = lines(capsys.readouterr().out)
    d = json.loads(record().to_json())
    assert list(f) == [
        "fidelity_iou",
        "fidelity_inside",
        "fidelity_coverage",
        "nn_cv",
        "formation_seconds",
        "formation_wall_seconds",
        "formation_settled",
        "agents_finished",
        "robot",
        "steps_per_second",
        "mcap",
        "png",
    ]
    assert float(f["fidelity_inside"]) == d["fidelity"]["inside"] and f["formation_settled"] == "true"
    assert int(f["agents_finished"]) == d["finished"] and float(f["steps_per_second"]) == d["steps_per_second"]
    assert f["png"] == d["pictures"][0]
