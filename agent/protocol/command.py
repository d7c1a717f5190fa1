"""The gesture command (wire format v1, docs/command.md): parameters only, signed, strictly validated.

A command holds particle classes (each a share of the swarm and a route of waypoints with the body-force
parameters of eq. 6.2, and optional stiffness/viscosity switches), the swarm size the shares refer to,
and nothing per particle. The envelope is `{"v":1,"body":` BODY `,"sig":"` HMAC-SHA256(secret, BODY) in hex
`"}`: the signature covers the body's bytes as sent, so a receiver checks it before reading any JSON. The
secret is made by the launcher per run and handed to the coordinator and the agents at start (environment),
never sent on the bus.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import math
from dataclasses import asdict, dataclass, field

VERSION = 1
MAX_BYTES = 64 * 1024
MAX_CLASSES = 64
MAX_ROUTE = 32
MAX_COORD = 1e6
MAX_RINGS = 32
MAX_VERTICES = 512  # over all rings of a fill shape: the crossing check is O(V^2) in every agent
MAX_ZONES = 16  # material zones of a fill shape (fingers, arms)
MAX_DEPTH = 32  # nested arrays/objects, the body counting 1: a command nests 5 deep, its annotations a few more


class CommandRejected(ValueError):
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
    beta: float = 2.0  # stiffness before any switch
    mu: float = 0.0  # viscosity before any switch
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
        body = _canonical(self.body())
        sig = hmac.new(secret, body, hashlib.sha256).hexdigest()
        return _V1 + body + _SIG_KEY + sig.encode() + _TAIL_END


_HEAD = b'{"v":'
_V1 = b'{"v":1,"body":'
_SIG_KEY = b',"sig":"'
_TAIL_END = b'"}'
_TAIL_LEN = len(_SIG_KEY) + 64 + len(_TAIL_END)


def _canonical(obj) -> bytes:
    """The one encoding of a body: keys sorted, no spaces, ASCII only, no NaN (deterministic, so the same
    command is the same bytes and its republication is recognised without decoding)."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False).encode()


def _num(d: dict, key: str, lo: float, hi: float, optional: bool = False):
    if key not in d:
        if optional:
            return None
        raise CommandRejected("malformed", f"missing {key}")
    v = d[key]
    if isinstance(v, int) and not isinstance(v, bool) and abs(v) > 2**1023:  # float(v) would overflow
        raise CommandRejected("malformed", f"{key} out of range")
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not lo <= v <= hi:
        raise CommandRejected("malformed", f"{key}={v!r} not in [{lo}, {hi}]")
    return float(v)


def _only(d, allowed: set, where: str) -> None:
    if not isinstance(d, dict):
        raise CommandRejected("malformed", f"{where} is not an object")
    extra = set(d) - allowed
    if extra:
        raise CommandRejected("malformed", f"{where}: unknown field {min(extra)!r}")


def _no_constant(name: str):
    raise ValueError(f"{name} is not allowed")


def _finite(text: str) -> float:
    v = float(text)
    if not math.isfinite(v):
        raise ValueError(f"{text[:20]} is not finite")
    return v


def _int(text: str):
    """A JSON integer as the compiled agent's serde_json reads it: -0 is the float -0.0 (so it is no valid
    `seq`), and one that no binary64 holds (beyond ~1.8e308) is refused."""
    if text == "-0":
        return -0.0
    v = int(text)
    float(v)  # OverflowError (an ArithmeticError, not a ValueError): caught in `decode`
    return v


def _plain(v, depth: int = 1) -> None:
    """What serde_json refuses and Python's json accepts: a lone surrogate (no UTF-8 holds it) in a string or
    a key; and, on both sides, containers nested deeper than MAX_DEPTH."""
    if isinstance(v, str):
        v.encode()  # UnicodeEncodeError (a ValueError) on a lone surrogate
    elif isinstance(v, (dict, list)):
        if depth > MAX_DEPTH:
            raise ValueError(f"nested deeper than {MAX_DEPTH}")
        for k in v if isinstance(v, dict) else ():
            k.encode()
        for x in v.values() if isinstance(v, dict) else v:
            _plain(x, depth + 1)


def verify(data: bytes, secret: bytes) -> bytes:
    """The body bytes of an envelope, once their HMAC matches; raise CommandRejected, reading no JSON.

    The envelope is exactly `{"v":1,"body":` BODY `,"sig":"` HMAC-SHA256(secret, BODY) in hex `"}`, as `encode`
    writes it: a forgery costs the receiver one HMAC, and no second parser has to agree with the first."""
    if not isinstance(data, (bytes, bytearray)) or len(data) > MAX_BYTES:
        raise CommandRejected("malformed", "too large or not bytes")
    data = bytes(data)
    if not data.startswith(_V1):
        end = data.find(b",", len(_HEAD)) if data.startswith(_HEAD) else -1
        v = data[len(_HEAD) : end] if end >= 0 else b""
        if v.isdigit() and v != b"1":
            raise CommandRejected("version", f"v={v[:20].decode()}")
        raise CommandRejected("malformed", 'not an envelope {"v":1,"body":...,"sig":"..."}')
    n = len(data)
    if n < len(_V1) + _TAIL_LEN or data[n - _TAIL_LEN : n - 66] != _SIG_KEY or data[n - 2 :] != _TAIL_END:
        raise CommandRejected("signature", "unsigned, or not a hex HMAC-SHA256")
    body = data[len(_V1) : n - _TAIL_LEN]
    expected = hmac.new(secret, body, hashlib.sha256).hexdigest().encode()
    if not hmac.compare_digest(expected, data[n - 66 : n - 2]):
        raise CommandRejected("signature")
    return body


def decode(data: bytes, secret: bytes) -> GestureCommand:
    """Verify and parse an envelope from the network; raise CommandRejected with the reason.

    The body is JSON (RFC 8259) in UTF-8, read as serde_json reads it in the compiled agent: no NaN/Infinity,
    no number beyond binary64 (a float or an integer), no lone surrogate, at most MAX_DEPTH deep."""
    body = verify(data, secret)
    try:
        obj = json.loads(body.decode("utf-8"), parse_constant=_no_constant, parse_float=_finite, parse_int=_int)
        _plain(obj)
    except (ValueError, ArithmeticError, RecursionError) as exc:  # UnicodeError is a ValueError
        raise CommandRejected("malformed", f"not JSON: {str(exc)[:80]}") from None
    return parse_body(obj)


def parse_body(body: dict) -> GestureCommand:
    _only(body, {"seq", "gesture", "n_agents", "classes", "beta", "mu", "extra", "fill"}, "body")
    seq = body.get("seq")
    if isinstance(seq, bool) or not isinstance(seq, int) or not 0 <= seq < 2**62:
        raise CommandRejected("malformed", "seq")
    n = body.get("n_agents")
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 100000:
        raise CommandRejected("malformed", "n_agents")
    gesture = body.get("gesture", "")
    if not isinstance(gesture, str) or len(gesture) > 64:
        raise CommandRejected("malformed", "gesture")
    raw_classes = body.get("classes")
    if not isinstance(raw_classes, list) or not 1 <= len(raw_classes) <= MAX_CLASSES:
        raise CommandRejected("malformed", "classes")
    classes = []
    for c in raw_classes:
        _only(c, {"name", "share", "route"}, "class")
        name = c.get("name", "")
        if not isinstance(name, str) or len(name) > 64:
            raise CommandRejected("malformed", "class name")
        share = _num(c, "share", 0.0, 1e6)
        route = c.get("route")
        if not isinstance(route, list) or not 1 <= len(route) <= MAX_ROUTE:
            raise CommandRejected("malformed", "route")
        wps = []
        for w in route:
            _only(w, {"x", "y", "r", "s", "alpha", "beta", "mu"}, "waypoint")
            wps.append(
                Waypoint(
                    _num(w, "x", -MAX_COORD, MAX_COORD),
                    _num(w, "y", -MAX_COORD, MAX_COORD),
                    _num(w, "r", 0.0, MAX_COORD),
                    _num(w, "s", 0.0, MAX_COORD),
                    _num(w, "alpha", 0.0, 1e4),
                    _num(w, "beta", 0.0, 1e4, optional=True),
                    _num(w, "mu", 0.0, 1e4, optional=True),
                )
            )
        classes.append(ParticleClass(name, share, tuple(wps)))
    if sum(c.share for c in classes) <= 0:
        raise CommandRejected("malformed", "shares sum to 0")
    extra = body.get("extra", {})
    if not isinstance(extra, dict):
        raise CommandRejected("malformed", "extra")
    fill = _fill(body["fill"]) if "fill" in body else None
    return GestureCommand(
        seq, gesture, n, tuple(classes), _num(body, "beta", 0.0, 1e4), _num(body, "mu", 0.0, 1e4), extra, fill
    )


def _fill(f) -> Fill:
    _only(f, {"rings", "alpha", "s", "zones"}, "fill")
    raw = f.get("rings")
    if not isinstance(raw, list) or not 1 <= len(raw) <= MAX_RINGS:
        raise CommandRejected("malformed", "fill rings")
    rings, total = [], 0
    for ring in raw:
        if not isinstance(ring, list) or len(ring) < 3:
            raise CommandRejected("malformed", "fill ring has fewer than 3 vertices")
        total += len(ring)
        if total > MAX_VERTICES:
            raise CommandRejected("malformed", f"fill has more than {MAX_VERTICES} vertices")
        vs = []
        for v in ring:
            if not isinstance(v, list) or len(v) != 2:
                raise CommandRejected("malformed", "fill vertex is not [x, y]")
            vs.append((_num({"x": v[0]}, "x", -MAX_COORD, MAX_COORD), _num({"y": v[1]}, "y", -MAX_COORD, MAX_COORD)))
        rings.append(tuple(vs))
    if edges_cross(rings):
        raise CommandRejected("malformed", "fill rings cross themselves or each other")
    zones = tuple(_zone(z) for z in _zone_list(f))
    return Fill(tuple(rings), _num(f, "alpha", 0.0, 1e4), _num(f, "s", 0.0, MAX_COORD), zones)


def _zone_list(f: dict) -> list:
    raw = f.get("zones", [])
    if not isinstance(raw, list) or len(raw) > MAX_ZONES:
        raise CommandRejected("malformed", f"fill zones (a list of at most {MAX_ZONES})")
    return raw


def _zone(z) -> Zone:
    _only(z, {"x", "y", "ux", "uy", "a", "b", "beta", "mu"}, "fill zone")
    ux, uy = _num(z, "ux", -1.0, 1.0), _num(z, "uy", -1.0, 1.0)
    if abs(ux * ux + uy * uy - 1.0) > 1e-6:
        raise CommandRejected("malformed", "fill zone axis is not a unit vector")
    a, b = _num(z, "a", 0.0, MAX_COORD), _num(z, "b", 0.0, MAX_COORD)
    if not (a > 0.0 and b > 0.0):
        raise CommandRejected("malformed", "fill zone semi-axes must be > 0")
    return Zone(
        _num(z, "x", -MAX_COORD, MAX_COORD),
        _num(z, "y", -MAX_COORD, MAX_COORD),
        ux,
        uy,
        a,
        b,
        _num(z, "beta", 0.0, 1e4),
        _num(z, "mu", 0.0, 1e4),
    )


def _side(ax, ay, bx, by, cx, cy):
    """Sign of the turn a -> b -> c (+1 left, -1 right, 0 on the line)."""
    cross = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    return (cross > 0.0) - (cross < 0.0)


def edges_cross(rings) -> bool:
    """Do two edges of the rings cross properly (each one's ends strictly on both sides of the other)?

    Touching (a shared vertex, a vertex on an edge, collinear overlap) is not crossing: adjacent edges
    share a vertex, and a pixel contour may touch itself. O(V^2); the same test in agent/native/src/fill.rs.
    """
    edges = [(*ring[k], *ring[(k + 1) % len(ring)]) for ring in rings for k in range(len(ring))]
    for a in range(len(edges)):
        ax, ay, bx, by = edges[a]
        for b in range(a + 1, len(edges)):
            cx, cy, dx, dy = edges[b]
            if (
                _side(ax, ay, bx, by, cx, cy) * _side(ax, ay, bx, by, dx, dy) < 0
                and _side(cx, cy, dx, dy, ax, ay) * _side(cx, cy, dx, dy, bx, by) < 0
            ):
                return True
    return False
