"""What goes on disk: topic names, the Foxglove well-known JSON schemas, and the packed particle layout.

Foxglove recognises a JSON-encoded channel by its schema *name* (`foxglove.PointCloud`, ...); the schema
*data* is a JSON Schema describing the same fields. Binary fields are base64 strings in JSON. Our own
extra information rides in a top-level `"fluidswarm"` object, which Foxglove ignores.
"""

from __future__ import annotations

import json

import numpy as np

SCHEMA_ENCODING = "jsonschema"
MESSAGE_ENCODING = "json"
EXTRA_KEY = "fluidswarm"  # our own structured fields inside a Foxglove message


def topic(run: str, leaf: str) -> str:
    """MCAP topic for `leaf` of run `run`, mirroring the Zenoh key expression `fluidswarm/<run>/<leaf>`."""
    return f"fluidswarm/{run}/{leaf}"


STATE, SCENE, COMMAND, IMAGE, EVENTS = "state", "scene", "command", "perception/image", "event"

# Packed layout of one particle in the point cloud's `data` (little-endian, 64 bytes). Every SPH field is
# float64 so analysis recovers exactly what the agents computed; red/green/blue/alpha are the class colour.
PARTICLE_DTYPE = np.dtype(
    {
        "names": ["id", "class", "x", "y", "vx", "vy", "rho", "p", "red", "green", "blue", "alpha"],
        "formats": ["<u4", "<u4", "<f8", "<f8", "<f8", "<f8", "<f8", "<f8", "u1", "u1", "u1", "u1"],
        "offsets": [0, 4, 8, 16, 24, 32, 40, 48, 56, 57, 58, 59],
        "itemsize": 64,
    }
)

# foxglove.NumericType
NUMERIC_TYPE = {"u1": 1, "i1": 2, "<u2": 3, "<i2": 4, "<u4": 5, "<i4": 6, "<f4": 7, "<f8": 8}
NUMERIC_DTYPE = {1: "u1", 2: "i1", 3: "<u2", 4: "<i2", 5: "<u4", 6: "<i4", 7: "<f4", 8: "<f8"}


def packed_fields(dtype: np.dtype) -> list[dict]:
    """`foxglove.PackedElementField` list describing a structured dtype."""
    out = []
    assert dtype.names is not None and dtype.fields is not None  # a structured dtype
    for name in dtype.names:
        sub, offset = dtype.fields[name][:2]
        out.append({"name": name, "offset": int(offset), "type": NUMERIC_TYPE[sub.str.replace("|", "")]})
    return out


# Class colours (RGBA 0-255), the matplotlib "tab10" cycle; class k uses entry k mod 10.
CLASS_COLOURS = np.array(
    [
        (31, 119, 180),
        (255, 127, 14),
        (44, 160, 44),
        (214, 39, 40),
        (148, 103, 189),
        (140, 86, 75),
        (227, 119, 194),
        (127, 127, 127),
        (188, 189, 34),
        (23, 190, 207),
    ],
    dtype=np.uint8,
)


def class_colour(class_ids: np.ndarray) -> np.ndarray:
    """(N, 3) uint8 RGB colour of each class id."""
    return CLASS_COLOURS[np.asarray(class_ids, dtype=np.int64) % len(CLASS_COLOURS)]


# --- JSON Schemas (field names and types of the Foxglove well-known schemas) ---------------------------

_TIME = {
    "type": "object",
    "properties": {
        "sec": {"type": "integer", "minimum": 0},
        "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999},
    },
}
_VEC3 = {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}}
_QUAT = {"type": "object", "properties": {k: {"type": "number"} for k in "xyzw"}}
_POSE = {"type": "object", "properties": {"position": _VEC3, "orientation": _QUAT}}
_COLOR = {"type": "object", "properties": {k: {"type": "number", "minimum": 0, "maximum": 1} for k in "rgba"}}
_KEY_VALUE = {"type": "object", "properties": {"key": {"type": "string"}, "value": {"type": "string"}}}
_EXTRA = {"type": "object", "description": "fluidswarm's own fields; ignored by Foxglove"}


def _enum(*names: str) -> dict:
    return {"oneOf": [{"title": n, "const": i} for i, n in enumerate(names)]}


_POINT_CLOUD = {
    "title": "foxglove.PointCloud",
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "frame_id": {"type": "string"},
        "pose": _POSE,
        "point_stride": {"type": "integer", "minimum": 0},
        "fields": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {
                    "name": {"type": "string"},
                    "offset": {"type": "integer", "minimum": 0},
                    "type": _enum(
                        "UNKNOWN", "UINT8", "INT8", "UINT16", "INT16", "UINT32", "INT32", "FLOAT32", "FLOAT64"
                    ),
                },
            },
        },
        "data": {"type": "string", "contentEncoding": "base64"},
        EXTRA_KEY: _EXTRA,
    },
}

_CYLINDER = {
    "type": "object",
    "properties": {
        "pose": _POSE,
        "size": _VEC3,
        "bottom_scale": {"type": "number"},
        "top_scale": {"type": "number"},
        "color": _COLOR,
    },
}
_ARROW = {
    "type": "object",
    "properties": {
        "pose": _POSE,
        "shaft_length": {"type": "number"},
        "shaft_diameter": {"type": "number"},
        "head_length": {"type": "number"},
        "head_diameter": {"type": "number"},
        "color": _COLOR,
    },
}
_LINE = {
    "type": "object",
    "properties": {
        "type": _enum("LINE_STRIP", "LINE_LOOP", "LINE_LIST"),
        "pose": _POSE,
        "thickness": {"type": "number"},
        "scale_invariant": {"type": "boolean"},
        "points": {"type": "array", "items": _VEC3},
        "color": _COLOR,
        "colors": {"type": "array", "items": _COLOR},
        "indices": {"type": "array", "items": {"type": "integer"}},
    },
}
_ENTITY = {
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "frame_id": {"type": "string"},
        "id": {"type": "string"},
        "lifetime": {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}},
        "frame_locked": {"type": "boolean"},
        "metadata": {"type": "array", "items": _KEY_VALUE},
        "arrows": {"type": "array", "items": _ARROW},
        "cubes": {"type": "array"},
        "spheres": {"type": "array"},
        "cylinders": {"type": "array", "items": _CYLINDER},
        "lines": {"type": "array", "items": _LINE},
        "triangles": {"type": "array"},
        "texts": {"type": "array"},
        "models": {"type": "array"},
    },
}
_SCENE_UPDATE = {
    "title": "foxglove.SceneUpdate",
    "type": "object",
    "properties": {
        "deletions": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {"timestamp": _TIME, "type": _enum("MATCHING_ID", "ALL"), "id": {"type": "string"}},
            },
        },
        "entities": {"type": "array", "items": _ENTITY},
        EXTRA_KEY: _EXTRA,
    },
}

_COMPRESSED_IMAGE = {
    "title": "foxglove.CompressedImage",
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "frame_id": {"type": "string"},
        "data": {"type": "string", "contentEncoding": "base64"},
        "format": {"type": "string", "description": "jpeg, png, webp or avif"},
    },
}

_LOG = {
    "title": "foxglove.Log",
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "level": _enum("UNKNOWN", "DEBUG", "INFO", "WARNING", "ERROR", "FATAL"),
        "message": {"type": "string"},
        "name": {"type": "string"},
        "file": {"type": "string"},
        "line": {"type": "integer", "minimum": 0},
        EXTRA_KEY: _EXTRA,
    },
}

_COMMAND = {
    "title": "fluidswarm.Command",
    "description": "A gesture command exactly as the controller published it (a JSON object).",
    "type": "object",
}

# schema name -> JSON Schema; the names are the ones Foxglove knows.
SCHEMAS = {
    "foxglove.PointCloud": _POINT_CLOUD,
    "foxglove.SceneUpdate": _SCENE_UPDATE,
    "foxglove.CompressedImage": _COMPRESSED_IMAGE,
    "foxglove.Log": _LOG,
    "fluidswarm.Command": _COMMAND,
}

# leaf -> schema name
TOPIC_SCHEMAS = {
    STATE: "foxglove.PointCloud",
    SCENE: "foxglove.SceneUpdate",
    COMMAND: "fluidswarm.Command",
    IMAGE: "foxglove.CompressedImage",
    EVENTS: "foxglove.Log",
}

LOG_LEVELS = {"unknown": 0, "debug": 1, "info": 2, "warning": 3, "error": 4, "fatal": 5}


def schema_bytes(name: str) -> bytes:
    return json.dumps(SCHEMAS[name], separators=(",", ":")).encode()


def stamp(t: float) -> dict:
    """Foxglove `time` {sec, nsec} of t seconds."""
    ns = seconds_to_ns(t)
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def seconds_to_ns(t: float) -> int:
    t = float(t)
    if not np.isfinite(t) or t < 0:
        raise ValueError(f"time must be a finite number of seconds >= 0, got {t}")
    return int(round(t * 1e9))
