"""A stand-in for the ROS 2 side in tests (docs/ros2.md "What was verified here"): a plain Zenoh router in a
process of its own where rmw_zenohd would be, and a peer that reads rmw_zenoh's format the way a ROS 2 node does,
written here from rmw_zenoh's sources (liveliness_utils.cpp, attachment_helpers.cpp), not with the product's
ros2link/rmw.py: tokens split by its key-expression indexes, the attachment unpacked by hand, the GID
recomputed with XXH3-128, CDR decoded by rosbags."""

from __future__ import annotations

import struct
import subprocess
import sys
import threading
from dataclasses import dataclass

import xxhash
import zenoh
from rosbags.typesys import Stores, get_typestore

from tests.swarm_helpers import wait_until

ROUTER = """
import sys, time, zenoh
c = zenoh.Config()
c.insert_json5("mode", '"router"')
c.insert_json5("listen/endpoints", '["' + sys.argv[1] + '"]')
c.insert_json5("scouting/multicast/enabled", "false")
c.insert_json5("timestamping/enabled", "true")
s = zenoh.open(c)
print("up", flush=True)
sys.stdin.read()  # until the test closes its end
"""
TYPESTORE = get_typestore(Stores.ROS2_JAZZY)


def start_router(endpoint: str) -> subprocess.Popen:
    """A plain eclipse-zenoh router listening on `endpoint`, in its own process (stdin closed: it exits)."""
    proc = subprocess.Popen(
        [sys.executable, "-c", ROUTER, endpoint], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    assert proc.stdout is not None and proc.stdout.readline().strip() == "up"
    return proc


def stop_router(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.kill()
    proc.wait(10)


@dataclass(frozen=True)
class Token:
    """A liveliness token split at rmw_zenoh's KeyexprIndex positions."""

    key: str
    domain: int
    zid: str
    nid: str
    id: str
    kind: str
    enclave: str
    namespace: str
    node: str
    topic: str = ""
    dds_type: str = ""
    type_hash: str = ""
    qos: str = ""

    @property
    def msgtype(self) -> str:
        pkg, kind, _, name = self.dds_type.split("::")
        return f"{pkg}/{kind}/{name.removesuffix('_')}"

    @property
    def data_key(self) -> str:
        return f"{self.domain}/{self.topic.strip('/')}/{self.dds_type}/{self.type_hash}"

    @property
    def gid(self) -> bytes:
        h = xxhash.xxh3_128_intdigest(self.key.encode())
        return struct.pack("<QQ", h & (2**64 - 1), h >> 64)


def split_token(key: str) -> Token:
    parts = key.split("/")
    assert parts[0] == "@ros2_lv" and all(parts), key
    assert len(parts) in (9, 13), key
    un = [p.replace("%", "/") for p in parts]
    return Token(key, int(parts[1]), parts[2], parts[3], parts[4], parts[5], un[6], un[7], un[8], *un[9:13])


def unpack_attachment(data: bytes) -> tuple[int, int, bytes]:
    """int64 sequence number, int64 source timestamp, then the 16-byte GID behind its one-byte length."""
    assert len(data) == 33, len(data)
    seq, stamp, n = struct.unpack_from("<qqB", data)
    assert n == 16
    return seq, stamp, data[17:]


class Peer:
    """A zenoh client of the router at `endpoint`, as a ROS 2 process's session would be."""

    def __init__(self, endpoint: str):
        conf = zenoh.Config()
        conf.insert_json5("mode", '"client"')
        conf.insert_json5("connect/endpoints", f'["{endpoint}"]')
        conf.insert_json5("scouting/multicast/enabled", "false")
        conf.insert_json5("timestamping/enabled", "true")
        self.session = zenoh.open(conf)
        self.lock = threading.Lock()
        self.samples: dict[str, list[tuple[bytes, bytes | None]]] = {}
        self._subs: list = []

    def tokens(self, domain: int) -> list[Token]:
        """Every token of `domain` now: a liveliness query on @ros2_lv/<domain>/**."""
        replies = self.session.liveliness().get(f"@ros2_lv/{domain}/**", timeout=2.0)
        return [split_token(str(r.ok.key_expr)) for r in replies if r.ok is not None]

    def wait_tokens(self, domain: int, want: int, timeout: float) -> list[Token]:
        found: list[Token] = []

        def enough() -> bool:
            found[:] = self.tokens(domain)
            return len(found) >= want

        assert wait_until(enough, timeout, every=0.2), f"{len(found)} tokens: {[t.key for t in found]}"
        return found

    def subscribe(self, key: str, latched: bool = False) -> None:
        """Keep every sample on `key` (payload, attachment); `latched`: as a reliable transient-local subscriber of
        rmw_zenoh's (rmw_subscription_data.cpp): an AdvancedSubscriber asking late publishers' caches for what
        they sent before, recovering missed samples by their heartbeat."""
        self.samples.setdefault(key, [])

        def keep(sample) -> None:
            att = sample.attachment.to_bytes() if sample.attachment is not None else None
            with self.lock:
                self.samples[key].append((sample.payload.to_bytes(), att))

        if latched:
            self._subs.append(
                zenoh.ext.declare_advanced_subscriber(
                    self.session,
                    key,
                    keep,
                    history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=1),
                    recovery=zenoh.ext.RecoveryConfig(heartbeat=True),
                    subscriber_detection=True,
                )
            )
        else:
            self._subs.append(self.session.declare_subscriber(key, keep))

    def declare_token(self, key: str):
        token = self.session.liveliness().declare_token(key)
        self._subs.append(token)
        return token

    def put(self, key: str, payload: bytes, attachment: bytes) -> None:
        self.session.put(key, payload, attachment=attachment)

    def close(self) -> None:
        for s in self._subs:
            s.undeclare()
        self.session.close()


def decode(data: bytes, msgtype: str):
    return TYPESTORE.deserialize_cdr(data, msgtype)
