"""RunWriter writes a Foxglove-ready, indexed, compressed MCAP that holds every alive agent at every step,
also when agents die mid-run and when the recorder is interrupted (issue 6)."""

import base64
import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from coordinator.control.geometry import ImageToDomain
from fluidswarm.recording.messages import body_entities
from fluidswarm.recording.reader import check, load_run
from fluidswarm.recording.synthetic import write_synthetic_run
from fluidswarm.recording.writer import RunWriter

FOXGLOVE = {"foxglove.PointCloud", "foxglove.SceneUpdate", "foxglove.Log", "foxglove.CompressedImage"}


def _states_by_step(path: Path) -> tuple[dict[int, set[int]], dict]:
    """Read the state topic with the mcap library alone: step -> ids present; also schema per topic."""
    steps, schemas = {}, {}
    with open(path, "rb") as fh:
        reader = make_reader(fh)
        for schema, channel, message in reader.iter_messages():
            schemas[channel.topic] = (schema.name, schema.encoding, channel.message_encoding)
            if channel.topic.endswith("/state"):
                msg = json.loads(message.data)
                raw = np.frombuffer(base64.b64decode(msg["data"]), dtype="<u4").reshape(-1, msg["point_stride"] // 4)
                field = {f["name"]: f for f in msg["fields"]}
                assert field["id"]["offset"] == 0 and field["id"]["type"] == 5  # UINT32
                steps[msg["fluidswarm"]["step"]] = set(raw[:, 0].tolist())
                assert message.sequence == msg["fluidswarm"]["step"]
    return steps, schemas


def test_file_is_foxglove_ready_complete_and_holds_the_scenario(tmp_path):
    path = tmp_path / "demo.mcap"
    with RunWriter(path, {"run": "demo", "scenario": {"name": "wave", "agents": 12}, "seed": 7}) as w:
        w.write_image(0.0, b"\xff\xd8\xff\xe0fakejpeg", frame_id="camera")
        w.write_command(0.0, '{"gesture": "wave"}')
        w.write_scene(0.0, waypoints=[(1.0, 1.0, 0.2)], ellipses=[(1.0, 1.0, 0.5, 0.2, 10.0)])
        w.write_event(0.0, "info", "coordinator", "run started")
        for step in range(20):
            n = 12
            w.write_states(
                step,
                step * 0.1,
                np.arange(n),
                np.random.rand(n, 2),
                np.zeros((n, 2)),
                np.ones(n),
                np.zeros(n),
                np.arange(n) % 2,
            )

    steps, schemas = _states_by_step(path)
    assert sorted(steps) == list(range(20))
    assert all(ids == set(range(12)) for ids in steps.values())
    assert {name for name, _, _ in schemas.values()} >= FOXGLOVE
    assert {(enc, msg_enc) for _, enc, msg_enc in schemas.values()} == {("jsonschema", "json")}
    assert set(schemas) == {
        f"fluidswarm/demo/{leaf}" for leaf in ("state", "scene", "command", "perception/image", "event")
    }

    with open(path, "rb") as fh:
        reader = make_reader(fh)
        summary = reader.get_summary()
        assert summary.chunk_indexes and all(ci.compression == "zstd" for ci in summary.chunk_indexes)
        assert all(ci.message_index_offsets for ci in summary.chunk_indexes)  # indexed
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
    assert json.loads(meta["run"]["scenario"]) == {"name": "wave", "agents": 12}
    assert meta["run"]["run"] == "demo" and meta["run"]["seed"] == "7" and meta["run"]["code_version"]
    assert check(path) == (True, 20, 0)


def test_states_round_trip_exactly_in_float64(tmp_path):
    rng = np.random.default_rng(3)
    n = 40
    ids = rng.permutation(1000)[:n]
    pos, vel = rng.normal(size=(n, 2)), rng.normal(size=(n, 2))
    rho, p, cls = rng.normal(1000, 1, n), rng.normal(size=n), rng.integers(0, 5, n)
    alive = rng.random(n) > 0.3
    with RunWriter(tmp_path / "exact.mcap", {"scenario": "exact"}) as w:
        w.write_states(5, 0.25, ids, pos, vel, rho, p, cls, alive=alive)
    run = load_run(tmp_path / "exact.mcap")
    (f,) = run.frames
    assert (f.step, f.t) == (5, 0.25)
    np.testing.assert_array_equal(f.ids, ids[alive])
    np.testing.assert_array_equal(f.positions, pos[alive])
    np.testing.assert_array_equal(f.velocities, vel[alive])
    np.testing.assert_array_equal(f.density, rho[alive])
    np.testing.assert_array_equal(f.pressure, p[alive])
    np.testing.assert_array_equal(f.class_ids, cls[alive])
    assert run.name == "exact" and run.metadata["scenario"] == "exact"


def test_everything_else_round_trips(tmp_path):
    mask = np.zeros((30, 40), bool)
    mask[5:20, 10:30] = True
    tf = ImageToDomain.fit(mask.shape, (0.0, 2.0, 0.0, 1.0))
    with RunWriter(tmp_path / "all.mcap", {"run": "r1"}) as w:
        w.write_target(0.5, mask, tf)
        w.write_scene(1.0, waypoints=[(0.1, 0.2, 0.3)], ellipses=[(1, 2, 3, 4, 45)])
        w.write_command(1.5, '{"gesture": "fist", "scale": 1.5}')
        w.write_image(2.0, b"\x00\x01\x02binary", frame_id="cam0")
        w.write_event(2.5, "error", "agent/4", "died", kind="died", agent=4, step=12)
    run = load_run(tmp_path / "all.mcap")
    np.testing.assert_array_equal(run.target.mask, mask)
    assert run.target.transform == tf and run.target.t == 0.5
    assert run.scenes[0].waypoints == [(0.1, 0.2, 0.3)] and run.scenes[0].ellipses == [(1, 2, 3, 4, 45)]
    assert run.commands == [(1.5, {"gesture": "fist", "scale": 1.5})]
    assert run.images[0].data == b"\x00\x01\x02binary" and run.images[0].frame_id == "cam0"
    ev = run.events[0]
    assert (ev.level, ev.name, ev.message, ev.kind, ev.agent, ev.step) == (4, "agent/4", "died", "died", 4, 12)


def test_a_run_where_a_fifth_of_the_agents_die_is_complete(tmp_path):
    kill = {3: 10, 7: 11, 12: 25, 18: 30, 0: 39, 9: 2}  # 6 of 30 agents
    path = tmp_path / "killed.mcap"
    write_synthetic_run(path, steps=40, n=30, kill=kill)
    steps, _ = _states_by_step(path)
    for agent, first_missing in kill.items():
        assert all(agent in steps[s] for s in range(first_missing))
        assert all(agent not in steps[s] for s in range(first_missing, 40))
    assert check(path) == (True, 40, 0)


def test_lost_states_and_lost_steps_are_counted(tmp_path):
    path = tmp_path / "lossy.mcap"
    n = 5
    with RunWriter(path, {"run": "lossy", "agent_ids": list(range(6))}) as w:  # agent 5 never reports
        w.write_event(0.0, "info", "agent/4", "died", kind="died", agent=4)  # at t=0.2 below
        for step in (0, 1, 2, 4):  # step 3 lost entirely
            ids = np.arange(n) if step != 1 else np.arange(n - 1)  # agent 4 missing at step 1
            w.write_states(
                step,
                step * 0.1,
                ids,
                np.zeros((len(ids), 2)),
                np.zeros((len(ids), 2)),
                np.ones(len(ids)),
                np.zeros(len(ids)),
                np.zeros(len(ids), int),
            )
    # agent 4's death at t=0 means it is not expected anywhere; recorded extra states are not "missing".
    # missing: agent 5 at steps 0..4 (5) + step 3 for agents 0..3 (4) = 9
    assert check(path) == (False, 4, 9)


def test_time_based_death_event(tmp_path):
    path = tmp_path / "died.mcap"
    with RunWriter(path, {"run": "died"}) as w:
        for step in range(6):
            t = step * 0.1
            if step == 3:
                w.write_event(t, "warning", "agent/1", "died", kind="died", agent=1)
            ids = np.array([0, 1]) if step < 2 else np.array([0])  # agent 1's last state is step 1: lost step 2
            w.write_states(
                step,
                t,
                ids,
                np.zeros((len(ids), 2)),
                np.zeros((len(ids), 2)),
                np.ones(len(ids)),
                np.zeros(len(ids)),
                np.zeros(len(ids), int),
            )
    assert check(path) == (False, 6, 1)


def test_closed_early_file_is_readable_and_complete(tmp_path):
    path = tmp_path / "early.mcap"
    w = write_synthetic_run(path, steps=100, n=20, stop_after=13)
    assert w.closed
    w.close()  # idempotent
    assert w.write_states(99, 9.9, [0], [[0, 0]], [[0, 0]], [1], [0], [0]) is False  # dropped after close
    assert check(path) == (True, 13, 0)


def test_interrupt_in_the_middle_of_writing_leaves_a_finished_file(tmp_path):
    """KeyboardInterrupt raised by a timer signal at arbitrary points while writing, as Ctrl-C would."""
    for attempt in range(3):
        path = tmp_path / f"interrupted{attempt}.mcap"
        written = 0
        old = signal.signal(signal.SIGALRM, _raise_interrupt)
        try:
            with RunWriter(path, {"run": "irq"}) as w:
                signal.setitimer(signal.ITIMER_REAL, 0.02 + 0.013 * attempt)
                n = 200
                for step in range(100_000):
                    w.write_states(
                        step,
                        step * 0.01,
                        np.arange(n),
                        np.random.rand(n, 2),
                        np.zeros((n, 2)),
                        np.ones(n),
                        np.zeros(n),
                        np.arange(n) % 3,
                    )
                    written = step + 1
        except KeyboardInterrupt:
            pass
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, old)
        assert w.closed
        complete, steps, missing = check(path)
        assert complete and missing == 0 and steps in (written, written + 1) and steps > 0


def _raise_interrupt(signum, frame):
    raise KeyboardInterrupt


_RECORDER = textwrap.dedent("""
    import signal, sys
    import numpy as np
    from fluidswarm.recording.writer import RunWriter
    w = RunWriter(sys.argv[1], {"run": "sig", "scenario": "sigterm"})
    def close_and_exit(signum, frame):
        w.close()
        sys.exit(0)
    def exit_only(signum, frame):  # forgets close(): the writer still finishes the file at exit
        sys.exit(0)
    handler = {"close": close_and_exit, "exit": exit_only, "default": None}[sys.argv[2]]
    if handler:
        signal.signal(signal.SIGTERM, handler)
        signal.signal(signal.SIGINT, handler)
    n, step = 50, 0
    while True:
        w.write_states(step, step * 0.01, np.arange(n), np.random.rand(n, 2), np.zeros((n, 2)), np.ones(n),
                       np.zeros(n), np.arange(n) % 3)
        step += 1
        if step == 30:
            print("ready", flush=True)
""")


@pytest.mark.parametrize(
    "sig,handler,rc",
    [
        (signal.SIGTERM, "close", 0),
        (signal.SIGINT, "close", 0),
        (signal.SIGTERM, "exit", 0),  # no close() at all
        (signal.SIGINT, "default", -signal.SIGINT),  # uncaught KeyboardInterrupt, no close()
    ],
)
@pytest.mark.swarm
def test_recorder_process_stopped_by_signal_leaves_a_finished_file(tmp_path, sig, handler, rc):
    path = tmp_path / "sig.mcap"
    proc = subprocess.Popen(
        [sys.executable, "-c", _RECORDER, str(path), handler],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        assert proc.stdout.readline().strip() == "ready"
        proc.send_signal(sig)
        assert proc.wait(timeout=20) == rc
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    complete, steps, missing = check(path)
    assert complete and steps >= 30 and missing == 0
    assert load_run(path).metadata["scenario"] == "sigterm"


@pytest.mark.parametrize(
    "bad",
    [
        dict(positions=np.zeros((3, 3))),
        dict(ids=np.array([0, 0, 1])),
        dict(ids=np.array([-1, 0, 1])),
        dict(alive=np.array([1, 0, 1])),
        dict(class_ids=np.array([0.5, 1, 2])),
        dict(t=-1.0),
        dict(t=float("nan")),
    ],
)
def test_write_states_rejects_bad_input(tmp_path, bad):
    args = dict(
        step=0,
        t=0.0,
        ids=np.arange(3),
        positions=np.zeros((3, 2)),
        velocities=np.zeros((3, 2)),
        density=np.ones(3),
        pressure=np.zeros(3),
        class_ids=np.zeros(3, int),
        alive=None,
    )
    args.update(bad)
    with RunWriter(tmp_path / "bad.mcap", {}) as w, pytest.raises(ValueError):
        w.write_states(**args)


def test_rejects_bad_run_names_and_commands(tmp_path):
    with pytest.raises(ValueError, match="Zenoh"):
        RunWriter(tmp_path / "x.mcap", {"run": "a/b"})
    with RunWriter(tmp_path / "y.mcap", {}) as w:
        with pytest.raises(ValueError, match="JSON"):
            w.write_command(0.0, "not json")
        with pytest.raises(ValueError, match="level"):
            w.write_event(0.0, "loud", "x", "y")
    assert not os.path.exists(tmp_path / "x.mcap")


def test_bodies_are_discs_of_their_radius_with_an_arrow_along_each_heading(tmp_path):
    (e,) = body_entities(1.5, [[1.0, 2.0], [3.0, 4.0]], [0.0, np.pi / 2], 0.2)["entities"]
    assert e["id"] == "bodies" and e["timestamp"] == {"sec": 1, "nsec": 500_000_000}
    assert [c["size"]["x"] for c in e["cylinders"]] == [0.4, 0.4]
    assert [(c["pose"]["position"]["x"], c["pose"]["position"]["y"]) for c in e["cylinders"]] == [(1, 2), (3, 4)]
    quats = [a["pose"]["orientation"] for a in e["arrows"]]
    assert quats[0] == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}  # along +x
    assert quats[1]["z"] == pytest.approx(np.sqrt(0.5)) and quats[1]["w"] == pytest.approx(np.sqrt(0.5))  # +y
    assert body_entities(0.0, [[1.0, 2.0]], None, 0.2)["entities"][0]["arrows"] == []  # no heading: no arrow
    for bad in ([[np.nan, 0.0]], [1.0, 2.0]):
        with pytest.raises(ValueError, match="body centres"):
            body_entities(0.0, bad, None, 0.2)
    with pytest.raises(ValueError, match="body radius"):
        body_entities(0.0, [[1.0, 2.0]], None, 0.0)
    with pytest.raises(ValueError, match="headings"):
        body_entities(0.0, [[1.0, 2.0]], [0.0, 1.0], 0.2)
    # in a file beside the states, the reader takes the states and leaves the drawing
    path = tmp_path / "bodies.mcap"
    with RunWriter(path, {"run": "b"}) as w:
        w.write_states(
            0,
            0.0,
            np.arange(2),
            np.array([[1.0, 2.0], [3.0, 4.0]]),
            np.zeros((2, 2)),
            np.ones(2),
            np.zeros(2),
            np.zeros(2, int),
        )
        w.write_bodies(0.0, [[1.0, 2.0], [3.0, 4.0]], [0.0, 1.0], 0.2)
    run = load_run(path, images=False)
    assert len(run.frames) == 1 and run.scenes == []
