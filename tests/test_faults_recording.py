"""A record survives its writer (issue 36, item 2): chunks reach the file on time, a file without its footer is
read up to its last whole record, and `replay --recover` rewrites it finished."""

from __future__ import annotations

import shutil
import time

import numpy as np
import pytest

from agent.protocol.errors import UserError
from fluidswarm.cli import main
from fluidswarm.recording.reader import completeness, load_run
from fluidswarm.recording.recover import after_recorder, salvage
from fluidswarm.recording.writer import RunWriter
from swarmhost.helpers import describe_exit


def write_steps(w: RunWriter, steps, n: int = 5) -> None:
    for s in steps:
        pos = np.column_stack([np.arange(n, dtype=float), np.full(n, float(s))])
        w.write_states(s, s * 0.01, np.arange(n), pos, np.zeros((n, 2)), np.ones(n), np.zeros(n), np.zeros(n, int))


def snapshot_after_kill(tmp_path, flush_seconds: float = 0.4, wait: float = 0.7):
    """Write steps 0-9 and 10-19, each followed by the flush period, then 20-24, and copy the file as it is:
    what a SIGKILL of the writer then would leave on disk (everything flushed reached the kernel)."""
    path, dead = tmp_path / "run.mcap", tmp_path / "dead.mcap"
    w = RunWriter(path, {"run": "r"}, flush_seconds=flush_seconds)
    try:
        for part in (range(10), range(10, 20)):
            write_steps(w, part)
            time.sleep(wait)
        write_steps(w, range(20, 25))  # in the chunk in progress: lost with the writer
        shutil.copyfile(path, dead)
    finally:
        w.close()
    return path, dead


def test_a_killed_writer_keeps_every_step_older_than_its_flush_period(tmp_path):
    _, dead = snapshot_after_kill(tmp_path)
    run = load_run(dead)
    assert run.truncated and run.metadata["run"] == "r"
    assert run.steps.tolist() == list(range(20))  # the flushed ones, all, and nothing invented
    c = completeness(run)
    assert (c.complete, c.steps, c.missing_states) == (True, 20, 0)


def test_a_writer_killed_at_once_leaves_an_mcap_header_and_its_metadata(tmp_path):
    path, dead = tmp_path / "run.mcap", tmp_path / "dead.mcap"
    w = RunWriter(path, {"run": "r", "scenario": "x"})
    shutil.copyfile(path, dead)
    w.close()
    run = load_run(dead)
    assert run.truncated and run.metadata["scenario"] == "x" and run.frames == []


def test_a_file_cut_inside_a_record_keeps_the_records_before_it(tmp_path):
    _, dead = snapshot_after_kill(tmp_path)
    whole = salvage(dead)
    assert whole.chunks_kept == 2
    data = dead.read_bytes()
    dead.write_bytes(data[: len(data) - len(data) // 4])  # the second chunk loses its end
    cut = salvage(dead)
    assert cut.why and cut.bytes_kept < whole.bytes_kept and cut.chunks_kept == 1
    assert load_run(dead).steps.tolist() == list(range(10))


def test_replay_recover_rewrites_the_file_finished_and_says_what_it_kept(tmp_path, capsys):
    _, dead = snapshot_after_kill(tmp_path)
    assert main(["replay", str(dead), "--check"]) == 0
    out = capsys.readouterr().out
    assert "steps=20" in out and "truncated=true" in out and "bytes_dropped=" in out
    assert main(["replay", str(dead), "--recover"]) == 0
    out = capsys.readouterr().out
    assert "recovered=true" in out and "steps=20" in out and "chunks_dropped=0" in out
    run = load_run(dead)
    assert not run.truncated and run.steps.tolist() == list(range(20))
    assert main(["replay", str(dead), "--recover"]) == 0  # finished now: left as it is
    assert "recovered=false" in capsys.readouterr().out


def test_an_empty_or_foreign_file_is_one_line_naming_it(tmp_path, capsys):
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    with pytest.raises(UserError, match="empty.mcap: not an MCAP file"):
        load_run(empty)
    assert main(["replay", str(empty), "--recover"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "empty.mcap" in err[0]


def test_after_a_recorder_killed_before_its_footer_the_run_rewrites_the_file_finished_and_names_the_kill(tmp_path):
    path, dead = snapshot_after_kill(tmp_path)
    assert after_recorder(path, 0) is None  # the usual end: nothing to say, the file untouched
    note = after_recorder(dead, -9, describe_exit(-9), "fluidswarm record: stuck")
    assert note is not None and "was killed by signal 9 (SIGKILL) (fluidswarm record: stuck) before finishing" in note
    assert str(dead) in note and "rewritten finished" in note and "\n" not in note
    run = load_run(dead)
    assert not run.truncated and run.steps.tolist() == list(range(20))
    note = after_recorder(
        path, 1, describe_exit(1)
    )  # a recorder that failed after writing its footer: named, the file left
    assert note is not None and "exited with code 1 after finishing" in note
    assert after_recorder(tmp_path / "never.mcap", -9) is None  # no file, nothing to rewrite
