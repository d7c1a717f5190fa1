"""A run's data as the standard ROS 2 messages (docs/ros2.md): what the live bridge publishes
(fluidswarm/recording/ros2_bridge.py) and the bag holds (fluidswarm/ros2_bag.py), built and CDR-serialised with rosbags'
type store (the standard definitions of ROS 2 Jazzy; no codec of our own).

Frames: every position is in `world` (the run's domain, metres, z = 0); each agent's body frame is
`robot_<id>/base_link`. Stamps are the simulated clock (`/clock`).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import cv2
import numpy as np

from agent.sph.obstacles import Circle, Obstacle
from coordinator.control.geometry import ImageToDomain
from fluidswarm.recording.schemas import LOG_LEVELS
from ros2link.cdr import serialize, typestore
from ros2link.rmw import KEEP_LAST, RELIABLE, TRANSIENT_LOCAL, VOLATILE, Qos

WORLD = "world"
POSES, PARTICLES, TF, CLOCK, TARGET, COMMAND, EVENTS, IMAGE = (
    "/fluidswarm/poses",
    "/fluidswarm/particles",
    "/tf",
    "/clock",
    "/fluidswarm/target",
    "/fluidswarm/command",
    "/fluidswarm/events",
    "/fluidswarm/image",
)


@dataclass(frozen=True)
class Topic:
    name: str
    msgtype: str
    qos: Qos


# What a ROS 2 user expects on each: the state topics reliable, volatile, a small queue (/tf as tf2's broadcaster
# offers it: depth 100); the target latched (transient local, depth 1: RViz's latched displays, late joiners get it).
TOPICS = (
    Topic(POSES, "geometry_msgs/msg/PoseArray", Qos(RELIABLE, VOLATILE, KEEP_LAST, 10)),
    Topic(PARTICLES, "sensor_msgs/msg/PointCloud2", Qos(RELIABLE, VOLATILE, KEEP_LAST, 10)),
    Topic(TF, "tf2_msgs/msg/TFMessage", Qos(RELIABLE, VOLATILE, KEEP_LAST, 100)),
    Topic(CLOCK, "rosgraph_msgs/msg/Clock", Qos(RELIABLE, VOLATILE, KEEP_LAST, 10)),
    Topic(TARGET, "visualization_msgs/msg/MarkerArray", Qos(RELIABLE, TRANSIENT_LOCAL, KEEP_LAST, 1)),
    Topic(COMMAND, "std_msgs/msg/String", Qos(RELIABLE, TRANSIENT_LOCAL, KEEP_LAST, 1)),
    Topic(EVENTS, "std_msgs/msg/String", Qos(RELIABLE, VOLATILE, KEEP_LAST, 100)),
    Topic(IMAGE, "sensor_msgs/msg/CompressedImage", Qos(RELIABLE, TRANSIENT_LOCAL, KEEP_LAST, 1)),
)
BY_NAME = {t.name: t for t in TOPICS}

# PointCloud2 layout: float32 x, y, z (what RViz reads), uint32 id, float32 density, pressure (colouring)
POINT_DTYPE = np.dtype(
    [("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("id", "<u4"), ("density", "<f4"), ("pressure", "<f4")]
)
POINT_OFFSETS = (("x", 0), ("y", 4), ("z", 8), ("id", 12), ("density", 16), ("pressure", 20))
_FLOAT32, _UINT32 = 7, 6  # sensor_msgs/PointField datatypes
LINE_STRIP, ADD, DELETEALL = 4, 0, 3  # visualization_msgs/Marker


def _t(name: str):
    return typestore().types[name]


def stamp(t: float):
    ns = max(0, round(t * 1e9))
    return _t("builtin_interfaces/msg/Time")(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def header(t: float, frame: str = WORLD):
    return _t("std_msgs/msg/Header")(stamp=stamp(t), frame_id=frame)


def yaw_quaternion(yaw: float):
    return _t("geometry_msgs/msg/Quaternion")(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))


def headings(velocities: np.ndarray, heading: np.ndarray | None) -> np.ndarray:
    """Each agent's yaw: its heading where it has one (a unicycle, live), else the direction it moves (0 at rest)."""
    if heading is not None:
        return np.asarray(heading, dtype=float)
    v = np.asarray(velocities, dtype=float)
    return np.where(np.hypot(v[:, 0], v[:, 1]) > 0, np.arctan2(v[:, 1], v[:, 0]), 0.0)


def poses(t: float, ids: np.ndarray, xy: np.ndarray, yaw: np.ndarray) -> bytes:
    """geometry_msgs/PoseArray in `world`, one pose per agent in increasing id order (the caller's `ids` sorted)."""
    Pose, Point = _t("geometry_msgs/msg/Pose"), _t("geometry_msgs/msg/Point")
    order = np.argsort(ids, kind="stable")
    items = [
        Pose(position=Point(x=float(xy[k, 0]), y=float(xy[k, 1]), z=0.0), orientation=yaw_quaternion(float(yaw[k])))
        for k in order
    ]
    return serialize(_t("geometry_msgs/msg/PoseArray")(header=header(t), poses=items), "geometry_msgs/msg/PoseArray")


def particles(t: float, ids: np.ndarray, xy: np.ndarray, density: np.ndarray, pressure: np.ndarray) -> bytes:
    """sensor_msgs/PointCloud2 in `world`: x, y, z, id, density, pressure per agent (POINT_DTYPE), id order."""
    order = np.argsort(ids, kind="stable")
    cloud = np.zeros(len(ids), POINT_DTYPE)
    cloud["x"], cloud["y"] = xy[order, 0], xy[order, 1]
    cloud["id"], cloud["density"], cloud["pressure"] = ids[order], density[order], pressure[order]
    Field = _t("sensor_msgs/msg/PointField")
    fields = [
        Field(name=name, offset=offset, datatype=_UINT32 if name == "id" else _FLOAT32, count=1)
        for name, offset in POINT_OFFSETS
    ]
    msg = _t("sensor_msgs/msg/PointCloud2")(
        header=header(t),
        height=1,
        width=len(ids),
        fields=fields,
        is_bigendian=False,
        point_step=POINT_DTYPE.itemsize,
        row_step=POINT_DTYPE.itemsize * len(ids),
        data=np.frombuffer(cloud.tobytes(), np.uint8),
        is_dense=True,
    )
    return serialize(msg, "sensor_msgs/msg/PointCloud2")


def transforms(t: float, ids: np.ndarray, xy: np.ndarray, yaw: np.ndarray) -> bytes:
    """tf2_msgs/TFMessage: `world` -> `robot_<id>/base_link` for every agent."""
    Stamped, Transform, Vector3 = (
        _t("geometry_msgs/msg/TransformStamped"),
        _t("geometry_msgs/msg/Transform"),
        _t("geometry_msgs/msg/Vector3"),
    )
    h = header(t)
    items = [
        Stamped(
            header=h,
            child_frame_id=f"robot_{int(ids[k])}/base_link",
            transform=Transform(
                translation=Vector3(x=float(xy[k, 0]), y=float(xy[k, 1]), z=0.0), rotation=yaw_quaternion(float(yaw[k]))
            ),
        )
        for k in np.argsort(ids, kind="stable")
    ]
    return serialize(_t("tf2_msgs/msg/TFMessage")(transforms=items), "tf2_msgs/msg/TFMessage")


def clock(t: float) -> bytes:
    return serialize(_t("rosgraph_msgs/msg/Clock")(clock=stamp(t)), "rosgraph_msgs/msg/Clock")


def text(value: str) -> bytes:
    return serialize(_t("std_msgs/msg/String")(data=value), "std_msgs/msg/String")


def event_text(level, name: str, message: str, kind: str | None, agent: int | None, step: int | None) -> str:
    """A run event as the JSON object on /fluidswarm/events; `level` by name (info, warning, ...), as given to the
    recorder's writer or as the MCAP keeps it (a number)."""
    if not isinstance(level, str):
        level = next((k for k, v in LOG_LEVELS.items() if v == int(level)), "unknown")
    return json.dumps(
        {"level": level.lower(), "name": name, "message": message, "kind": kind, "agent": agent, "step": step},
        sort_keys=True,
    )


def command_text(command: dict) -> str:
    """The gesture command (the JSON object the coordinator published) on /fluidswarm/command."""
    return json.dumps(command, sort_keys=True, separators=(",", ":"))


def compressed_image(t: float, data: bytes, fmt: str, frame: str) -> bytes:
    """The perception input as sensor_msgs/CompressedImage (format "jpeg", "png")."""
    msg = _t("sensor_msgs/msg/CompressedImage")(
        header=header(t, frame), format=fmt, data=np.frombuffer(bytes(data), np.uint8)
    )
    return serialize(msg, "sensor_msgs/msg/CompressedImage")


def outline_loops(mask: np.ndarray, transform: ImageToDomain) -> list[np.ndarray]:
    """The silhouette's outer outlines in the domain, closed (as the MCAP's scene draws them)."""
    contours, _ = cv2.findContours(np.asarray(mask).astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    loops = [transform.to_domain(c.reshape(-1, 2) + 0.5) for c in contours]
    return [np.vstack([xy, xy[:1]]) for xy in loops if len(xy)]


def obstacle_loops(obstacles: tuple[Obstacle, ...], segments: int = 48) -> list[np.ndarray]:
    loops = []
    for o in obstacles:
        if isinstance(o, Circle):
            a = np.linspace(0, 2 * math.pi, segments + 1)
            loops.append(np.column_stack([o.x + o.radius * np.cos(a), o.y + o.radius * np.sin(a)]))
        else:
            xy = np.asarray(o.vertices, dtype=float)
            loops.append(np.vstack([xy, xy[:1]]))
    return loops


def markers(t: float, target: list[np.ndarray], obstacles: list[np.ndarray]) -> bytes:
    """visualization_msgs/MarkerArray: a DELETEALL (the new set replaces the last), then a line strip per
    target outline (namespace `target`, grey) and per obstacle (namespace `obstacles`, dark)."""
    Marker, Point, Color, Vector3, Pose = (
        _t("visualization_msgs/msg/Marker"),
        _t("geometry_msgs/msg/Point"),
        _t("std_msgs/msg/ColorRGBA"),
        _t("geometry_msgs/msg/Vector3"),
        _t("geometry_msgs/msg/Pose"),
    )
    Duration = _t("builtin_interfaces/msg/Duration")
    identity = Pose(position=Point(x=0.0, y=0.0, z=0.0), orientation=yaw_quaternion(0.0))

    def marker(ns: str, k: int, action: int, loop: np.ndarray | None, grey: float, width: float):
        return Marker(
            header=header(t),
            ns=ns,
            id=k,
            type=LINE_STRIP,
            action=action,
            pose=identity,
            scale=Vector3(x=width, y=0.0, z=0.0),
            color=Color(r=grey, g=grey, b=grey, a=1.0),
            lifetime=Duration(sec=0, nanosec=0),
            frame_locked=False,
            points=[] if loop is None else [Point(x=float(x), y=float(y), z=0.0) for x, y in loop],
            colors=[],
            texture_resource="",
            texture=_t("sensor_msgs/msg/CompressedImage")(header=header(t), format="", data=np.zeros(0, np.uint8)),
            uv_coordinates=[],
            text="",
            mesh_resource="",
            mesh_file=_t("visualization_msgs/msg/MeshFile")(filename="", data=np.zeros(0, np.uint8)),
            mesh_use_embedded_materials=False,
        )

    items = [marker("", 0, DELETEALL, None, 0.0, 0.0)]
    items += [marker("target", k, ADD, loop, 0.5, 0.02) for k, loop in enumerate(target)]
    items += [marker("obstacles", k, ADD, loop, 0.2, 0.04) for k, loop in enumerate(obstacles)]
    return serialize(_t("visualization_msgs/msg/MarkerArray")(markers=items), "visualization_msgs/msg/MarkerArray")
