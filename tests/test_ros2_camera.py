"""`imitate --camera ros2:TOPIC`: a hand photograph published as a ROS 2 camera would publish it (rmw_zenoh's keys,
tokens and attachment, written here by hand from its sources: tests/ros2_peer.py), on a plain Zenoh router standing
in for rmw_zenohd, drives a 60-agent imitation; a topic nobody publishes, a wrong type, an unsupported encoding are
one line each."""

from __future__ import annotations

import json
import os
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from ros2link.camera import compressed_to_bgr, image_to_bgr
from swarmhost.router_host import free_port
from tests.ros2_peer import TYPESTORE, Peer, start_router, stop_router
from tests.swarm_helpers import wait_until

FLUIDSWARM = [sys.executable, "-m", "fluidswarm"]
HAND = Path(__file__).resolve().parents[1] / "scenarios" / "inputs" / "digit5_IMG_1143.JPG"  # an open hand
DOMAIN = 3


def image_msg(bgr: np.ndarray, encoding: str):
    T = TYPESTORE.types
    picture = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB) if encoding == "rgb8" else bgr
    h, w = picture.shape[:2]
    return T["sensor_msgs/msg/Image"](
        header=T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=1, nanosec=0), frame_id="camera"),
        height=h,
        width=w,
        encoding=encoding,
        is_bigendian=0,
        step=w * 3,
        data=np.ascontiguousarray(picture).reshape(-1),
    )


def compressed_msg(bgr: np.ndarray):
    T = TYPESTORE.types
    ok, jpeg = cv2.imencode(".jpg", bgr)
    assert ok
    return T["sensor_msgs/msg/CompressedImage"](
        header=T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=1, nanosec=0), frame_id="camera"),
        format="jpeg",
        data=jpeg.reshape(-1),
    )


class Camera:
    """A ROS 2 camera node `/test_camera` publishing `msg` of `msgtype` on `topic` at 10 Hz until stopped."""

    def __init__(self, peer: Peer, topic: str, msgtype: str, msg):
        zid = str(peer.session.info.zid())
        pkg, kind, name = msgtype.split("/")
        dds = f"{pkg}::{kind}::dds_::{name}_"
        self.rihs = TYPESTORE.hash_rihs01(msgtype)
        mangled = topic.replace("/", "%")
        peer.declare_token(f"@ros2_lv/{DOMAIN}/{zid}/0/0/NN/%/%/test_camera")
        self.token = f"@ros2_lv/{DOMAIN}/{zid}/0/1/MP/%/%/test_camera/{mangled}/{dds}/{self.rihs}/::,10:,:,:,,"
        peer.declare_token(self.token)
        self.key = f"{DOMAIN}/{topic.strip('/')}/{dds}/{self.rihs}"
        self.payload = bytes(TYPESTORE.serialize_cdr(msg, msgtype))
        self.peer, self.stop, self.sent = peer, threading.Event(), 0
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        gid = bytes(range(16))
        while not self.stop.wait(0.1):
            self.sent += 1
            self.peer.put(self.key, self.payload, struct.pack("<qqB16s", self.sent, time.time_ns(), 16, gid))

    def close(self) -> None:
        self.stop.set()
        self.thread.join(5)


def _imitate(source: str, router: str, out: Path, agents: int = 60, steps: int = 700) -> subprocess.Popen:
    return subprocess.Popen(
        FLUIDSWARM
        + ["imitate", "--camera", source, "--subject", "hand", "--agents", str(agents), "--steps", str(steps)]
        + ["--out", str(out), "--ros2-router", router, "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=dict(os.environ, ROS_DOMAIN_ID=str(DOMAIN)),
    )


@pytest.fixture
def ros2_bus():
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = start_router(endpoint)
    peer = Peer(endpoint)
    yield endpoint, peer
    peer.close()
    stop_router(router)


@pytest.mark.swarm
@pytest.mark.parametrize("kind", ["image", "compressed"])
def test_a_ros2_camera_of_a_hand_drives_a_60_agent_imitation(ros2_bus, tmp_path, kind):
    endpoint, peer = ros2_bus
    photo = cv2.imread(str(HAND))
    if kind == "image":
        topic, camera = (
            "/camera/image_raw",
            Camera(peer, "/camera/image_raw", "sensor_msgs/msg/Image", image_msg(photo, "rgb8")),
        )
    else:
        topic = "/camera/image_raw/compressed"
        camera = Camera(peer, topic, "sensor_msgs/msg/CompressedImage", compressed_msg(photo))
    run = _imitate(f"ros2:{topic}", endpoint, tmp_path)
    try:
        # the coordinator's node subscribes with its own MS token, on the key the camera's token names
        subs: list = []
        assert wait_until(
            lambda: bool(subs.extend(t for t in peer.tokens(DOMAIN) if t.kind == "MS") or subs), 60, every=0.5
        )
        assert subs[0].topic == topic and subs[0].node == "fluidswarm_camera" and subs[0].data_key == camera.key
        out, err = run.communicate(timeout=300)
    finally:
        camera.close()
        if run.poll() is None:
            run.kill()
            run.communicate()
    assert run.returncode == 0, err[-2000:]
    r = json.loads(out.strip().splitlines()[-1])
    assert r["finished"] == 60 and r["gestures"][0]["gesture"] == "hand_5", r["gestures"]
    print(kind, r["fidelity"], r["realtime_factor"])
    assert r["fidelity"]["iou"] >= 0.7, r["fidelity"]


@pytest.mark.swarm
def test_bad_ros2_camera_sources_are_one_line_each(ros2_bus, tmp_path):
    endpoint, peer = ros2_bus
    photo = cv2.imread(str(HAND))
    wrong = Camera(peer, "/camera/words", "std_msgs/msg/String", TYPESTORE.types["std_msgs/msg/String"](data="hi"))
    yuv = Camera(peer, "/camera/yuv", "sensor_msgs/msg/Image", image_msg(photo, "yuv422"))
    try:
        cases = {
            "ros2:/camera/nobody": "nobody publishes /camera/nobody on ROS 2 domain 3",
            "ros2:/camera/words": "carries std_msgs/msg/String, not sensor_msgs/msg/Image",
            "ros2:/camera/yuv": "encoding 'yuv422' is not supported",
            "ros2:camera": "is not a ROS 2 topic name",
        }
        for source, why in cases.items():
            run = _imitate(source, endpoint, tmp_path / source.replace("/", "_"), agents=8, steps=50)
            _, err = run.communicate(timeout=120)
            lines = err.strip().splitlines()
            assert run.returncode != 0 and len(lines) == 1, err
            assert lines[0].startswith(f"fluidswarm imitate: error: camera {source}: ") and why in lines[0], lines[0]
    finally:
        wrong.close()
        yuv.close()


def test_pictures_of_each_encoding_decode_to_the_same_bgr():
    photo = cv2.imread(str(HAND))
    for encoding in ("rgb8", "bgr8"):
        assert np.array_equal(image_to_bgr(image_msg(photo, encoding)), photo)
    gray = cv2.cvtColor(photo, cv2.COLOR_BGR2GRAY)
    mono = image_msg(photo, "bgr8")
    mono.encoding, mono.step, mono.data = "mono8", photo.shape[1], gray.reshape(-1)
    assert np.array_equal(image_to_bgr(mono), cv2.cvtColor(gray, cv2.COLOR_GRAY2BGR))
    assert compressed_to_bgr(compressed_msg(photo)).shape == photo.shape
    short = image_msg(photo, "bgr8")
    short.data = short.data[:-1]
    for bad, why in ((short, "do not hold"), (image_msg(photo, "yuv422"), "not supported")):
        with pytest.raises(ValueError, match=why):
            image_to_bgr(bad)
