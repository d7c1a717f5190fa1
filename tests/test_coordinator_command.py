"""The gesture command and the three controllers, without a swarm: schema (parameters only), strict
validation of untrusted input, the pure route following, the PCA templates and the ANN's command."""

from __future__ import annotations

import copy
import hashlib
import hmac
import itertools
import json
import os
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from agent.protocol.command import CommandRejected, Waypoint, _canonical, decode, verify
from agent.sph.particle import NFIELDS, Control, X, Y
from coordinator.control.imitation_setup import imitation_of_input
from coordinator.control.route import CommandFollower, RouteFollower, class_counts, class_of
from tests.swarm_helpers import PER_PARTICLE, field_names

REPO = Path(__file__).resolve().parent.parent
WAVE2 = REPO / "scenarios" / "inputs" / "weizmann_wave2_person0.png"
ALLOWED = {
    "v",
    "body",
    "sig",
    "seq",
    "gesture",
    "n_agents",
    "classes",
    "beta",
    "mu",
    "extra",
    "name",
    "share",
    "route",
    "x",
    "y",
    "r",
    "s",
    "alpha",
}


def sign_raw(b: bytes, secret: bytes) -> bytes:
    """The envelope around exactly these body bytes, signed over them."""
    return b'{"v":1,"body":' + b + b',"sig":"' + hmac.new(secret, b, hashlib.sha256).hexdigest().encode() + b'"}'


def sign(body: dict, secret: bytes) -> bytes:
    return sign_raw(_canonical(body), secret)


@pytest.fixture(scope="module")
def commands(shared_image):
    out = {}
    for name, path, frame in (
        ("v", shared_image(2), 0),
        ("one", shared_image(1), 0),
        ("wave_side", WAVE2, 14),
        ("wave_up", WAVE2, 0),
    ):
        for controller in ("region", "pca", "ann"):
            out[name, controller] = imitation_of_input(path, 30, controller, frame)
    return out


def test_every_controller_sends_parameters_only(commands):
    secret = os.urandom(32)
    for (name, controller), im in commands.items():
        env = json.loads(im.command.encode(secret))
        body = env["body"]
        fields = field_names({k: v for k, v in env.items() if k != "body"}) | field_names(
            {k: v for k, v in body.items() if k != "extra"}
        )
        assert fields <= ALLOWED, (name, controller, fields - ALLOWED)
        assert not fields & PER_PARTICLE
        assert decode(im.command.encode(secret), secret) == im.command
        assert all(c.share > 0 for c in im.command.classes) and im.command.n_agents == 30
        assert len(json.dumps(body["extra"])) < 2000  # annotations, not a hidden per-particle table


def test_pca_templates_and_body_regions(commands):
    assert commands["v", "pca"].command.gesture == "v_separation"
    assert commands["one", "pca"].command.gesture in ("pointing_at_angle", "horizontal_pointing")
    assert commands["wave_side", "pca"].command.gesture == "arms_sideways"
    assert commands["wave_up", "pca"].command.gesture == "both_arms_up"
    # the V template's two finger routes end left and right of the palm, above it
    cls = {c.name: c for c in commands["v", "pca"].command.classes}
    palm = cls["palm"].route[0]
    assert cls["finger_left"].route[-1].x < palm.x < cls["finger_right"].route[-1].x
    assert min(cls["finger_left"].route[-1].y, cls["finger_right"].route[-1].y) > palm.y
    # the fingers/arms switch stiffness at their first waypoint (thesis branching: 50 fingers, 20 arms)
    assert cls["finger_left"].route[0].beta == 50.0
    side = {c.name: c for c in commands["wave_side", "region"].command.classes}
    arms = [c for n, c in side.items() if n.startswith(("left_arm", "right_arm"))]
    assert arms and all(c.route[1].beta == 20.0 for c in arms)
    centre = side["torso0"].route[0]
    assert all(c.route[-1].x < centre.x for n, c in side.items() if n.startswith("left_arm"))
    assert all(c.route[-1].x > centre.x for n, c in side.items() if n.startswith("right_arm"))


def test_ann_controller_uses_the_network_force(commands):
    for name in ("v", "one"):
        cmd = commands[name, "ann"].command
        f_along, f_split = cmd.extra["force"]
        fingers = [c for c in cmd.classes if c.name.startswith("finger")]
        assert len(fingers) == (2 if f_split >= 0.25 else 1)
        assert fingers[0].route[-1].alpha == pytest.approx(np.clip(2.0 * max(f_along, 0.2), 0.5, 10.0), abs=1e-3)
        assert len(cmd.extra["features"]) == 6


def test_gesture_sequence_gets_a_new_command_per_change():
    cmds = [c for _first, c in imitation_of_input(WAVE2, 24, "region", frame=None).commands]
    assert len(cmds) >= 3
    assert [c.seq for c in cmds] == list(range(1, len(cmds) + 1))
    assert all(a.gesture != b.gesture for a, b in itertools.pairwise(cmds))
    assert {"left_up-right_up", "left_side-right_side"} <= {c.gesture for c in cmds}


def test_class_split_largest_remainder():
    assert class_counts(10, [3.0, 1.0, 1.0]) == [6, 2, 2]
    assert class_counts(7, [1, 1, 1]) == [3, 2, 2]
    assert [class_of(i, 10, [3.0, 1.0, 1.0]) for i in range(10)] == [0] * 6 + [1] * 2 + [2] * 2
    assert sum(class_counts(61, np.random.default_rng(0).random(17))) == 61


def test_route_follower_advances_within_r_and_switches_beta():
    route = [
        Waypoint(0, 0, 1.0, 2.0, 4.0),
        Waypoint(5, 0, 1.0, 2.0, 4.0, beta=20.0, mu=1.0),
        Waypoint(10, 0, 2.0, 2.0, 4.0),
    ]
    f = RouteFollower(route, beta=2.0, mu=0.2)
    state = np.zeros(NFIELDS)
    state[X], state[Y] = 3.0, 3.0
    c = f.control(state, 0)
    assert (c.wx, c.wy, c.r, c.alpha, c.beta, f.index) == (0, 0, 1.0, 4.0, 2.0, 0)
    state[X], state[Y] = 0.5, 0.0
    f.control(state, 1)
    assert f.index == 1 and f.beta == 2.0
    state[X] = 4.5
    c = f.control(state, 2)
    assert f.index == 2 and f.beta == 20.0 and f.mu == 1.0 and c.beta == 20.0
    state[X] = 10.0
    f.control(state, 3)
    assert f.index == 2  # the last waypoint is kept


def test_command_follower_rejects_and_changes_nothing(commands):
    im = commands["v", "region"]
    secret = os.urandom(32)
    spec = SimpleNamespace(id=3, secret=secret.hex(), static_control=lambda: Control(beta=2.0, mu=0.2))
    follower = CommandFollower(spec)
    state = im.setup.states[3].copy()
    before = follower.control(state, 0)
    body = json.loads(im.command.encode(secret))["body"]
    bad = [
        b"",
        b"{",
        b"null",
        b"[]",
        b"\xff\xfe",
        b"x" * 70000,
        im.command.encode(os.urandom(32)),
        json.dumps({"v": 2, "body": body, "sig": "0"}).encode(),
        json.dumps({"v": 1, "body": body}).encode(),
        b"[" * 30000 + b"]" * 30000,
        b'{"v":1,"body":{"seq":1e400},"sig":"00"}',
        b'{"v":1,"body":{"seq":NaN},"sig":"00"}',
        json.dumps({"v": 1, "body": body, "sig": "\u00e9" * 64}, ensure_ascii=False).encode(),
    ]
    # strictly validated even when correctly signed (a compromised or buggy coordinator)
    for path, value in (
        (("seq",), -1),
        (("seq",), True),
        (("n_agents",), 0),
        (("classes",), []),
        (("classes", 0, "share"), "1"),
        (("classes", 0, "route"), []),
        (("classes", 0, "route", 0, "x"), 1e300),
        (("classes", 0, "route", 0, "alpha"), -1.0),
        (("classes", 0, "route", 0, "r"), None),
        (("classes", 0, "route", 0, "id"), 3),
        (("classes", 0, "positions"), [[0, 0]]),
        (("ids",), [1, 2]),
        (("beta",), float("inf")),
        (("gesture",), "x" * 65),
        (("extra",), []),
    ):
        b = copy.deepcopy(body)
        target = b
        for k in path[:-1]:
            target = target[k]
        target[path[-1]] = value
        try:
            bad.append(sign(b, secret))
        except ValueError:  # not even encodable as canonical JSON (inf)
            bad.append(json.dumps({"v": 1, "body": b, "sig": "00"}).encode())
    reasons = [follower.offer(p) for p in bad]
    assert all(reasons), list(zip(reasons, bad))
    assert set(reasons) <= {"malformed", "signature", "version"}
    assert follower.control(state, 1) == before and follower.particle_class == 0 and follower.accepted == 0
    for p in bad:
        with pytest.raises(CommandRejected):
            decode(p, secret)
    assert follower.offer(im.command.encode(secret)) is None
    assert follower.offer(im.command.encode(secret)) is None  # a republication is not a replay
    older = type(im.command)(**{**im.command.__dict__, "seq": 0}).encode(secret)
    assert follower.offer(older) == "replay"
    c = follower.control(state, 2)
    assert follower.particle_class == class_of(3, 30, [k.share for k in im.command.classes])
    assert c != before and follower.report()["commands_accepted"] == 1


def test_the_signature_covers_the_bytes_sent(commands):
    """The HMAC is over the body's bytes on the wire, checked before they are read: the same body written with
    other whitespace under the coordinator's signature is a forgery, not the same command; signed over its own
    bytes it is a command with equal fields, which a follower holding the original takes as a replay (only the
    very same bytes are a republication)."""
    cmd = commands["v", "region"].command
    secret = os.urandom(32)
    sent = cmd.encode(secret)
    body, sig = sent[len(b'{"v":1,"body":') : -74], sent[-66:-2]
    assert verify(sent, secret) == body == _canonical(cmd.body())
    spaced = json.dumps(json.loads(body), sort_keys=True, indent=1).encode()
    assert json.loads(spaced) == json.loads(body) and spaced != body
    for forged in (
        b'{"v":1,"body":' + spaced + b',"sig":"' + sig + b'"}',
        b'{"v":1,"body":' + body + b' ,"sig":"' + sig + b'"}',
    ):
        with pytest.raises(CommandRejected) as exc:
            decode(forged, secret)
        assert exc.value.reason == "signature"
    resigned = sign_raw(spaced, secret)
    assert decode(resigned, secret) == cmd
    # verified before parsing: a forged envelope whose body is no JSON is a forgery; signed, it is malformed
    for data, reason in (
        (b'{"v":1,"body":not json,"sig":"' + sig + b'"}', "signature"),
        (sign_raw(b"not json", secret), "malformed"),
    ):
        with pytest.raises(CommandRejected) as exc:
            decode(data, secret)
        assert exc.value.reason == reason
    spec = SimpleNamespace(id=3, secret=secret.hex(), static_control=lambda: Control(beta=2.0, mu=0.2))
    follower = CommandFollower(spec)
    assert [follower.offer(p) for p in (sent, sent, resigned, sent)] == [None, None, "replay", None]
    assert follower.accepted == 1
