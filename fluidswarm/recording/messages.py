"""The Foxglove message of each topic of a run, built and validated from plain arrays: pure functions
(bad input raises ValueError naming the field); `RunWriter` queues what they return. The topics, schemas and
packed layout are schemas.py's; docs/recording.md lists them."""

from __future__ import annotations

import base64
import math
from collections.abc import Iterable, Sequence

import cv2
import numpy as np

from agent.sph.obstacles import Circle, Obstacle
from coordinator.control.geometry import ImageToDomain
from fluidswarm.recording import schemas as sc

IDENTITY_POSE = {"position": {"x": 0.0, "y": 0.0, "z": 0.0}, "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}
FRAME_ID = "domain"
_ELLIPSE_SEGMENTS = 48
_CIRCLE_SEGMENTS = 64


def _color(rgb: Sequence[int], alpha: float) -> dict:
    return {"r": rgb[0] / 255, "g": rgb[1] / 255, "b": rgb[2] / 255, "a": alpha}


def _point(x: float, y: float) -> dict:
    return {"x": float(x), "y": float(y), "z": 0.0}


def _rows(name: str, value, n: int, width: int | None = None) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    shape = (n,) if width is None else (n, width)
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
    return arr


def _entity(stamp: dict, entity_id: str, **primitives) -> dict:
    entity = {
        "timestamp": stamp,
        "frame_id": FRAME_ID,
        "id": entity_id,
        "lifetime": {"sec": 0, "nsec": 0},
        "frame_locked": False,
        "metadata": [],
    }
    for key in ("arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts", "models"):
        entity[key] = primitives.get(key, [])
    return entity


def _line_loop(xy, thickness: float, rgb: Sequence[int]) -> dict:
    """A closed outline through the points `xy` ((n, 2), domain m) in one colour: the scene's line primitive."""
    return {
        "type": 1,
        "pose": IDENTITY_POSE,
        "thickness": thickness,
        "scale_invariant": True,
        "points": [_point(x, y) for x, y in xy],
        "color": _color(rgb, 1.0),
        "colors": [],
        "indices": [],
    }


def _disc(x: float, y: float, r: float, colour: dict) -> dict:
    """A flat disc of radius `r` at (x, y): the scene's cylinder primitive, 2 mm high."""
    return {
        "pose": {"position": _point(x, y), "orientation": IDENTITY_POSE["orientation"]},
        "size": {"x": 2 * r, "y": 2 * r, "z": 0.002},
        "bottom_scale": 1.0,
        "top_scale": 1.0,
        "color": colour,
    }


def _ellipse_line(x: float, y: float, major: float, minor: float, angle_deg: float) -> dict:
    a = np.linspace(0, 2 * math.pi, _ELLIPSE_SEGMENTS, endpoint=False)
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    ex, ey = major / 2 * np.cos(a), minor / 2 * np.sin(a)
    return _line_loop([(x + c * u - s * v, y + s * u + c * v) for u, v in zip(ex, ey)], 2.0, (214, 39, 40))


def state_cloud(step: int, t: float, ids, positions, velocities, density, pressure, class_ids, alive=None) -> dict:
    """All particle states of one step as ONE `foxglove.PointCloud` (topic `fluidswarm/<run>/state`).

    Arrays have one row per particle; `alive` (bool, optional) selects the rows to record, otherwise
    every row is taken as alive. Fields are packed as `schemas.PARTICLE_DTYPE` (SPH values float64).
    The step number is the MCAP message sequence and `fluidswarm.step` in the message.
    """
    step = int(step)
    if step < 0:
        raise ValueError(f"step must be >= 0, got {step}")
    ids = np.asarray(ids).reshape(-1)
    n = len(ids)
    if n and (not np.issubdtype(ids.dtype, np.integer) or ids.min() < 0 or ids.max() >= 2**32):
        raise ValueError("ids must be integers in [0, 2**32)")
    cls = np.asarray(class_ids).reshape(-1)
    if cls.shape != (n,) or (n and (not np.issubdtype(cls.dtype, np.integer) or cls.min() < 0)):
        raise ValueError(f"class_ids must be {n} non-negative integers")
    pos = _rows("positions", positions, n, 2)
    vel = _rows("velocities", velocities, n, 2)
    rho = _rows("density", density, n)
    p = _rows("pressure", pressure, n)
    if alive is not None:
        keep = np.asarray(alive)
        if keep.dtype != bool or keep.shape != (n,):
            raise ValueError(f"alive must be a boolean mask of shape ({n},)")
        ids, cls, pos, vel, rho, p = ids[keep], cls[keep], pos[keep], vel[keep], rho[keep], p[keep]
    if len(np.unique(ids)) != len(ids):
        raise ValueError(f"step {step}: duplicate particle ids")
    packed = np.zeros(len(ids), dtype=sc.PARTICLE_DTYPE)
    packed["id"], packed["class"] = ids, cls
    packed["x"], packed["y"], packed["vx"], packed["vy"] = pos[:, 0], pos[:, 1], vel[:, 0], vel[:, 1]
    packed["rho"], packed["p"] = rho, p
    rgb = sc.class_colour(cls)
    packed["red"], packed["green"], packed["blue"], packed["alpha"] = rgb[:, 0], rgb[:, 1], rgb[:, 2], 255
    payload = {
        "timestamp": sc.stamp(t),
        "frame_id": FRAME_ID,
        "pose": IDENTITY_POSE,
        "point_stride": sc.PARTICLE_DTYPE.itemsize,
        "fields": sc.packed_fields(sc.PARTICLE_DTYPE),
        "data": base64.b64encode(packed.tobytes()).decode("ascii"),
        sc.EXTRA_KEY: {"step": step, "count": int(len(ids))},
    }
    return payload


def scene_update(t: float, waypoints: Iterable[Sequence[float]] = (), ellipses: Iterable[Sequence[float]] = ()) -> dict:
    """Waypoints (x, y, r) as flat discs and ellipses (x, y, major, minor, angle_deg; full axis
    lengths, angle counter-clockwise from +x) as outlines: one `foxglove.SceneUpdate` on
    `fluidswarm/<run>/scene` replacing the previous waypoints and ellipses."""
    wps = [tuple(float(v) for v in w) for w in waypoints]
    els = [tuple(float(v) for v in e) for e in ellipses]
    if any(len(w) != 3 or w[2] < 0 for w in wps):
        raise ValueError("waypoints must be (x, y, r) with r >= 0")
    if any(len(e) != 5 or e[2] < 0 or e[3] < 0 for e in els):
        raise ValueError("ellipses must be (x, y, major, minor, angle_deg) with non-negative axes")
    stamp = sc.stamp(t)
    discs = [_disc(x, y, r, _color((0, 0, 0), 0.25)) for x, y, r in wps]
    loops = [_ellipse_line(*e) for e in els]
    payload = {
        "deletions": [],
        "entities": [
            _entity(stamp, "waypoints", cylinders=discs),
            _entity(stamp, "ellipses", lines=loops),
        ],
        sc.EXTRA_KEY: {"waypoints": [list(w) for w in wps], "ellipses": [list(e) for e in els]},
    }
    return payload


def target_outline(t: float, mask: np.ndarray, transform: ImageToDomain) -> tuple[dict, bytes]:
    """The target silhouette's outline in the domain as a `foxglove.SceneUpdate`, and the mask as PNG
    bytes (the writer stores them as attachment and metadata)."""
    mask = np.asarray(mask).astype(bool)
    if mask.ndim != 2 or not mask.any():
        raise ValueError("target mask must be a 2-D array with at least one foreground pixel")
    ok, png = cv2.imencode(".png", mask.astype(np.uint8) * 255)
    if not ok:
        raise ValueError("could not encode the target mask as PNG")
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    lines = []
    for c in contours:
        xy = transform.to_domain(c.reshape(-1, 2) + 0.5)
        lines.append(_line_loop(xy, 2.0, (80, 80, 80)))
    payload = {"deletions": [], "entities": [_entity(sc.stamp(t), "target", lines=lines)]}
    return payload, png.tobytes()


def obstacle_outlines(t: float, obstacles: Iterable[Obstacle]) -> dict:
    """The domain's obstacles (agent/sph/obstacles.py) as one `foxglove.SceneUpdate` entity `obstacles` on
    `fluidswarm/<run>/scene`: a line loop per obstacle, a polygon through its vertices, a circle through
    `_CIRCLE_SEGMENTS` points of its boundary."""
    loops = []
    for o in obstacles:
        if isinstance(o, Circle):
            a = np.linspace(0, 2 * math.pi, _CIRCLE_SEGMENTS, endpoint=False)
            xy = np.column_stack([o.x + o.radius * np.cos(a), o.y + o.radius * np.sin(a)])
        else:
            xy = np.asarray(o.vertices, dtype=float)
        loops.append(_line_loop(xy, 3.0, (40, 40, 40)))
    if not loops:
        raise ValueError("obstacles must hold at least one circle or polygon")
    return {"deletions": [], "entities": [_entity(sc.stamp(t), "obstacles", lines=loops)]}


def body_entities(t: float, centres, headings, radius: float) -> dict:
    """The robots' bodies (agent/sph/robot.py) as one `foxglove.SceneUpdate` entity `bodies` on
    `fluidswarm/<run>/scene`: a flat disc of the body radius at each body centre (a unicycle's axle centre)
    and, for a body with a heading (unicycles; `headings` None for the others), an arrow along it from the
    centre, one diameter long, so a viewer sees where each robot faces and whether two bodies touch."""
    c = np.asarray(centres, dtype=float)
    if c.ndim != 2 or c.shape[1] != 2 or not np.isfinite(c).all():
        raise ValueError(f"body centres must be finite (N, 2), got shape {c.shape}")
    if not (math.isfinite(radius) and radius > 0):
        raise ValueError(f"body radius must be a positive number, got {radius!r}")
    th = None if headings is None else _rows("headings", headings, len(c))
    colour = _color((31, 119, 180), 0.45)
    discs = [_disc(x, y, radius, colour) for x, y in c]
    arrows = []
    if th is not None:
        for (x, y), a in zip(c, th):
            # a yaw of `a` about +z as a unit quaternion (Foxglove's arrow points along its pose's +x)
            q = {"x": 0.0, "y": 0.0, "z": math.sin(a / 2), "w": math.cos(a / 2)}
            arrows.append(
                {
                    "pose": {"position": _point(x, y), "orientation": q},
                    "shaft_length": 1.4 * radius,
                    "shaft_diameter": 0.2 * radius,
                    "head_length": 0.6 * radius,
                    "head_diameter": 0.5 * radius,
                    "color": _color((20, 20, 20), 1.0),
                }
            )
    return {"deletions": [], "entities": [_entity(sc.stamp(t), "bodies", cylinders=discs, arrows=arrows)]}


def compressed_image(t: float, jpeg_bytes: bytes, frame_id: str = "camera", fmt: str = "jpeg") -> dict:
    """The perception input as `foxglove.CompressedImage` on `fluidswarm/<run>/perception/image`."""
    payload = {
        "timestamp": sc.stamp(t),
        "frame_id": str(frame_id),
        "data": base64.b64encode(bytes(jpeg_bytes)).decode("ascii"),
        "format": fmt,
    }
    return payload


def event_log(
    t: float,
    level: int | str,
    name: str,
    message: str,
    *,
    kind: str | None = None,
    agent: int | None = None,
    step: int | None = None,
) -> dict:
    """A `foxglove.Log` on `fluidswarm/<run>/event`.

    `level` is a foxglove LogLevel (0-5) or its name ("info", ...); `name` the process (e.g.
    "agent/17"). For `check`, lifecycle events carry `kind` ("started" | "died" | "stopped" | "finished";
    also "froze", "rejected", ...) and the `agent` id; `step`, if given, is the first step at which the event
    holds (started: first step with a state; the others: first step without one); without it, time `t` decides.
    """
    if isinstance(level, str):
        if level.lower() not in sc.LOG_LEVELS:
            raise ValueError(f"unknown log level {level!r}; use one of {sorted(sc.LOG_LEVELS)}")
        level = sc.LOG_LEVELS[level.lower()]
    if int(level) not in range(6):
        raise ValueError(f"log level must be 0..5, got {level}")
    extra = {"kind": kind, "agent": None if agent is None else int(agent), "step": None if step is None else int(step)}
    payload = {
        "timestamp": sc.stamp(t),
        "level": int(level),
        "message": str(message),
        "name": str(name),
        "file": "",
        "line": 0,
        sc.EXTRA_KEY: extra,
    }
    return payload
