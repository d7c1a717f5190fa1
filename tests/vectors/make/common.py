"""What several vector files share: the fixed secrets, the signed envelope and the standard command with its
variants, and the list forms the Rust side reads."""

from __future__ import annotations

import hashlib
import hmac
import json
from pathlib import Path

from agent.protocol.command import GestureCommand, ParticleClass, Waypoint
from agent.sph.particle import Control

HERE = Path(__file__).resolve().parent.parent

# The digit-2 hand photo of the shared sign-language-digits set (IMG_1140.JPG), committed with the scenarios:
# the generator (and tests/test_vectors.py, which reruns it) needs no ../shared.
PHOTO = HERE.parent.parent / "scenarios" / "inputs" / "digit2_IMG_1140.JPG"

SECRET = bytes(range(32))
OTHER_SECRET = bytes(range(1, 33))
HEAD = b'{"v":1,"body":'


def canonical(body: dict) -> bytes:
    """The body bytes most vectors sign: Python json's sorted compact form (the encoder's before issue 34, so
    the committed payloads keep their bytes). Signed, any writer's bytes are a command; these can also hold
    what the one encoder (GestureCommand.encode, serde_json) refuses to write, such as integers beyond 64 bits."""
    return json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False).encode()


def framed(body: bytes, sig: bytes, head: bytes = HEAD) -> bytes:
    """The envelope's framing around these body bytes and this signature text, whatever they are."""
    return head + body + b',"sig":"' + sig + b'"}'


def sig_raw(body: bytes, secret: bytes = SECRET) -> bytes:
    return hmac.new(secret, body, hashlib.sha256).hexdigest().encode()


def sign_raw(body: bytes, secret: bytes = SECRET) -> bytes:
    """The envelope around exactly these body bytes, signed over them."""
    return framed(body, sig_raw(body, secret))


def sign(body: dict, secret: bytes = SECRET) -> bytes:
    return sign_raw(canonical(body), secret)


def reserialised(body: dict, **dumps) -> bytes:
    """The body's JSON written otherwise (json.dumps with these options): other bytes, the same values."""
    return json.dumps(body, **dumps).encode("utf-8")


def relaid(body: dict, v=1, sig: str | None = None) -> bytes:
    """The envelope as a JSON object laid out otherwise (keys reversed, indented), signed over the canonical
    body: what a v1 receiver once accepted, now no envelope (the signature must cover the bytes sent)."""
    env = {
        "sig": sig_raw(canonical(body)).decode() if sig is None else sig,
        "body": dict(reversed(list(body.items()))),
        "v": v,
    }
    return json.dumps(env, indent=1, ensure_ascii=False).encode("utf-8")


STANDARD = GestureCommand(
    seq=1,
    gesture="v_sign",
    n_agents=30,
    classes=(
        ParticleClass(
            "left", 1.0, (Waypoint(10.0, 12.5, 1.0, 3.0, 4.0, beta=5.0), Waypoint(20.0, 25.0, 0.5, 2.0, 6.0, mu=0.25))
        ),
        ParticleClass("right", 2.0, (Waypoint(40.0, 12.5, 1.0, 3.0, 4.0),)),
    ),
    beta=2.0,
    mu=0.0,
    extra={"controller": "region", "ellipses": [[1.5, 2.0, 0.3, -0.7]]},
)


def body(**changes) -> dict:
    """The standard command's body (a dict) with fields replaced."""
    b = STANDARD.body()
    b.update(changes)
    return b


def waypoint(**changes) -> dict:
    w = {"x": 1.0, "y": 2.0, "r": 0.5, "s": 1.0, "alpha": 3.0}
    w.update(changes)
    return w


def one_class(**changes) -> dict:
    c = {"name": "c", "share": 1.0, "route": [waypoint()]}
    c.update(changes)
    return c


def control_list(c: Control) -> list:
    return [c.wx, c.wy, c.r, c.s, c.alpha, c.beta, c.mu, c.push_x, c.push_y]
