"""rmw_zenoh's wire format (ROS 2's Zenoh middleware, ros2/rmw_zenoh; docs/ros2.md): key expressions, liveliness
tokens, QoS strings, the sample attachment and entity GIDs, written and read as rmw_zenoh_cpp does
(liveliness_utils.cpp, qos.cpp, attachment_helpers.cpp, rmw_publisher_data.cpp).

- data key: `<domain>/<topic without outer slashes>/<pkg>::msg::dds_::<Name>_/<RIHS01_ type hash>`;
- tokens: `@ros2_lv/<domain>/<zid>/<nid>/<id>/<NN|MP|MS>/<enclave>/<namespace>/<node>[/<topic>/<type>/<hash>/<qos>]`,
  names with `/` written as `%`;
- QoS: `reliability:durability:history,depth:deadline_s,deadline_ns:lifespan_s,lifespan_ns:liveliness,lease_s,lease_ns`,
  each field empty where it equals rmw_zenoh's default (reliable, volatile, keep last 42, infinite times,
  automatic liveliness);
- attachment (33 bytes, zenoh's ext serializer): sequence number int64, source timestamp int64 (wall clock ns),
  GID as 16 bytes behind its length; rmw_zenoh drops a sample without it;
- GID: XXH3-128 of the entity's token, low half then high half, little-endian.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, replace

import xxhash
import zenoh
import zenoh.ext

ADMIN_SPACE = "@ros2_lv"
NODE, PUBLISHER, SUBSCRIBER = "NN", "MP", "MS"
ENTITIES = (NODE, PUBLISHER, SUBSCRIBER, "SS", "SC")
DEFAULT_ROUTER = "tcp/localhost:7447"  # rmw_zenohd's endpoint
DOMAIN_ENV = "ROS_DOMAIN_ID"
MAX_DOMAIN = 232  # ROS 2's largest domain id
ATTACHMENT_BYTES = 33

# rmw's enums (rmw/types.h)
RELIABLE, BEST_EFFORT = 1, 2
TRANSIENT_LOCAL, VOLATILE = 1, 2
KEEP_LAST, KEEP_ALL = 1, 2
AUTOMATIC = 1
INFINITE = (9223372036, 854775807)  # RMW_DURATION_INFINITE as (sec, nsec)


@dataclass(frozen=True)
class Qos:
    """An rmw QoS profile (rmw's enum values; durations as (sec, nsec))."""

    reliability: int = RELIABLE
    durability: int = VOLATILE
    history: int = KEEP_LAST
    depth: int = 42
    deadline: tuple[int, int] = INFINITE
    lifespan: tuple[int, int] = INFINITE
    liveliness: int = AUTOMATIC
    lease: tuple[int, int] = INFINITE


DEFAULT_QOS = Qos()  # rmw_zenoh's defaults (qos.cpp)


def qos_keyexpr(qos: Qos) -> str:
    """The token's QoS field: each value that differs from rmw_zenoh's default, in its place."""

    def f(value, default) -> str:
        return "" if value == default else str(value)

    d = DEFAULT_QOS
    return ":".join(
        (
            f(qos.reliability, d.reliability),
            f(qos.durability, d.durability),
            f(qos.history, d.history) + "," + f(qos.depth, d.depth),
            f(qos.deadline[0], d.deadline[0]) + "," + f(qos.deadline[1], d.deadline[1]),
            f(qos.lifespan[0], d.lifespan[0]) + "," + f(qos.lifespan[1], d.lifespan[1]),
            ",".join((f(qos.liveliness, d.liveliness), f(qos.lease[0], d.lease[0]), f(qos.lease[1], d.lease[1]))),
        )
    )


def parse_qos(text: str) -> Qos | None:
    """A token's QoS field read back (None if it is not one)."""
    parts = text.split(":")
    if len(parts) != 6:
        return None
    groups = [parts[0:1], parts[1:2], *(p.split(",") for p in parts[2:])]
    if [len(g) for g in groups] != [1, 1, 2, 2, 2, 3] or any(v and not v.isdigit() for g in groups for v in g):
        return None
    d = DEFAULT_QOS

    def n(value: str, default: int) -> int:
        return int(value) if value else default

    (rel,), (dur,), (hist, depth), (dl_s, dl_ns), (ls_s, ls_ns), (live, lease_s, lease_ns) = groups
    return Qos(
        n(rel, d.reliability),
        n(dur, d.durability),
        n(hist, d.history),
        n(depth, d.depth),
        (n(dl_s, d.deadline[0]), n(dl_ns, d.deadline[1])),
        (n(ls_s, d.lifespan[0]), n(ls_ns, d.lifespan[1])),
        n(live, d.liveliness),
        (n(lease_s, d.lease[0]), n(lease_ns, d.lease[1])),
    )


def domain_from_env(environ=os.environ) -> int:
    """ROS_DOMAIN_ID (default 0); ValueError naming it when it is not a domain id."""
    raw = environ.get(DOMAIN_ENV, "").strip()
    if not raw:
        return 0
    if not raw.isdigit() or int(raw) > MAX_DOMAIN:
        raise ValueError(f"{DOMAIN_ENV}={raw!r} is not a ROS 2 domain id (0..{MAX_DOMAIN})")
    return int(raw)


_NAME = re.compile(r"^(/[A-Za-z_][A-Za-z0-9_]*)+$")


def valid_topic(topic: str) -> bool:
    """A fully qualified ROS 2 topic name (`/a/b_c`): what a key chunk can carry."""
    return bool(_NAME.match(topic)) and "__" not in topic


def dds_type(msgtype: str) -> str:
    """`geometry_msgs/msg/PoseArray` -> `geometry_msgs::msg::dds_::PoseArray_`, the type name in keys and tokens."""
    pkg, kind, name = msgtype.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def ros_type(dds: str) -> str | None:
    """The inverse of dds_type (None if `dds` is not such a name)."""
    m = re.fullmatch(r"([A-Za-z0-9_]+)::(msg|srv|action)::dds_::([A-Za-z0-9_]+)_", dds)
    return f"{m[1]}/{m[2]}/{m[3]}" if m else None


def topic_key(domain: int, topic: str, msgtype: str, type_hash: str) -> str:
    """The data key expression of `topic` (rmw_zenoh TopicInfo: outer slashes stripped)."""
    return f"{domain}/{topic.strip('/')}/{dds_type(msgtype)}/{type_hash}"


def mangle(name: str) -> str:
    return name.replace("/", "%")


def demangle(name: str) -> str:
    return name.replace("%", "/")


@dataclass(frozen=True)
class Entity:
    """One liveliness token's fields (rmw_zenoh liveliness::Entity)."""

    domain: int
    zid: str
    nid: str
    id: str
    kind: str  # NN, MP, MS, SS, SC
    enclave: str = "/"
    namespace: str = "/"
    node: str = ""
    topic: str = ""  # below: publishers and subscribers only
    msgtype: str = ""  # ROS form, e.g. geometry_msgs/msg/PoseArray
    type_hash: str = ""
    qos: Qos = DEFAULT_QOS

    @property
    def token(self) -> str:
        parts = [
            ADMIN_SPACE,
            str(self.domain),
            self.zid,
            self.nid,
            self.id,
            self.kind,
            mangle(self.enclave),
            mangle(self.namespace),
            mangle(self.node),
        ]
        if self.kind != NODE:
            parts += [mangle(self.topic), dds_type(self.msgtype), self.type_hash, qos_keyexpr(self.qos)]
        return "/".join(parts)

    @property
    def gid(self) -> bytes:
        """16 bytes: XXH3-128 of the token, low 64 bits first, each little-endian (as rmw_zenoh's Entity)."""
        return xxhash.xxh3_128_intdigest(self.token.encode()).to_bytes(16, "little")

    @property
    def key(self) -> str:
        return topic_key(self.domain, self.topic, self.msgtype, self.type_hash)


def parse_token(key: str) -> Entity | None:
    """A liveliness key read by rmw_zenoh's rules (Entity::make): None for anything else."""
    parts = key.split("/")
    if len(parts) < 9 or parts[0] != ADMIN_SPACE or any(not p for p in parts) or parts[5] not in ENTITIES:
        return None
    if not parts[1].isdigit():
        return None
    base = Entity(
        int(parts[1]),
        parts[2],
        parts[3],
        parts[4],
        parts[5],
        demangle(parts[6]),
        demangle(parts[7]),
        demangle(parts[8]),
    )
    if base.kind == NODE:
        return base if len(parts) == 9 else None
    if len(parts) != 13:
        return None
    qos, msgtype = parse_qos(parts[12]), ros_type(parts[10])
    if qos is None or msgtype is None:
        return None
    return replace(base, topic=demangle(parts[9]), msgtype=msgtype, type_hash=parts[11], qos=qos)


def attachment(sequence: int, timestamp_ns: int, gid: bytes) -> bytes:
    """The 33 bytes every rmw_zenoh sample carries, by zenoh's own serializer (as rmw_zenoh's AttachmentData)."""
    return zenoh.ext.z_serialize((zenoh.ext.Int64(sequence), zenoh.ext.Int64(timestamp_ns), bytes(gid))).to_bytes()


def parse_attachment(data: bytes | None) -> tuple[int, int, bytes] | None:
    """(sequence number, source timestamp ns, GID) of an attachment; None if it is not one."""
    if data is None or len(data) != ATTACHMENT_BYTES or data[16] != 16:
        return None
    try:
        seq, stamp, gid = zenoh.ext.z_deserialize(
            tuple[zenoh.ext.Int64, zenoh.ext.Int64, bytes], zenoh.ZBytes(bytes(data))
        )
    except (zenoh.ext.ZDeserializeError, TypeError, ValueError):
        return None
    return int(seq), int(stamp), bytes(gid)


def session_config(endpoint: str, timeout_ms: int) -> zenoh.Config:
    """A client of the ROS 2 system's router at `endpoint`, as rmw_zenoh's sessions are (client mode; no
    scouting), and nothing of the swarm's: no credentials (the run's own are never sent to it)."""
    conf = zenoh.Config()
    conf.insert_json5("mode", '"client"')
    conf.insert_json5("connect/endpoints", f'["{endpoint}"]')
    conf.insert_json5("connect/timeout_ms", str(int(timeout_ms)))
    conf.insert_json5("scouting/multicast/enabled", "false")
    # as rmw_zenoh's session config: its transient-local publishers' caches order samples by timestamp
    conf.insert_json5("timestamping/enabled", "true")
    return conf


def check_endpoint(endpoint: str) -> str:
    """A zenoh endpoint `proto/host:port` (ValueError naming it otherwise)."""
    if not re.fullmatch(r"(tcp|udp|tls|quic|unixsock-stream)/\S+", endpoint or ""):
        raise ValueError(f"--ros2-router {endpoint!r} is not a zenoh endpoint (e.g. {DEFAULT_ROUTER})")
    return endpoint
