"""The gesture command (wire format v1, docs/command.md): parameters only, signed, strictly validated.

The typed command (dataclasses) is here; its encoding, signature, verification and every check of a received
one are the agent crate's (agent/native/src/command.rs, through agent._native), so the coordinator and the
agents share one implementation.

A command holds particle classes (each a share of the swarm and a route of waypoints with the body-force
parameters of eq. 6.2, and optional stiffness/viscosity switches), the swarm size the shares refer to,
and nothing per particle. The envelope is `{"v":1,"body":` BODY `,"sig":"` HMAC-SHA256(secret, BODY) in hex
`"}`: the signature covers the body's bytes as sent, so a receiver checks it before reading any JSON. The
secret is made by the launcher per run and handed to the coordinator and the agents at start (environment),
never sent on the bus.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

from agent.protocol.errors import FluidswarmError
from agent.records import native
from agent.sph.params import SPHParams

# The bounds (docs/command.md), the agent crate's command.rs: what a receiver accepts.
VERSION = 1
MAX_BYTES = native.COMMAND_MAX_BYTES
MAX_CLASSES = native.COMMAND_MAX_CLASSES
MAX_ROUTE = native.COMMAND_MAX_ROUTE
MAX_COORD = native.COMMAND_MAX_COORD
MAX_RINGS = native.COMMAND_MAX_RINGS
MAX_VERTICES = native.COMMAND_MAX_VERTICES  # over all rings of a fill shape: the crossing check is O(V^2)
MAX_ZONES = native.COMMAND_MAX_ZONES  # material zones of a fill shape (fingers, arms)
MAX_DEPTH = native.COMMAND_MAX_DEPTH  # nested arrays/objects, the body counting 1


class CommandRejected(FluidswarmError, ValueError):
    """reason: 'malformed' | 'version' | 'signature' | 'replay'."""

    def __init__(self, reason: str, detail: str = ""):
        super().__init__(f"{reason}: {detail}" if detail else reason)
        self.reason = reason


@dataclass(frozen=True)
class Waypoint:
    """x, y [m]; r [m] radius with no force; s [m] ramp; alpha [1/s^2] gain (eq. 6.2); beta [N/m] and mu
    [kg/s] to switch to when the waypoint is reached (None: keep)."""

    x: float
    y: float
    r: float
    s: float
    alpha: float
    beta: float | None = None
    mu: float | None = None


@dataclass(frozen=True)
class ParticleClass:
    name: str
    share: float
    route: tuple[Waypoint, ...]


@dataclass(frozen=True)
class Zone:
    """Part of the shape where the fluid is another material (thesis ch. 6: the region controller switches
    beta 2 -> 20 in the arms and 2 -> 50 in the fingers): an ellipse with centre (x, y) [m], unit major axis
    (ux, uy) and semi-axes a, b [m]. An agent inside it, ((d.u)/a)^2 + ((d x u)/b)^2 <= 1 with d its offset
    from the centre, uses stiffness `beta` [N/m] and viscosity `mu` [kg/s]; the first zone that holds it wins."""

    x: float
    y: float
    ux: float
    uy: float
    a: float
    b: float
    beta: float
    mu: float


@dataclass(frozen=True)
class Fill:
    """The silhouette the swarm fills (agent/fill.py): `rings` of (x, y) vertices [m], closed implicitly,
    even-odd (a ring inside another is a hole), no two edges crossing; already eroded by half a particle
    spacing by the coordinator. A particle outside is pulled towards the nearest boundary point with gain
    `alpha` [1/s^2] over ramp `s` [m] (eq. 6.2); inside, no body force."""

    rings: tuple[tuple[tuple[float, float], ...], ...]
    alpha: float
    s: float
    zones: tuple[Zone, ...] = ()  # where stiffness/viscosity differ from the command's beta/mu


@dataclass(frozen=True)
class GestureCommand:
    seq: int  # strictly increasing per run: agents reject older ones (replay)
    gesture: str  # what the coordinator recognised (for logs)
    n_agents: int  # swarm size the shares are divided over
    classes: tuple[ParticleClass, ...]
    beta: float = SPHParams.beta  # stiffness before any switch (the fluid's)
    mu: float = SPHParams.mu  # viscosity before any switch
    extra: dict = field(default_factory=dict)  # free-form annotations (ellipses, controller) for logs only
    fill: Fill | None = None  # the shape to fill; with it, routes are not followed (classes still label)

    def body(self) -> dict:
        d = asdict(self)
        if self.fill is None:
            del d["fill"]  # commands without a shape keep their v1 bytes
        else:
            d["fill"] = {
                "rings": [[list(v) for v in ring] for ring in self.fill.rings],
                "alpha": self.fill.alpha,
                "s": self.fill.s,
            }
            if self.fill.zones:  # a shape without zones keeps its bytes
                d["fill"]["zones"] = [asdict(z) for z in self.fill.zones]
        d["classes"] = [
            {
                "name": c.name,
                "share": c.share,
                "route": [{k: v for k, v in asdict(w).items() if v is not None} for w in c.route],
            }
            for c in self.classes
        ]
        return d

    def encode(self, secret: bytes) -> bytes:
        """The signed envelope (agent._native: the one writer, command.rs sign)."""
        return native.command_sign(_canonical(self.body()), secret)


def _canonical(obj) -> bytes:
    """The one encoding of a body (agent._native: serde_json): keys sorted, no spaces, shortest round-trip
    numbers, UTF-8, no NaN (deterministic, so the same command is the same bytes and its republication is
    recognised without decoding). ValueError for what JSON cannot hold."""
    return native.command_canonical(obj)


def verify(data: bytes, secret: bytes) -> bytes:
    """The body bytes of an envelope, once their HMAC matches; raise CommandRejected, reading no JSON.

    The envelope is exactly `{"v":1,"body":` BODY `,"sig":"` HMAC-SHA256(secret, BODY) in hex `"}`, as `encode`
    writes it: a forgery costs the receiver one HMAC, and no second parser has to agree with the first."""
    if not isinstance(data, (bytes, bytearray)):
        raise CommandRejected("malformed", "not bytes")
    body = native.command_verify(bytes(data), secret)
    if isinstance(body, str):
        raise CommandRejected(body)
    return body


def decode(data: bytes, secret: bytes) -> GestureCommand:
    """Verify and parse an envelope from the network; raise CommandRejected with the reason.

    The body is JSON (RFC 8259) in UTF-8, read by serde_json (agent crate: command.rs, the compiled agent's
    own reader): no NaN/Infinity, no number beyond binary64, no lone surrogate, at most MAX_DEPTH deep."""
    if not isinstance(data, (bytes, bytearray)):
        raise CommandRejected("malformed", "not bytes")
    body = native.command_decode(bytes(data), secret)
    if isinstance(body, str):
        raise CommandRejected(body)
    return _typed(body)


def parse_body(body: dict) -> GestureCommand:
    """The typed command of a body given as Python objects (the coordinator's commands file), checked as an
    agent checks a received one; raise CommandRejected("malformed")."""
    reason = native.command_check_body(body)
    if reason is not None:
        raise CommandRejected(reason)
    return _typed(body)


def _typed(body: dict) -> GestureCommand:
    """The dataclasses of a body agent._native accepted (so every field is there, of its type and range)."""

    def opt(w: dict, key: str) -> float | None:
        return float(w[key]) if key in w else None

    classes = tuple(
        ParticleClass(
            c.get("name", ""),
            float(c["share"]),
            tuple(
                Waypoint(
                    float(w["x"]),
                    float(w["y"]),
                    float(w["r"]),
                    float(w["s"]),
                    float(w["alpha"]),
                    opt(w, "beta"),
                    opt(w, "mu"),
                )
                for w in c["route"]
            ),
        )
        for c in body["classes"]
    )
    fill = None
    if "fill" in body:
        f = body["fill"]
        fill = Fill(
            tuple(tuple((float(x), float(y)) for x, y in ring) for ring in f["rings"]),
            float(f["alpha"]),
            float(f["s"]),
            tuple(
                Zone(*(float(z[k]) for k in ("x", "y", "ux", "uy", "a", "b", "beta", "mu"))) for z in f.get("zones", [])
            ),
        )
    return GestureCommand(
        body["seq"],
        body.get("gesture", ""),
        body["n_agents"],
        classes,
        float(body["beta"]),
        float(body["mu"]),
        body.get("extra", {}),
        fill,
    )


def edges_cross(rings) -> bool:
    """Do two edges of the rings cross properly (each one's ends strictly on both sides of the other)?

    Touching (a shared vertex, a vertex on an edge, collinear overlap) is not crossing: adjacent edges
    share a vertex, and a pixel contour may touch itself. O(V^2): agent crate fill.rs, through agent._native.
    """
    return native.fill_edges_cross([[(float(x), float(y)) for x, y in ring] for ring in rings])
