"""`fluidswarm replay RUN.mcap --ros2-bag DIR`: the bag read back by two independent ROS 2 readers (rosbags' rosbag2
reader, mcap-ros2-support's decoder): every topic, count and value equals the MCAP's."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore
from ruamel.yaml import YAML

from fluidswarm.cli import main
from fluidswarm.recording.reader import Recording, load_run
from fluidswarm.recording.ros2_messages import outline_loops
from fluidswarm.recording.synthetic import write_synthetic_run

FLUIDSWARM = [sys.executable, "-m", "fluidswarm"]
V_SIGN = Path(__file__).resolve().parents[1] / "scenarios" / "inputs" / "digit2_IMG_1140.JPG"
TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
LEVELS = {0: "unknown", 1: "debug", 2: "info", 3: "warning", 4: "error", 5: "fatal"}


def _bag(mcap: Path, out: Path, capsys) -> tuple[int, str, str]:
    """`fluidswarm replay MCAP --ros2-bag OUT` in this process: (exit code, stdout, stderr)."""
    code = main(["replay", str(mcap), "--ros2-bag", str(out)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _expected_counts(run: Recording) -> dict[str, int]:
    counts = {t: len(run.frames) for t in ("/clock", "/fluidswarm/poses", "/tf", "/fluidswarm/particles")}
    counts["/fluidswarm/target"] = len(run.targets) or (1 if run.metadata.get("obstacles") else 0)
    counts["/fluidswarm/command"] = len(run.commands)
    counts["/fluidswarm/events"] = len(run.events)
    counts["/fluidswarm/image"] = len(run.images)
    return {k: v for k, v in counts.items() if v}


def _stamp_ns(msg) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def check_bag(mcap: Path, bag: Path) -> None:
    """The bag at `bag` holds the run of `mcap`, as both readers see it."""
    run = load_run(mcap)
    want = _expected_counts(run)
    info = YAML(typ="safe").load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["version"] == 9 and info["storage_identifier"] == "mcap"
    assert {t["topic_metadata"]["name"]: t["message_count"] for t in info["topics_with_message_count"]} == want
    for t in info["topics_with_message_count"]:
        meta = t["topic_metadata"]
        assert meta["type_description_hash"] == TYPESTORE.hash_rihs01(meta["type"])
        assert meta["serialization_format"] == "cdr" and meta["offered_qos_profiles"][0]["reliability"] == "reliable"
    (file,) = bag.glob("*.mcap")
    assert info["relative_file_paths"] == [file.name] == [f"{bag.name}_0.mcap"]

    # the MCAP records rosbag2 writes: profile, schemas, channel metadata, the rosbag2 metadata record
    with open(file, "rb") as f:
        reader = make_reader(f)
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert summary is not None
        for ch in summary.channels.values():
            schema = summary.schemas[ch.schema_id]
            assert ch.message_encoding == "cdr" and schema.encoding == "ros2msg"
            assert ch.metadata["topic_type_hash"] == TYPESTORE.hash_rihs01(schema.name)
            qos = YAML(typ="safe").load(ch.metadata["offered_qos_profiles"])
            assert qos[0]["history"] == "keep_last" and qos[0]["depth"] >= 1
        records = {r.name: r.metadata for r in reader.iter_metadata()}
        assert YAML(typ="safe").load(records["rosbag2"]["serialized_metadata"])["message_count"] == sum(want.values())

    # rosbags' rosbag2 reader, with its own CDR decoder
    got: dict[str, list] = {}
    with Reader(bag) as reader:
        assert {c.topic: c.digest for c in reader.connections} == {
            c.topic: TYPESTORE.hash_rihs01(c.msgtype) for c in reader.connections
        }
        for connection, ns, raw in reader.messages():
            got.setdefault(connection.topic, []).append((ns, TYPESTORE.deserialize_cdr(raw, connection.msgtype)))
    assert {k: len(v) for k, v in got.items()} == want

    for (ns, poses), (_, tf), (_, cloud), (_, clock), frame in zip(
        got["/fluidswarm/poses"], got["/tf"], got["/fluidswarm/particles"], got["/clock"], run.frames, strict=True
    ):
        order = np.argsort(frame.ids)
        t_ns = round(frame.t * 1e9)
        assert ns == t_ns == _stamp_ns(poses) == clock.clock.sec * 1_000_000_000 + clock.clock.nanosec
        xy = np.array([[p.position.x, p.position.y] for p in poses.poses])
        assert np.array_equal(xy, frame.positions[order])  # the MCAP's float64, bit for bit
        yaw = np.array([2 * np.arctan2(p.orientation.z, p.orientation.w) for p in poses.poses])
        v = frame.velocities[order]
        moving = np.hypot(v[:, 0], v[:, 1]) > 0
        assert np.allclose(np.angle(np.exp(1j * (yaw[moving] - np.arctan2(v[moving, 1], v[moving, 0])))), 0, atol=1e-9)
        assert [t.child_frame_id for t in tf.transforms] == [f"robot_{i}/base_link" for i in np.sort(frame.ids)]
        assert np.array_equal([[t.transform.translation.x, t.transform.translation.y] for t in tf.transforms], xy)
        rows = np.frombuffer(
            cloud.data.tobytes(),
            dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("id", "<u4"), ("density", "<f4"), ("pressure", "<f4")],
        )
        assert np.array_equal(rows["id"], np.sort(frame.ids))
        assert np.array_equal(rows["x"], frame.positions[order, 0].astype(np.float32))
        assert np.array_equal(rows["density"], frame.density[order].astype(np.float32))
        assert np.array_equal(rows["pressure"], frame.pressure[order].astype(np.float32))
    for (ns, msg), (t, command) in zip(got.get("/fluidswarm/command", []), run.commands, strict=True):
        assert ns == round(t * 1e9) and json.loads(msg.data) == command
    for (ns, msg), e in zip(got["/fluidswarm/events"], run.events, strict=True):
        assert ns == round(e.t * 1e9)
        assert json.loads(msg.data) == {
            "level": LEVELS[e.level],
            "name": e.name,
            "message": e.message,
            "kind": e.kind,
            "agent": e.agent,
            "step": e.step,
        }
    for (ns, msg), image in zip(got.get("/fluidswarm/image", []), run.images, strict=True):
        assert ns == round(image.t * 1e9) and msg.format == image.format and msg.data.tobytes() == image.data
    for (ns, msg), target in zip(got.get("/fluidswarm/target", []), run.targets, strict=True):
        outlines = [mk for mk in msg.markers if mk.ns == "target"]
        loops = outline_loops(target.mask, target.transform)
        assert ns == round(target.t * 1e9) and len(outlines) == len(loops)
        for mk, loop in zip(outlines, loops, strict=True):
            assert np.array_equal([[p.x, p.y] for p in mk.points], loop)

    # mcap-ros2-support: an independent CDR decoder, from the schemas in the file alone
    decoded: dict[str, list] = {}
    with open(file, "rb") as f:
        for _, channel, _, msg in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            decoded.setdefault(channel.topic, []).append(msg)
    assert {k: len(v) for k, v in decoded.items()} == want
    for poses, frame in zip(decoded["/fluidswarm/poses"], run.frames, strict=True):
        xy = np.array([[p.position.x, p.position.y] for p in poses.poses])
        assert np.array_equal(xy, frame.positions[np.argsort(frame.ids)])
    assert [json.loads(s.data)["kind"] for s in decoded["/fluidswarm/events"]] == [e.kind for e in run.events]


def test_a_synthetic_run_as_a_bag_equals_its_mcap(tmp_path, capsys):
    mcap = tmp_path / "syn.mcap"
    write_synthetic_run(mcap, steps=40, n=25, kill={3: 20})
    code, out, err = _bag(mcap, tmp_path / "syn_bag", capsys)
    assert code == 0, err
    assert "wrote" in out and "/fluidswarm/poses 40" in out
    check_bag(mcap, tmp_path / "syn_bag")


def test_a_bag_directory_that_exists_or_cannot_be_written_is_one_line(tmp_path, capsys):
    mcap = tmp_path / "syn.mcap"
    write_synthetic_run(mcap, steps=5, n=5)
    (tmp_path / "taken").mkdir()
    cases = {
        tmp_path / "taken": "it exists",
        tmp_path / "no" / "bag": "no such directory",
        Path("/sys/fluidswarm-bag"): "cannot be written",  # sysfs takes no new directory, not even root's
    }
    for out, why in cases.items():
        code, stdout, stderr = _bag(mcap, out, capsys)
        assert code != 0 and stdout == ""
        assert stderr.count("\n") == 1 and why in stderr and str(out) in stderr, stderr
    assert not (tmp_path / "no").exists()
    # on a run command: said before anything starts
    assert main(["imitate", str(V_SIGN), "--out", str(tmp_path / "o"), "--ros2-bag", str(tmp_path / "taken")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "it exists" in err and not (tmp_path / "o").exists(), err


@pytest.mark.swarm
def test_the_bag_of_a_60_agent_unicycle_imitation_equals_its_mcap(tmp_path, capsys):
    """The bag written by the run itself (`imitate --ros2-bag DIR`), and again by `replay --ros2-bag`: the same."""
    done = subprocess.run(
        FLUIDSWARM
        + ["imitate", str(V_SIGN), "--agents", "60", "--steps", "300", "--robot", "unicycle", "--out", str(tmp_path)]
        + ["--json", "--ros2-bag", str(tmp_path / "bag")],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert json.loads(done.stdout)["finished"] == 60
    assert f"ros2: wrote the bag {tmp_path / 'bag'}" in done.stderr
    mcap = tmp_path / "digit2_IMG_1140.mcap"
    check_bag(mcap, tmp_path / "bag")
    code, _, err = _bag(mcap, tmp_path / "again", capsys)
    assert code == 0, err
    again = (tmp_path / "again" / "metadata.yaml").read_text().replace("again_0.mcap", "bag_0.mcap")
    assert again == (tmp_path / "bag" / "metadata.yaml").read_text()
    assert len(load_run(mcap).frames) >= 250
