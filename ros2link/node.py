"""One ROS 2 node on rmw_zenoh's bus (ros2link/rmw.py): its own Zenoh session to the ROS 2 system's router,
its node token (NN), a token per publisher (MP) and subscriber (MS), samples with the attachment rmw_zenoh wants.

One node for the whole run (`/fluidswarm`): hundreds of nodes hurt rmw_zenoh's graph (its issues #318, #408).
The session carries no credentials of the run's (rmw.session_config): the swarm's own router is never reached
from here, and nothing but this session touches the ROS 2 side.
"""

from __future__ import annotations

import itertools
import threading
import time
from collections.abc import Callable

import zenoh
import zenoh.ext

from ros2link import rmw

MISS_HEARTBEAT_S = 0.5  # rmw_zenoh's SAMPLE_MISS_DETECTION_HEARTBEAT_PERIOD (rmw_publisher_data.cpp), sporadic


class Publisher:
    """One topic's publisher: its MP token, its key, its sequence numbers (from 1, as rmw_zenoh's)."""

    def __init__(self, session: zenoh.Session, entity: rmw.Entity):
        self.entity, self.key, self.gid = entity, entity.key, entity.gid
        self.sequence = 0
        reliability = (
            zenoh.Reliability.RELIABLE if entity.qos.reliability == rmw.RELIABLE else zenoh.Reliability.BEST_EFFORT
        )
        self._pub: zenoh.Publisher | zenoh.ext.AdvancedPublisher
        if entity.qos.durability == rmw.TRANSIENT_LOCAL:
            # as rmw_zenoh's: a cache of `depth` samples that late transient-local subscribers query, and (reliable)
            # the sample-miss heartbeat its reliable transient-local subscribers recover lost samples by
            reliable = entity.qos.reliability == rmw.RELIABLE
            self._pub = zenoh.ext.declare_advanced_publisher(
                session,
                self.key,
                cache=zenoh.ext.CacheConfig(max_samples=entity.qos.depth),
                sample_miss_detection=zenoh.ext.MissDetectionConfig(heartbeat=None, sporadic_heartbeat=MISS_HEARTBEAT_S)
                if reliable
                else None,
                publisher_detection=True,
                reliability=reliability,
                congestion_control=zenoh.CongestionControl.DROP,
            )
        else:
            # DROP, as rmw_zenoh's keep-last publishers: a slow ROS 2 side never holds this process up
            self._pub = session.declare_publisher(
                self.key, reliability=reliability, congestion_control=zenoh.CongestionControl.DROP
            )
        self._token = session.liveliness().declare_token(entity.token)

    def put(self, cdr: bytes) -> None:
        self.sequence += 1
        self._pub.put(cdr, attachment=rmw.attachment(self.sequence, time.time_ns(), self.gid))

    def undeclare(self) -> None:
        for part in (self._token, self._pub):
            try:
                part.undeclare()
            except Exception:  # noqa: BLE001, S110  # a session already closed or lost: nothing left to withdraw
                pass


class Node:
    """`/fluidswarm` (or `name`) on domain `domain` of the router at `endpoint`. `open` may raise
    zenoh.ZError (no router there within `timeout` s)."""

    def __init__(self, endpoint: str, domain: int, name: str = "fluidswarm", namespace: str = "/"):
        self.endpoint, self.domain, self.name, self.namespace = endpoint, domain, name, namespace
        self.session: zenoh.Session | None = None
        self._ids = itertools.count()
        self._parts: list = []
        self.node: rmw.Entity | None = None

    def open(self, timeout: float) -> None:
        self.session = zenoh.open(rmw.session_config(self.endpoint, int(timeout * 1000)))
        nid = str(next(self._ids))
        self.node = rmw.Entity(
            self.domain, str(self.session.info.zid()), nid, nid, rmw.NODE, "/", self.namespace, self.name
        )
        self._parts.append(self.session.liveliness().declare_token(self.node.token))

    def _entity(self, kind: str, topic: str, msgtype: str, type_hash: str, qos: rmw.Qos) -> rmw.Entity:
        assert self.node is not None and self.session is not None, "open() first"
        return rmw.Entity(
            self.domain,
            self.node.zid,
            self.node.nid,
            str(next(self._ids)),
            kind,
            "/",
            self.namespace,
            self.name,
            topic,
            msgtype,
            type_hash,
            qos,
        )

    def publisher(self, topic: str, msgtype: str, type_hash: str, qos: rmw.Qos) -> Publisher:
        assert self.session is not None, "open() first"
        pub = Publisher(self.session, self._entity(rmw.PUBLISHER, topic, msgtype, type_hash, qos))
        self._parts.append(pub)
        return pub

    def subscriber(
        self, topic: str, msgtype: str, type_hash: str, qos: rmw.Qos, on_sample: Callable[[zenoh.Sample], None]
    ) -> rmw.Entity:
        """A subscriber of `topic` and its MS token (without it `ros2 topic pub` waits for a match forever)."""
        assert self.session is not None, "open() first"
        entity = self._entity(rmw.SUBSCRIBER, topic, msgtype, type_hash, qos)
        self._parts.append(self.session.declare_subscriber(entity.key, on_sample))
        self._parts.append(self.session.liveliness().declare_token(entity.token))
        return entity

    def publishers_of(self, topic: str, timeout: float) -> list[rmw.Entity]:
        """The publishers of `topic` on this domain the ROS 2 graph knows now (a liveliness query)."""
        assert self.session is not None, "open() first"
        found = []
        for reply in self.session.liveliness().get(f"{rmw.ADMIN_SPACE}/{self.domain}/**", timeout=timeout):
            entity = rmw.parse_token(str(reply.ok.key_expr)) if reply.ok is not None else None
            if entity is not None and entity.kind == rmw.PUBLISHER and entity.topic == topic:
                found.append(entity)
        return found

    def connected(self) -> bool:
        """Whether the session has a router now (it reconnects by itself after a loss)."""
        return self.session is not None and any(True for _ in self.session.info.routers_zid())

    def close(self) -> None:
        """Withdraw every token, publisher and subscriber, then close the session; never raises."""
        for part in reversed(self._parts):
            try:
                part.undeclare()
            except Exception:  # noqa: BLE001, S110  # already gone with a lost session
                pass
        self._parts.clear()
        if self.session is not None:
            session, self.session = self.session, None
            closer = threading.Thread(target=session.close, daemon=True)  # a lost router must not hold the exit
            closer.start()
            closer.join(2.0)
