"""`fluidswarm replay RUN.mcap --ros2-bag DIR`: a recorded run as a rosbag2 directory that `ros2 bag info` and
`ros2 bag play` take (docs/ros2.md "Bags").

The layout is rosbag2's MCAP storage (rosbag2_storage_mcap, bag version 9): one `DIR/<DIR name>_0.mcap` with
profile `ros2`, a `ros2msg` schema per type (the full .msg text with its dependencies), `cdr` messages, channel
metadata `offered_qos_profiles` (YAML) and `topic_type_hash` (RIHS01), the `rosbag2` metadata record, and
`DIR/metadata.yaml`. The messages are the live bridge's (fluidswarm/recording/ros2_messages.py) built from the MCAP; log
times are the simulated clock. rosbags' own bag writer leaves `topic_type_hash` out of the channels, so the file
is written with the mcap package, rosbags giving the types, hashes and CDR.
"""

from __future__ import annotations

import io
import os
from dataclasses import dataclass, field
from pathlib import Path

from mcap.writer import CompressionType, Writer
from ruamel.yaml import YAML

from agent.protocol.errors import UserError
from agent.sph.obstacles import obstacles_from
from fluidswarm.recording import ros2_messages as m
from fluidswarm.recording import schemas as sc
from fluidswarm.recording.reader import Recording
from fluidswarm.recording.writer import code_version
from ros2link import cdr
from ros2link.rmw import KEEP_ALL, RELIABLE, TRANSIENT_LOCAL, Qos

VERSION = 9  # rosbag2's metadata version (Jazzy)


def qos_profiles(qos: Qos) -> list[dict]:
    """rosbag2's `offered_qos_profiles` (version 9): one profile, the publisher's."""
    return [
        {
            "history": "keep_all" if qos.history == KEEP_ALL else "keep_last",
            "depth": qos.depth,
            "reliability": "reliable" if qos.reliability == RELIABLE else "best_effort",
            "durability": "transient_local" if qos.durability == TRANSIENT_LOCAL else "volatile",
            "deadline": {"sec": qos.deadline[0], "nsec": qos.deadline[1]},
            "lifespan": {"sec": qos.lifespan[0], "nsec": qos.lifespan[1]},
            "liveliness": "automatic",
            "liveliness_lease_duration": {"sec": qos.lease[0], "nsec": qos.lease[1]},
            "avoid_ros_namespace_conventions": False,
        }
    ]


def _yaml(value) -> str:
    yaml = YAML(typ="safe")
    yaml.default_flow_style = False
    out = io.StringIO()
    yaml.dump(value, out)
    return out.getvalue()


def check_bag_dir(path: Path) -> None:
    """A new directory at `path` can be made: else one line naming it (before anything is read or written)."""
    if path.exists() or path.is_symlink():
        raise UserError(f"--ros2-bag {path}: it exists (rosbag2 writes a new directory)")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise UserError(f"--ros2-bag {path}: no such directory {parent}")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise UserError(f"--ros2-bag {path}: {parent} cannot be written (permission denied)")


@dataclass
class BagSummary:
    path: Path
    counts: dict[str, int] = field(default_factory=dict)  # topic -> messages


def messages(run: Recording):
    """(topic, log time ns, CDR) of everything the bag holds, in time order per topic."""
    obstacles = m.obstacle_loops(obstacles_from(run.metadata.get("obstacles", [])))
    for f in run.frames:
        yaw = m.headings(f.velocities, None)
        ns = sc.seconds_to_ns(f.t)
        yield m.CLOCK, ns, m.clock(f.t)
        yield m.POSES, ns, m.poses(f.t, f.ids, f.positions, yaw)
        yield m.TF, ns, m.transforms(f.t, f.ids, f.positions, yaw)
        yield m.PARTICLES, ns, m.particles(f.t, f.ids, f.positions, f.density, f.pressure)
    targets = [(t.t, m.outline_loops(t.mask, t.transform)) for t in run.targets] or ([(0.0, [])] if obstacles else [])
    for t, loops in targets:
        yield m.TARGET, sc.seconds_to_ns(t), m.markers(t, loops, obstacles)
    for t, command in run.commands:
        yield m.COMMAND, sc.seconds_to_ns(t), m.text(m.command_text(command))
    for e in run.events:
        yield m.EVENTS, sc.seconds_to_ns(e.t), m.text(m.event_text(e.level, e.name, e.message, e.kind, e.agent, e.step))
    for image in run.images:
        yield m.IMAGE, sc.seconds_to_ns(image.t), m.compressed_image(image.t, image.data, image.format, image.frame_id)


def write_bag(run: Recording, path: Path) -> BagSummary:
    """Write `run` as the rosbag2 directory `path` (which must not exist: check_bag_dir)."""
    check_bag_dir(path)
    try:
        path.mkdir()
        return _write(run, path)
    except OSError as exc:
        raise UserError(f"--ros2-bag {path}: cannot be written ({exc.strerror or exc})") from None


def _write(run: Recording, path: Path) -> BagSummary:
    name = f"{path.name}_0.mcap"
    summary = BagSummary(path)
    by_topic: dict[str, list[tuple[int, bytes]]] = {}
    for topic, ns, data in messages(run):
        by_topic.setdefault(topic, []).append((ns, data))
    used = [t for t in m.TOPICS if by_topic.get(t.name)]
    with open(path / name, "wb") as stream:
        writer = Writer(stream, compression=CompressionType.ZSTD)
        writer.start(profile="ros2", library=f"fluidswarm {code_version()}")
        channels = {}
        for t in used:
            schema = writer.register_schema(t.msgtype, "ros2msg", cdr.msgdef(t.msgtype).encode())
            channels[t.name] = writer.register_channel(
                t.name,
                "cdr",
                schema,
                {"offered_qos_profiles": _yaml(qos_profiles(t.qos)), "topic_type_hash": cdr.type_hash(t.msgtype)},
            )
        stream_order = sorted(
            ((ns, k, t.name, data) for t in used for k, (ns, data) in enumerate(by_topic[t.name])),
            key=lambda item: item[0],
        )
        sequence: dict[str, int] = {}
        for ns, _k, topic, data in stream_order:
            sequence[topic] = sequence.get(topic, 0) + 1
            writer.add_message(channels[topic], log_time=ns, data=data, publish_time=ns, sequence=sequence[topic])
        summary.counts = {t.name: len(by_topic[t.name]) for t in used}
        times = [ns for ns, *_ in stream_order]
        start, duration = (min(times), max(times) - min(times)) if times else (0, 0)
        info = {
            "version": VERSION,
            "storage_identifier": "mcap",
            "duration": {"nanoseconds": duration},
            "starting_time": {"nanoseconds_since_epoch": start},
            "message_count": len(times),
            "topics_with_message_count": [
                {
                    "topic_metadata": {
                        "name": t.name,
                        "type": t.msgtype,
                        "serialization_format": "cdr",
                        "offered_qos_profiles": qos_profiles(t.qos),
                        "type_description_hash": cdr.type_hash(t.msgtype),
                    },
                    "message_count": summary.counts[t.name],
                }
                for t in used
            ],
            "compression_format": "",
            "compression_mode": "",
            "relative_file_paths": [name],
            "files": [
                {
                    "path": name,
                    "starting_time": {"nanoseconds_since_epoch": start},
                    "duration": {"nanoseconds": duration},
                    "message_count": len(times),
                }
            ],
            "custom_data": {"fluidswarm.run": str(run.name)},
            "ros_distro": "jazzy",
        }
        writer.add_metadata("rosbag2", {"serialized_metadata": _yaml(info)})
        writer.finish()
    (path / "metadata.yaml").write_text(_yaml({"rosbag2_bagfile_information": info}))
    return summary
