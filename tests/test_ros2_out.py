"""`--ros2`: a run published in rmw_zenoh's format, read by an independent peer on a plain Zenoh router that stands
in for rmw_zenohd (tests/ros2_peer.py); an absent or lost ROS 2 router costs the run one line, nothing else."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from fluidswarm.recording.reader import check, load_run
from ros2link import rmw
from swarmhost.router_host import free_port
from tests.ros2_peer import TYPESTORE, Peer, decode, split_token, start_router, stop_router, unpack_attachment

FLUIDSWARM = [sys.executable, "-m", "fluidswarm"]
V_SIGN = Path(__file__).resolve().parents[1] / "scenarios" / "inputs" / "digit2_IMG_1140.JPG"
DOMAIN = 7
PUBLISHED = {
    "/fluidswarm/poses": "geometry_msgs/msg/PoseArray",
    "/fluidswarm/particles": "sensor_msgs/msg/PointCloud2",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/clock": "rosgraph_msgs/msg/Clock",
    "/fluidswarm/target": "visualization_msgs/msg/MarkerArray",
    "/fluidswarm/command": "std_msgs/msg/String",
    "/fluidswarm/events": "std_msgs/msg/String",
    "/fluidswarm/image": "sensor_msgs/msg/CompressedImage",
}


def _imitate(out: Path, router: str, steps: int, extra=(), env=None) -> subprocess.Popen:
    return subprocess.Popen(
        FLUIDSWARM
        + ["imitate", str(V_SIGN), "--agents", "16", "--steps", str(steps), "--out", str(out), "--json", "--ros2"]
        + ["--ros2-router", router, *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=dict(os.environ, ROS_DOMAIN_ID=str(DOMAIN), **(env or {})),
    )


def _stamp(msg) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


@pytest.mark.swarm
def test_a_ros2_peer_finds_the_node_and_reads_the_recorded_states_step_for_step(tmp_path):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = start_router(endpoint)
    peer = Peer(endpoint)
    run = _imitate(tmp_path, endpoint, 400)
    try:
        tokens = peer.wait_tokens(DOMAIN, 1 + len(PUBLISHED), 60)
        # rmw_zenoh's rules: one node token (NN) and a publisher token (MP) per topic, all of one session and node
        nodes = [t for t in tokens if t.kind == "NN"]
        pubs = {t.topic: t for t in tokens if t.kind == "MP"}
        assert len(nodes) == 1 and (nodes[0].node, nodes[0].namespace, nodes[0].enclave) == ("fluidswarm", "/", "/")
        assert set(pubs) == set(PUBLISHED)
        for topic, token in pubs.items():
            assert token.msgtype == PUBLISHED[topic]
            assert token.type_hash == TYPESTORE.hash_rihs01(PUBLISHED[topic])  # rosbags' RIHS01 of the standard type
            assert (token.zid, token.nid, token.node) == (nodes[0].zid, nodes[0].nid, "fluidswarm")
            assert rmw.parse_token(token.key) is not None and rmw.parse_token(token.key).key == token.data_key
        assert pubs["/fluidswarm/poses"].qos == "::,10:,:,:,,"  # reliable, volatile, keep last 10
        assert pubs["/fluidswarm/target"].qos == ":1:,1:,:,:,,"  # transient local, keep last 1 (latched)
        for topic, token in pubs.items():
            peer.subscribe(token.data_key, latched=token.qos.split(":")[1] == "1")
        out, err = run.communicate(timeout=300)
    finally:
        if run.poll() is None:
            run.kill()
            run.communicate()
        stop_router(router)
    assert run.returncode == 0, err[-2000:]
    assert json.loads(out)["finished"] == 16
    assert "ros2: " not in err.replace("ros2: node /fluidswarm", "")  # no note: the router was there throughout
    mcap = tmp_path / "digit2_IMG_1140.mcap"
    assert check(mcap)[0]
    recording = load_run(mcap)
    frames = {round(f.t * 1e9): f for f in recording.frames}
    peer.close()

    got = {topic: peer.samples[token.data_key] for topic, token in pubs.items()}
    for topic, samples in got.items():
        seqs, stamps, gids = zip(*(unpack_attachment(att) for _, att in samples), strict=True) if samples else ((),) * 3
        assert samples, f"nothing on {topic}"
        assert list(seqs) == list(range(seqs[0], seqs[0] + len(seqs))), topic  # +1 each, none lost
        assert set(gids) == {pubs[topic].gid}, topic  # the GID rmw_zenoh derives from the token
        assert all(abs(s - time.time_ns()) < 600e9 for s in stamps)  # wall clock, ns

    poses = [decode(p, "geometry_msgs/msg/PoseArray") for p, _ in got["/fluidswarm/poses"]]
    assert len(poses) >= 0.8 * len(recording.frames), (len(poses), len(recording.frames))
    for msg in poses:
        assert msg.header.frame_id == "world"
        frame = frames[round(_stamp(msg) * 1e9)]
        xy = np.array([[p.position.x, p.position.y] for p in msg.poses])
        order = np.argsort(frame.ids)
        assert np.abs(xy - frame.positions[order]).max() <= 1e-9
    steps = [frames[round(_stamp(m) * 1e9)].step for m in poses]
    assert steps == list(range(steps[0], steps[0] + len(steps)))  # step for step
    assert steps[-1] == recording.frames[-1].step

    tf = decode(got["/tf"][-1][0], "tf2_msgs/msg/TFMessage")
    last = recording.frames[-1]
    assert [t.child_frame_id for t in tf.transforms] == [f"robot_{i}/base_link" for i in sorted(last.ids)]
    assert {t.header.frame_id for t in tf.transforms} == {"world"}
    cloud = decode(got["/fluidswarm/particles"][-1][0], "sensor_msgs/msg/PointCloud2")
    assert [f.name for f in cloud.fields] == ["x", "y", "z", "id", "density", "pressure"]
    assert cloud.width == len(last.ids) and cloud.point_step == 24
    rows = np.frombuffer(
        cloud.data.tobytes(),
        dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("id", "<u4"), ("d", "<f4"), ("p", "<f4")],
    )
    assert list(rows["id"]) == sorted(last.ids)
    clock = decode(got["/clock"][-1][0], "rosgraph_msgs/msg/Clock")
    assert clock.clock.sec + clock.clock.nanosec * 1e-9 == pytest.approx(last.t, abs=1e-9)
    # latched: the target drawn at t = 0, before this peer subscribed, came from the publisher's cache
    markers = decode(got["/fluidswarm/target"][0][0], "visualization_msgs/msg/MarkerArray").markers
    outlines = [m for m in markers if m.ns == "target"]
    assert outlines and all(len(m.points) >= 4 and m.header.frame_id == "world" for m in outlines)
    command = json.loads(decode(got["/fluidswarm/command"][0][0], "std_msgs/msg/String").data)
    assert command == recording.commands[0][1]
    image = decode(got["/fluidswarm/image"][0][0], "sensor_msgs/msg/CompressedImage")  # latched too
    assert image.format == "jpeg" and image.data.tobytes() == recording.images[0].data
    events = [json.loads(decode(p, "std_msgs/msg/String").data) for p, _ in got["/fluidswarm/events"]]
    assert {e["kind"] for e in events} >= {"finished"}


@pytest.mark.swarm
def test_an_absent_ros2_router_is_one_line_and_the_run_goes_on(tmp_path):
    run = _imitate(tmp_path, f"tcp/127.0.0.1:{free_port()}", 150)
    out, err = run.communicate(timeout=300)
    assert run.returncode == 0, err[-2000:]
    notes = [line for line in err.splitlines() if line.startswith("ros2: no ROS 2 router")]
    assert len(notes) == 1 and "the run goes on" in notes[0], err
    assert json.loads(out)["finished"] == 16
    assert check(tmp_path / "digit2_IMG_1140.mcap")[0]


@pytest.mark.swarm
def test_a_ros2_router_lost_mid_run_is_one_line_and_the_mcap_is_complete(tmp_path):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = start_router(endpoint)
    peer = Peer(endpoint)
    run = _imitate(tmp_path, endpoint, 600)
    try:
        peer.wait_tokens(DOMAIN, 1 + len(PUBLISHED), 60)
        peer.close()
        stop_router(router)  # SIGKILL: as a crashed rmw_zenohd
        out, err = run.communicate(timeout=300)
    finally:
        if run.poll() is None:
            run.kill()
            run.communicate()
        stop_router(router)
    assert run.returncode == 0, err[-2000:]
    assert [line for line in err.splitlines() if line.startswith("ros2: lost")] != [], err
    assert json.loads(out)["finished"] == 16
    assert check(tmp_path / "digit2_IMG_1140.mcap")[0]
    events = load_run(tmp_path / "digit2_IMG_1140.mcap").events
    assert any(e.name == "ros2" and "lost the ROS 2 router" in e.message for e in events)


def test_tokens_split_by_the_peer_equal_the_products_own():
    """The product's writer and the test's reader of a token agree (and the token's GID is XXH3-128 of it)."""
    e = rmw.Entity(
        3,
        "abcd",
        "0",
        "4",
        "MP",
        "/",
        "/",
        "fluidswarm",
        "/fluidswarm/poses",
        "geometry_msgs/msg/PoseArray",
        "RIHS01_00",
        rmw.Qos(depth=10),
    )
    t = split_token(e.token)
    assert (t.domain, t.topic, t.msgtype, t.type_hash, t.qos) == (
        3,
        "/fluidswarm/poses",
        "geometry_msgs/msg/PoseArray",
        "RIHS01_00",
        "::,10:,:,:,,",
    )
    assert t.data_key == e.key == "3/fluidswarm/poses/geometry_msgs::msg::dds_::PoseArray_/RIHS01_00"
    assert t.gid == e.gid
    assert unpack_attachment(rmw.attachment(7, 99, e.gid)) == (7, 99, e.gid)
    assert rmw.parse_attachment(rmw.attachment(7, 99, e.gid)) == (7, 99, e.gid)
    assert rmw.parse_qos(":1:,1:,:,:,,") == rmw.Qos(durability=rmw.TRANSIENT_LOCAL, depth=1)


class _Capture:
    def __init__(self):
        self.sent: list[bytes] = []

    def put(self, cdr: bytes) -> None:
        self.sent.append(cdr)


def test_a_unicycles_yaw_is_its_heading_and_a_points_its_motion():
    """The bridge's step (no session): PoseArray and /tf orientations from the state rows' heading (unicycles)
    or their velocity (others), in id order."""
    from agent.sph.particle import HEADING, SPEED, VX, VY, X, Y
    from fluidswarm.recording import ros2_messages as m
    from fluidswarm.recording.ros2_bridge import Bridge

    vals = np.zeros((3, SPEED + 1))
    vals[:, X], vals[:, Y] = [0.5, 0.1, 0.3], [1.0, 1.1, 1.2]
    vals[:, VX], vals[:, VY] = [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]
    vals[:, HEADING] = [0.3, -2.0, 1.0]
    ids = np.array([7, 2, 5])
    for unicycle, want in ((True, [-2.0, 1.0, 0.3]), (False, [0.0, 0.0, np.pi / 2])):
        pubs = {t.name: _Capture() for t in m.TOPICS}
        Bridge("tcp/127.0.0.1:1", 0, unicycle, print)._publish(pubs, ("states", 4, 0.08, ids, vals))
        poses = decode(pubs[m.POSES].sent[0], "geometry_msgs/msg/PoseArray").poses
        yaw = [2 * np.arctan2(p.orientation.z, p.orientation.w) for p in poses]
        assert np.allclose(yaw, want) and [p.position.x for p in poses] == [0.1, 0.3, 0.5]
        tf = decode(pubs[m.TF].sent[0], "tf2_msgs/msg/TFMessage").transforms
        assert [t.child_frame_id for t in tf] == ["robot_2/base_link", "robot_5/base_link", "robot_7/base_link"]
        assert decode(pubs[m.CLOCK].sent[0], "rosgraph_msgs/msg/Clock").clock.nanosec == 80_000_000


def test_bad_ros2_options_are_one_line(capsys, monkeypatch):
    from fluidswarm.cli import main

    for argv, env, why in (
        (["--ros2", "--ros2-router", "localhost:7447"], {}, "is not a zenoh endpoint"),
        (["--ros2"], {"ROS_DOMAIN_ID": "300"}, "ROS_DOMAIN_ID='300' is not a ROS 2 domain id"),
        (["--ros2-router", "tcp/h:1"], {}, "--ros2-router needs --ros2"),
    ):
        for k, v in env.items():
            monkeypatch.setenv(k, v)
        assert main(["imitate", str(V_SIGN), *argv]) == 1
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and why in err, err
        monkeypatch.delenv("ROS_DOMAIN_ID", raising=False)


def test_the_ros2_session_carries_none_of_the_runs_credentials(monkeypatch):
    """The recorder runs with its credentials on the swarm's bus in its environment; the ROS 2 session's config
    (rmw.session_config) takes none of them, and is a client of the ROS 2 router alone."""
    from agent.protocol.access import PASSWORD_ENV, USER_ENV
    from agent.protocol.session import client_config

    monkeypatch.setenv(USER_ENV, "recorder")
    monkeypatch.setenv(PASSWORD_ENV, "secret")
    assert json.loads(client_config(["tcp/127.0.0.1:1"]).get_json("transport/auth/usrpwd/user")) == "recorder"
    conf = rmw.session_config("tcp/rosbox:7447", 5000)
    assert json.loads(conf.get_json("transport/auth/usrpwd/user")) is None
    assert json.loads(conf.get_json("transport/auth/usrpwd/password")) is None
    assert json.loads(conf.get_json("connect/endpoints")) == ["tcp/rosbox:7447"]
    assert json.loads(conf.get_json("mode")) == "client"
