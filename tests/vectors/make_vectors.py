"""Generate the shared test vectors from the Python codecs (the oracle):
`.venv/bin/python tests/vectors/make_vectors.py`.

The files next to this script are committed; tests/test_vectors.py checks the Python codecs against them
and agent/native/tests/vectors.rs the Rust ones, so both implementations make the same decisions:

    state_records.json      wire.decode_state: 88-byte records, valid and rejected (reason)
    commands.json           agent.protocol.command.decode: envelopes (raw bytes in hex), accepted (parsed
                            fields, the fill shape when there is one) or rejected (reason)
    command_sequences.json  coordinator.control.route.CommandFollower: offers in order with each answer, and controls
    route.json              coordinator.control.route.class_counts/class_of and RouteFollower controls
    fill.json               agent.fill.inside/nearest_point and FillFollower controls, and
                            agent.protocol.command.edges_cross
    float_repr.json         Python's repr(float), which the canonical command body uses

Deterministic: a fixed secret, fixed commands and seeded random numbers. Expected floats are written by
json (repr), so they read back exactly.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import math
import random
import struct
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent))

from agent.fill import inside, nearest_point  # noqa: E402
from coordinator.control.route import CommandFollower, FillFollower, RouteFollower, class_counts, class_of  # noqa: E402
from agent.sph.particle import NFIELDS, Control  # noqa: E402
from agent.protocol.wire import decode_state, encode_state  # noqa: E402
from agent.protocol.command import (  # noqa: E402
    MAX_BYTES, MAX_RINGS, MAX_VERTICES, CommandRejected, Fill, GestureCommand, ParticleClass, Waypoint, Zone, _canonical,
    decode, edges_cross)

# The digit-2 hand photo of the shared sign-language-digits set (IMG_1140.JPG), committed with the scenarios:
# the generator (and tests/test_vectors.py, which reruns it) needs no ../shared.
PHOTO = HERE.parent.parent / "scenarios" / "inputs" / "digit2_IMG_1140.JPG"

SECRET = bytes(range(32))
OTHER_SECRET = bytes(range(1, 33))
HEAD = b'{"v":1,"body":'


# ----------------------------------------------------------------------------------------------------------
# state records

def record(version=1, kind=1, flags=0, agent_id=5, step=17, cls=0, reserved=0, floats=None) -> bytes:
    floats = floats or [1.5, -2.25, 0.1, -0.3, 0.85, 12.5, 0.001, -1e-7, 3.0]
    return struct.pack("<BBHIIHH9d", version, kind, flags, agent_id, step, cls, reserved, *floats)


def state_vectors() -> list:
    s = [10.0, 20.5, -0.75, 1.25, 0.9, 3.3, 0.01, 0.02, -0.03, 0.0]
    frozen = list(s)
    frozen[9] = 1.0
    extreme = [1e12, -1e12, 5e-324, -0.0, 1e12, -1e12, 0.30000000000000004, 1.7976931348623157e-300, 2.5]
    cases = [
        ("valid", encode_state(7, 42, s, 0)),
        ("valid_frozen_class3", encode_state(123456, 4294967295, frozen, 3)),
        ("valid_max_id_extreme_values", record(agent_id=2**31 - 1, cls=65535, floats=extreme)),
        ("valid_reserved_nonzero", record(reserved=0xBEEF)),  # reserved is not checked
        ("length_87", record()[:87]),
        ("length_89", record() + b"\0"),
        ("length_0", b""),
        ("version_2", record(version=2)),
        ("kind_2", record(kind=2)),
        ("version_2_and_bad_value", record(version=2, flags=2)),  # version is checked first
        ("nan", record(floats=[float("nan")] + [1.0] * 8)),
        ("inf", record(floats=[1.0, float("inf")] + [1.0] * 7)),
        ("minus_inf_in_stress", record(floats=[1.0] * 8 + [float("-inf")])),
        ("value_1e13", record(floats=[1.0] * 3 + [1e13] + [1.0] * 5)),
        ("value_just_above_1e12", record(floats=[math.nextafter(1e12, math.inf)] + [1.0] * 8)),
        ("rho_zero", record(floats=[1.0] * 4 + [0.0] + [1.0] * 4)),
        ("rho_minus_zero", record(floats=[1.0] * 4 + [-0.0] + [1.0] * 4)),
        ("rho_negative", record(floats=[1.0] * 4 + [-0.5] + [1.0] * 4)),
        ("flags_2", record(flags=2)),
        ("flags_3", record(flags=3)),
        ("id_2_31", record(agent_id=2**31)),
    ]
    out = []
    for name, data in cases:
        res, reason = decode_state(data)
        if res is None:
            expect = {"reject": reason}
        else:
            agent_id, step, cls, values = res
            expect = {"id": agent_id, "step": step, "class": cls, "values": list(values)}
        out.append({"name": name, "hex": data.hex(), "expect": expect})
    return out


# ----------------------------------------------------------------------------------------------------------
# commands

def sign_raw(body: bytes, secret: bytes = SECRET) -> bytes:
    """The standard envelope around exactly these body bytes (the HMAC over them)."""
    return HEAD + body + b',"sig":"' + hmac.new(secret, body, hashlib.sha256).hexdigest().encode() + b'"}'


def sign(body: dict, secret: bytes = SECRET) -> bytes:
    return sign_raw(_canonical(body), secret)


def sig_of(body: dict, secret: bytes = SECRET) -> str:
    return hmac.new(secret, _canonical(body), hashlib.sha256).hexdigest()


def relaid(body: dict, v=1, sig: str | None = None, extra_env: dict | None = None, indent=1) -> bytes:
    """An envelope laid out differently from `encode` (keys reversed, indented): not the fast path."""
    env = {"sig": sig_of(body) if sig is None else sig, "body": dict(reversed(list(body.items()))), "v": v}
    if extra_env:
        env.update(extra_env)
    # surrogatepass: a lone surrogate in a str goes out as its 3-byte encoding, which Python's json reads back
    return json.dumps(env, indent=indent, ensure_ascii=False).encode("utf-8", "surrogatepass")


STANDARD = GestureCommand(
    seq=1, gesture="v_sign", n_agents=30,
    classes=(ParticleClass("left", 1.0, (Waypoint(10.0, 12.5, 1.0, 3.0, 4.0, beta=5.0),
                                         Waypoint(20.0, 25.0, 0.5, 2.0, 6.0, mu=0.25))),
             ParticleClass("right", 2.0, (Waypoint(40.0, 12.5, 1.0, 3.0, 4.0),))),
    beta=2.0, mu=0.0, extra={"controller": "region", "ellipses": [[1.5, 2.0, 0.3, -0.7]]})


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


def raw(text: bytes, where: str = "extra") -> bytes:
    """The standard body, signed, with `text` written verbatim as extra's value (or as the top-level beta)."""
    if where == "extra":
        b = _canonical(body(extra={"k": "@@"}))
    else:
        b = _canonical(body(beta="@@"))
    assert b.count(b'"@@"') == 1
    return sign_raw(b.replace(b'"@@"', text))


def raw_canon(text: bytes) -> bytes:
    """`text` verbatim as extra's value, signed over the canonical body Python rebuilds from it (a leading
    space keeps it off the fast path, whose HMAC covers the raw bytes)."""
    b = _canonical(body(extra={"k": "@@"})).replace(b'"@@"', text)
    sig = hmac.new(SECRET, _canonical(json.loads(b)), hashlib.sha256).hexdigest().encode()
    return b" " + HEAD + b + b',"sig":"' + sig + b'"}'


def command_vectors() -> list:
    std = STANDARD.encode(SECRET)
    exotic = GestureCommand(
        seq=2**62 - 1, gesture="Zeichen ✌ 日本 😀 \"q\" \\ \t\x7f\u2028", n_agents=100000,
        classes=(ParticleClass("ünïcode", 1e6, (Waypoint(1e-05, 123.456, 0.0001, 1e6, 1e4, beta=0.0, mu=1e4),
                                                  Waypoint(-1e6, 0.30000000000000004, 5e-324, 0.0, 0.0))),
                 ParticleClass("", 0.0, (Waypoint(-0.0, 1.0, 2.0, 3.0, 4.0),))),
        beta=1e4, mu=1.5e-7,
        extra={"big": 1.5e16, "e16": 1e16, "under": 1e-16, "int": 12345678901234567890123456789, "neg": -7,
               "tiny": 5e-324, "max": 1.7976931348623157e308, "list": [True, False, None, "", {}],
               "fixed": 1234567890123456.0,
               "\u00e9": "key sorts after ascii", "\U0001F600": "astral key", "\uffff": "bmp key"})
    forged = bytearray(std)
    forged[std.index(b'"n_agents":30') + len(b'"n_agents":3')] = ord("1")  # 30 -> 31, same signature
    std_sig = std[-66:-2].decode()
    deep = {"k": 0}
    for _ in range(100):
        deep = [deep]
    big_pad = "x" * (MAX_BYTES - len(std) + 100)

    cases = [
        ("valid_standard", std),
        ("valid_exotic", exotic.encode(SECRET)),
        ("valid_relaid", relaid(STANDARD.body())),
        ("valid_relaid_crlf_whitespace",
         b"\r\n\t " + relaid(STANDARD.body(), indent="\t").replace(b"\n", b"\r\n") + b" \n"),
        ("valid_v_float", relaid(STANDARD.body(), v=1.0)),
        ("valid_v_true", relaid(STANDARD.body(), v=True)),
        # 10.0 with 21 more digits, 2.0 as 20E-1, 0.0 as 0.000e5: the same canonical body
        ("valid_float_other_spellings",
         relaid(body()).replace(b'"mu": 0.0', b'"mu": 0.000e5').replace(b'"beta": 2.0', b'"beta": 20E-1')
         .replace(b'"x": 10.0', b'"x": 10.000000000000000000001')),
        ("valid_escaped_text", relaid(body(gesture="é/\n")).replace(b'\\n', b'\\u000A').replace(b"/", b"\\/")),
        ("valid_deep_extra_100", sign(body(extra={"deep": deep}))),
        ("valid_int_4300_digits", sign(body(extra={"n": int("9" * 4300)}))),
        ("valid_share_int", sign(body(classes=[one_class(share=1, route=[waypoint(x=3, alpha=0)])]))),
        ("valid_gesture_64_astral", sign(body(gesture="😀" * 64))),
        ("valid_lone_surrogate_escape", sign(body(gesture="a\ud800b", extra={"\udc00": "\ud83d"}))),
        ("valid_surrogatepass_utf8",  # a surrogate encoded in UTF-8 bytes: Python decodes with 'surrogatepass'
         relaid(body(gesture="x\ud800y"))),
        ("valid_duplicate_key_last_wins",  # the signature covers {"seq": 1}; not the fast path's layout
         b" " + sign(body(seq=1)).replace(b'"seq":1}', b'"seq":7,"seq":1}', 1)),
        ("valid_raw_minus_zero_int", raw_canon(b"-0")),
        ("valid_raw_exponent_float", raw_canon(b"1E5")),
        ("valid_raw_float_underflow", raw_canon(b"-1e-400")),
        ("valid_raw_big_negative_int", raw_canon(b"-123456789012345678901234567890")),
        ("valid_raw_escapes", raw_canon(b'"\\\"\\/\\b\\f\\n\\r\\t\\u00E9\\uD83D\\uDE00\\uDE00\\uD83D x"')),
        ("valid_raw_whitespace_inside", raw_canon(b' [ 1 ,\t{ "a" :\r\nnull } , [ ] , { } , true ] ')),
        ("noncanonical_fast_path_minus_zero", raw(b"-0")),
        ("noncanonical_fast_path_exponent", raw(b"1E5")),
        ("valid_utf8_bom", b"\xef\xbb\xbf" + relaid(STANDARD.body())),
        ("valid_utf16_le_bom", b"\xff\xfe" + relaid(STANDARD.body()).decode().encode("utf-16-le")),
        ("valid_utf16_be_no_bom", relaid(STANDARD.body()).decode().encode("utf-16-be")),
        ("valid_utf32_le_no_bom", relaid(STANDARD.body()).decode().encode("utf-32-le")),
        ("valid_utf32_be_bom", b"\x00\x00\xfe\xff" + relaid(STANDARD.body()).decode().encode("utf-32-be")),
        ("valid_beta_mu_boundaries", sign(body(beta=0, mu=10000, classes=[one_class(route=[waypoint(
            x=-1000000, y=1e6, r=0, s=1000000.0, alpha=10000, beta=1e4, mu=0)])]))),
        ("valid_no_gesture_no_name_no_extra", sign({k: v for k, v in body(
            classes=[{"share": 0.5, "route": [waypoint()]}]).items() if k not in ("gesture", "extra")})),
        ("valid_classes_64", sign(body(classes=[one_class()] * 64))),
        ("valid_route_32", sign(body(classes=[one_class(route=[waypoint()] * 32)]))),
        ("valid_shares_one_nonzero",
         sign(body(classes=[one_class(share=0), one_class(share=0.0), one_class(share=1e-300)]))),

        ("forged_body_byte", bytes(forged)),
        ("wrong_secret", STANDARD.encode(OTHER_SECRET)),
        ("wrong_secret_relaid", relaid(STANDARD.body(), sig=sig_of(STANDARD.body(), OTHER_SECRET))),
        ("sig_uppercase", std[:-66] + std_sig.upper().encode() + b'"}'),
        ("sig_uppercase_relaid", relaid(STANDARD.body(), sig=std_sig.upper())),
        ("sig_63", relaid(STANDARD.body(), sig=std_sig[:63])),
        ("sig_65", relaid(STANDARD.body(), sig=std_sig + "0")),
        ("sig_non_ascii", relaid(STANDARD.body(), sig=std_sig[:63] + "é")),
        ("sig_empty", relaid(STANDARD.body(), sig="")),
        ("duplicate_key_fast_path", sign(body(seq=1)).replace(b'"seq":1}', b'"seq":7,"seq":1}', 1)),
        ("unsigned", json.dumps({"v": 1, "body": STANDARD.body()}).encode()),
        ("sig_not_string", relaid(STANDARD.body(), sig=5)),
        ("body_not_object", json.dumps({"v": 1, "body": [1], "sig": std_sig}).encode()),
        ("body_missing", json.dumps({"v": 1, "sig": std_sig}).encode()),
        ("v_2", relaid(STANDARD.body(), v=2)),
        ("v_string", relaid(STANDARD.body(), v="1")),
        ("v_missing", json.dumps({"body": STANDARD.body(), "sig": std_sig}).encode()),
        ("v_2_and_body_not_object", json.dumps({"v": 2, "body": 1, "sig": 1}).encode()),
        ("envelope_not_object", b"[1]"),
        ("envelope_unknown_field", relaid(STANDARD.body(), extra_env={"note": 1})),
        ("not_json", b"hello"),
        ("empty", b""),
        ("only_whitespace", b" \n"),
        ("trailing_garbage", relaid(STANDARD.body()) + b" x"),
        ("two_values", relaid(STANDARD.body()) + b"{}"),
        ("invalid_utf8", raw(b'"\xff"')),
        ("overlong_utf8", raw(b'"\xc0\xaf"')),
        ("utf16_odd_length", relaid(STANDARD.body()).decode().encode("utf-16-le") + b" "),
        ("utf32_beyond_unicode", relaid(body(gesture="@")).decode().encode("utf-32-le").replace(
            "@".encode("utf-32-le"), b"\x00\x00\x11\x00")),
        ("double_bom", b"\xef\xbb\xbf\xef\xbb\xbf" + relaid(STANDARD.body())),
        ("raw_control_char", raw(b'"\x01"')),
        ("bad_escape", raw(b'"\\x41"')),
        ("bad_unicode_escape", raw(b'"\\u12g4"')),
        ("nan", raw(b"NaN", "beta")),
        ("infinity", raw(b"Infinity", "beta")),
        ("minus_infinity", raw(b"-Infinity", "beta")),
        ("float_1e400", raw(b"1e400")),
        ("float_minus_1e400", raw(b"-1e400")),
        ("int_4301_digits", raw(b"9" * 4301)),
        ("leading_zero", raw(b"01")),
        ("dangling_point", raw(b"1.")),
        ("trailing_comma", raw(b"[1,]")),
        ("single_quotes", raw(b"'a'")),
        ("deep_nesting_10000", b"[" * 10000 + b"]" * 10000),
        ("deep_nesting_10000_signed", raw(b"[" * 10000 + b"]" * 10000)),
        ("oversize", sign(body(extra={"pad": big_pad}))),
        ("body_unknown_field", sign(body(note=1))),
        ("class_unknown_field", sign(body(classes=[one_class(color="red")]))),
        ("waypoint_unknown_field", sign(body(classes=[one_class(route=[waypoint(z=0.0)])]))),
        ("class_not_object", sign(body(classes=[[1]]))),
        ("seq_negative", sign(body(seq=-1))),
        ("seq_true", sign(body(seq=True))),
        ("seq_float", sign(body(seq=1.0))),
        ("seq_2_62", sign(body(seq=2**62))),
        ("seq_2_64", sign(body(seq=2**64))),
        ("seq_missing", sign({k: v for k, v in body().items() if k != "seq"})),
        ("n_agents_0", sign(body(n_agents=0))),
        ("n_agents_100001", sign(body(n_agents=100001))),
        ("n_agents_string", sign(body(n_agents="30"))),
        ("gesture_65", sign(body(gesture="g" * 65))),
        ("gesture_65_astral", sign(body(gesture="😀" * 65))),
        ("gesture_not_string", sign(body(gesture=1))),
        ("class_name_65", sign(body(classes=[one_class(name="n" * 65)]))),
        ("classes_empty", sign(body(classes=[]))),
        ("classes_65", sign(body(classes=[one_class()] * 65))),
        ("classes_not_list", sign(body(classes={"a": one_class()}))),
        ("route_empty", sign(body(classes=[one_class(route=[])]))),
        ("route_33", sign(body(classes=[one_class(route=[waypoint()] * 33)]))),
        ("share_negative", sign(body(classes=[one_class(share=-1.0)]))),
        ("share_1_5e16", sign(body(classes=[one_class(share=1.5e16)]))),
        ("share_true", sign(body(classes=[one_class(share=True)]))),
        ("share_string", sign(body(classes=[one_class(share="1")]))),
        ("share_missing", sign(body(classes=[{"name": "c", "route": [waypoint()]}]))),
        ("shares_sum_0", sign(body(classes=[one_class(share=0.0), one_class(share=0)]))),
        ("x_beyond_1e6", sign(body(classes=[one_class(route=[waypoint(x=1000000.0000000001)])]))),
        ("y_int_beyond_1e6", sign(body(classes=[one_class(route=[waypoint(y=1000001)])]))),
        ("r_negative", sign(body(classes=[one_class(route=[waypoint(r=-1e-300)])]))),
        ("alpha_1e5", sign(body(classes=[one_class(route=[waypoint(alpha=1e5)])]))),
        ("waypoint_beta_null", sign(body(classes=[one_class(route=[waypoint(beta=None)])]))),
        ("waypoint_mu_negative", sign(body(classes=[one_class(route=[waypoint(mu=-0.5)])]))),
        ("waypoint_missing_s", sign(body(classes=[one_class(route=[{"x": 1.0, "y": 2.0, "r": 0.5, "alpha": 3.0}])]))),
        ("beta_missing", sign({k: v for k, v in body().items() if k != "beta"})),
        ("mu_missing", sign({k: v for k, v in body().items() if k != "mu"})),
        ("beta_1e4_plus", sign(body(beta=10000.000000000002))),
        ("mu_bool", sign(body(mu=False))),
        ("extra_not_object", sign(body(extra=[]))),
        ("extra_null", sign(body(extra=None))),
    ] + fill_command_cases()
    out = []
    for name, data in cases:
        try:
            cmd = decode(data, SECRET)
        except CommandRejected as exc:
            expect = {"reject": exc.reason}
        else:
            assert name.startswith("valid"), name
            classes = [[lossy(c.name), c.share, [[w.x, w.y, w.r, w.s, w.alpha, w.beta, w.mu] for w in c.route]]
                       for c in cmd.classes]
            expect = {"accept": True, "seq": cmd.seq, "gesture": lossy(cmd.gesture), "n_agents": cmd.n_agents,
                      "classes": classes, "beta": cmd.beta, "mu": cmd.mu}
            if cmd.fill is not None:  # only then: the v1 vectors keep their expectations
                expect["fill"] = fill_list(cmd.fill)
        if not name.startswith("valid"):
            assert "reject" in expect, name
        out.append({"name": name, "payload_hex": bytes(data).hex(), "expect": expect})
    return out


def fill_list(fill: Fill) -> dict:
    return {"rings": [[list(v) for v in ring] for ring in fill.rings], "alpha": fill.alpha, "s": fill.s,
            "zones": [zone_list(z) for z in fill.zones]}


def zone_list(z: Zone) -> list:
    return [z.x, z.y, z.ux, z.uy, z.a, z.b, z.beta, z.mu]


ZONE = {"x": 1.0, "y": 2.0, "ux": 0.6, "uy": 0.8, "a": 3.0, "b": 1.5, "beta": 20.0, "mu": 1.0}


def square(x0, y0, side) -> list:
    return [[x0, y0], [x0 + side, y0], [x0 + side, y0 + side], [x0, y0 + side]]


def polygon(n: int, cx=0.0, cy=0.0, radius=10.0) -> list:
    """A regular n-gon, vertices rounded to 0.1 mm as the coordinator writes them."""
    return [[round(cx + radius * math.cos(2 * math.pi * k / n), 4), round(cy + radius * math.sin(2 * math.pi * k / n), 4)]
            for k in range(n)]


def photo_command(n_agents: int = 16):
    """The fill command the coordinator makes for the digit-2 photo."""
    import cv2

    from coordinator.control.imitation_setup import prepare

    return prepare(cv2.imread(str(PHOTO)), n_agents).command


def fill(**changes) -> dict:
    f = {"rings": [square(0.0, 0.0, 10.0)], "alpha": 80.0, "s": 0.2}
    f.update(changes)
    return f


def raw_fill(text: bytes) -> bytes:
    """The standard body with a fill whose first vertex's x is `text` verbatim, signed over those bytes."""
    b = _canonical(body(fill=fill(rings=[[["@@", 0.0], [10.0, 0.0], [10.0, 10.0]]])))
    assert b.count(b'"@@"') == 1
    return sign_raw(b.replace(b'"@@"', text))


def fill_command_cases() -> list:
    photo = photo_command()
    assert photo.fill is not None and len(photo.fill.rings) > 1
    triangles = [[[3.0 * k, 0.0], [3.0 * k + 1.0, 0.0], [3.0 * k, 1.0]] for k in range(MAX_RINGS + 1)]
    exact = body(fill=fill(rings=[[[0, 0], [10, 0], [10.5, 12.3456], [-0.0, 1e-05], [-1000000, 1e6]]], alpha=80, s=0))
    return [
        ("valid_fill_photo", photo.encode(SECRET)),
        ("valid_fill_photo_relaid", relaid(photo.body())),
        ("valid_fill_ints_and_exotic_floats", sign(exact)),
        ("valid_fill_ints_and_exotic_floats_relaid", relaid(exact)),
        ("valid_fill_float_other_spellings",  # the same canonical body as valid_fill_ints_and_exotic_floats
         relaid(exact).replace(b"12.3456", b"1234.56e-2").replace(b"1e-05", b"0.00001000")),
        ("valid_fill_hole", sign(body(fill=fill(rings=[square(0.0, 0.0, 10.0), square(4.0, 4.0, 2.0)])))),
        ("valid_fill_rings_touch_at_a_vertex",
         sign(body(fill=fill(rings=[square(0.0, 0.0, 1.0), square(1.0, 1.0, 1.0)])))),
        ("valid_fill_collinear_overlap",  # a spike back along an edge, as pixel contours have
         sign(body(fill=fill(rings=[[[0.0, 0.0], [4.0, 0.0], [2.0, 0.0], [2.0, 3.0]]])))),
        ("valid_fill_vertex_on_an_edge",
         sign(body(fill=fill(rings=[[[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]], [[2.0, 0.0], [3.0, -1.0], [1.0, -1.0]]])))),
        ("valid_fill_duplicate_vertex", sign(body(fill=fill(rings=[[[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]])))),
        ("valid_fill_rings_32", sign(body(fill=fill(rings=triangles[:MAX_RINGS])))),
        ("valid_fill_vertices_512", sign(body(fill=fill(rings=[polygon(MAX_VERTICES)])))),
        ("valid_fill_bounds", sign(body(fill=fill(rings=[[[-1e6, -1e6], [1e6, -1e6], [0, 1000000]]], alpha=10000, s=1e6)))),
        ("valid_fill_small_ints_alpha_s_zero",
         sign(body(fill=fill(rings=[[[-1, 0], [1, 0], [0, 1]]], alpha=0, s=0.0)))),

        ("valid_fill_zones", sign(body(fill=fill(zones=[ZONE, dict(ZONE, x=-4, ux=1, uy=0, beta=5, mu=0)])))),
        ("valid_fill_zones_empty", sign(body(fill=fill(zones=[])))),
        ("valid_fill_zones_16", sign(body(fill=fill(zones=[dict(ZONE, x=float(k)) for k in range(16)])))),
        ("fill_zones_17", sign(body(fill=fill(zones=[dict(ZONE, x=float(k)) for k in range(17)])))),
        ("fill_zones_not_list", sign(body(fill=fill(zones=ZONE)))),
        ("fill_zone_not_object", sign(body(fill=fill(zones=[[1.0, 2.0, 0.6, 0.8, 3.0, 1.5, 20.0, 1.0]])))),
        ("fill_zone_unknown_key", sign(body(fill=fill(zones=[dict(ZONE, r=1.0)])))),
        ("fill_zone_missing_mu", sign(body(fill=fill(zones=[{k: v for k, v in ZONE.items() if k != "mu"}])))),
        ("fill_zone_axis_not_unit", sign(body(fill=fill(zones=[dict(ZONE, ux=0.6, uy=0.81)])))),
        ("fill_zone_axis_beyond_1", sign(body(fill=fill(zones=[dict(ZONE, ux=1.5, uy=0.0)])))),
        ("fill_zone_a_zero", sign(body(fill=fill(zones=[dict(ZONE, a=0.0)])))),
        ("fill_zone_b_negative", sign(body(fill=fill(zones=[dict(ZONE, b=-1.0)])))),
        ("fill_zone_beta_beyond_1e4", sign(body(fill=fill(zones=[dict(ZONE, beta=10001.0)])))),
        ("fill_zone_mu_bool", sign(body(fill=fill(zones=[dict(ZONE, mu=True)])))),
        ("fill_zone_x_nan", sign_raw(_canonical(body(fill=fill(zones=[dict(ZONE, x="@@")]))).replace(b'"@@"', b"NaN"))),
        ("fill_crossing_rings", sign(body(fill=fill(rings=[square(0.0, 0.0, 2.0), square(1.0, 1.0, 2.0)])))),
        ("fill_bow_tie", sign(body(fill=fill(rings=[[[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]]])))),
        ("fill_ring_crosses_itself_far_apart",
         sign(body(fill=fill(rings=[[[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [5.0, -5.0], [0.0, 10.0]]])))),
        ("fill_vertices_513", sign(body(fill=fill(rings=[polygon(MAX_VERTICES + 1)])))),
        ("fill_vertices_513_over_two_rings",
         sign(body(fill=fill(rings=[polygon(300, radius=10.0), polygon(MAX_VERTICES + 1 - 300, radius=5.0)])))),
        ("fill_rings_33", sign(body(fill=fill(rings=triangles)))),
        ("fill_rings_empty", sign(body(fill=fill(rings=[])))),
        ("fill_rings_not_list", sign(body(fill=fill(rings={"a": square(0.0, 0.0, 1.0)})))),
        ("fill_rings_missing", sign(body(fill={"alpha": 80.0, "s": 0.2}))),
        ("fill_ring_2_vertices", sign(body(fill=fill(rings=[square(0.0, 0.0, 5.0), [[0.0, 0.0], [1.0, 1.0]]])))),
        ("fill_ring_not_list", sign(body(fill=fill(rings=[{"x": [0.0, 1.0, 2.0]}])))),
        ("fill_vertex_3_numbers", sign(body(fill=fill(rings=[[[0.0, 0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]])))),
        ("fill_vertex_1_number", sign(body(fill=fill(rings=[[[0.0, 0.0], [1.0], [0.0, 1.0]]])))),
        ("fill_vertex_object", sign(body(fill=fill(rings=[[[0.0, 0.0], {"x": 1.0, "y": 0.0}, [0.0, 1.0]]])))),
        ("fill_vertex_number", sign(body(fill=fill(rings=[[[0.0, 0.0], 1.0, [0.0, 1.0]]])))),
        ("fill_vertex_bool", sign(body(fill=fill(rings=[[[True, 0.0], [1.0, 0.0], [0.0, 1.0]]])))),
        ("fill_vertex_string", sign(body(fill=fill(rings=[[["0", 0.0], [1.0, 0.0], [0.0, 1.0]]])))),
        ("fill_vertex_null", sign(body(fill=fill(rings=[[[0.0, None], [1.0, 0.0], [0.0, 1.0]]])))),
        ("fill_vertex_beyond_1e6", sign(body(fill=fill(rings=[[[0.0, 0.0], [1000000.0000000001, 0.0], [0.0, 1.0]]])))),
        ("fill_vertex_int_beyond_1e6", sign(body(fill=fill(rings=[[[0, 0], [1, 0], [0, -1000001]]])))),
        ("fill_vertex_int_2_1023", sign(body(fill=fill(rings=[[[0, 0], [2**1023, 0], [0, 1]]])))),
        ("fill_vertex_int_2_1024", sign(body(fill=fill(rings=[[[0, 0], [2**1024, 0], [0, 1]]])))),
        ("fill_vertex_int_minus_10_400", sign(body(fill=fill(rings=[[[0, 0], [1, 0], [0, -10**400]]])))),
        ("fill_vertex_nan", raw_fill(b"NaN")),
        ("fill_vertex_infinity", raw_fill(b"-Infinity")),
        ("fill_vertex_1e400", raw_fill(b"1e400")),
        ("fill_vertex_int_4301_digits", raw_fill(b"9" * 4301)),
        ("fill_unknown_key", sign(body(fill=fill(r=1.0)))),
        ("fill_not_object", sign(body(fill=[square(0.0, 0.0, 1.0)]))),
        ("fill_null", sign(body(fill=None))),
        ("fill_alpha_missing", sign(body(fill={"rings": [square(0.0, 0.0, 1.0)], "s": 0.2}))),
        ("fill_alpha_beyond_1e4", sign(body(fill=fill(alpha=10000.000000000002)))),
        ("fill_alpha_bool", sign(body(fill=fill(alpha=True)))),
        ("fill_alpha_int_2_1024", sign(body(fill=fill(alpha=2**1024)))),
        ("fill_s_negative", sign(body(fill=fill(s=-1e-300)))),
        ("fill_s_missing", sign(body(fill={"rings": [square(0.0, 0.0, 1.0)], "alpha": 80.0}))),
        ("beta_int_2_1024", sign(body(beta=2**1024))),  # _num refuses an int float() cannot hold
        ("share_int_minus_2_1100", sign(body(classes=[one_class(share=-2**1100)]))),
    ]


def lossy(s: str) -> str:
    """A str as UTF-8 can carry it (lone surrogates as U+FFFD), as the Rust decoder reports it."""
    return "".join("\ufffd" if 0xD800 <= ord(c) < 0xE000 else c for c in s)


# ----------------------------------------------------------------------------------------------------------
# CommandFollower sequences

def spec(agent_id: int):
    return SimpleNamespace(secret=SECRET.hex(), id=agent_id,
                           static_control=lambda: Control(1.0, 2.0, 0.5, 1.0, 0.0, 2.0, 0.0, 0.0, 0.0))


def follower_sequences(commands: dict) -> list:
    def cmd(seq, n=10, shares=(1.0, 1.0, 1.0), gesture="g"):
        classes = tuple(ParticleClass(f"c{k}", s, (Waypoint(5.0 * k, 1.0, 0.5, 2.0, 3.0, beta=4.0 + k),
                                                     Waypoint(5.0 * k + 10.0, 2.0, 0.5, 2.0, 3.0, mu=0.5)))
                        for k, s in enumerate(shares))
        return GestureCommand(seq, gesture, n, classes, beta=2.0, mu=0.0, extra={"n": 1})

    c1 = cmd(1).encode(SECRET)
    c2 = cmd(2).encode(SECRET)
    c2_relaid = relaid(cmd(2).body())
    # Equal for Python (share 1 == 1.0, extra {"n": 1.0} == {"n": 1}) though another canonical body
    b = cmd(2).body()
    b["classes"][0]["share"] = 1
    b["extra"] = {"n": True}
    c2_equal = sign(b)
    c2_other = cmd(2, gesture="other").encode(SECRET)
    c3 = cmd(3, n=4, shares=(0.0, 1.0, 3.0)).encode(SECRET)
    c4 = cmd(4).encode(SECRET)
    c5 = cmd(5, n=6, shares=(2.0, 0.0, 1.0)).encode(SECRET)
    # A shape (a square with a square hole): every agent follows it, whatever its class; then routes again.
    shape = (((0.0, 0.0), (20.0, 0.0), (20.0, 20.0), (0.0, 20.0)), ((8.0, 8.0), (12.0, 8.0), (12.0, 12.0), (8.0, 12.0)))
    c6_cmd = GestureCommand(6, "fill", 10, cmd(6).classes, 3.0, 0.5, {"controller": "fill"}, Fill(shape, 80.0, 0.2))
    c6 = c6_cmd.encode(SECRET)
    c6_relaid = relaid(c6_cmd.body())
    b = c6_cmd.body()
    b["fill"]["rings"][0] = [[int(x), int(y)] for x, y in b["fill"]["rings"][0]]  # equal for Python: 20 == 20.0
    c6_equal = sign(b)
    b["fill"]["alpha"] = 81.0
    c6_other = sign(b)
    c7 = cmd(7).encode(SECRET)
    forged = bytearray(c4)
    forged[20] ^= 1
    steps = [
        ("offer", c1), ("offer", c1), ("control", (0.0, 0.0)), ("offer", c2), ("offer", c1), ("offer", c1),
        ("offer", c2_relaid), ("offer", c2_equal), ("offer", c2_other), ("offer", c2), ("control", (10.0, 1.0)),
        ("control", (10.0, 1.0)), ("offer", bytes(forged)), ("offer", b"{}"), ("offer", commands["v_2"]),
        ("offer", c3), ("control", (5.0, 1.0)), ("offer", c4), ("offer", c5), ("offer", c4), ("offer", c3),
        ("control", (10.1, 1.0)), ("offer", c5), ("offer", c3), ("control", (15.0, 1.0)), ("control", (100.0, 100.0)),
        ("offer", c6), ("offer", c6_relaid), ("offer", c6_equal), ("offer", c6_other), ("control", (5.0, 5.0)), ("control", (25.0, 10.0)), ("control", (10.0, 9.0)),
        ("control", (20.0, 20.0)), ("offer", c5), ("offer", c7), ("control", (0.0, 1.0)),
    ]
    out = []
    for agent_id in (0, 4, 9, 12):
        f = CommandFollower(spec(agent_id))
        seq = []
        for kind, arg in steps:
            if kind == "offer":
                seq.append({"offer_hex": arg.hex(), "expect": f.offer(arg), "has_command": f.has_command})
            else:
                state = np.zeros(NFIELDS)
                state[0], state[1] = arg
                c = f.control(state, 0)
                report = f.report()
                assert (report.pop("first_command_at") is None) == (f.accepted == 0)
                seq.append({"control": list(arg), "expect": control_list(c), "particle_class": f.particle_class,
                            "report": report})
        out.append({"agent_id": agent_id, "steps": seq})
    return out


def control_list(c: Control) -> list:
    return [c.wx, c.wy, c.r, c.s, c.alpha, c.beta, c.mu, c.push_x, c.push_y]


# ----------------------------------------------------------------------------------------------------------
# class_of and RouteFollower

def route_vectors() -> dict:
    rng = random.Random(7)
    cases = [(10, [1.0, 1.0, 1.0]), (7, [0.1, 0.2, 0.7]), (5, [0.0, 1.0, 0.0, 2.0]), (1, [1.0, 1.0]),
             (100000, [0.1] * 10), (33, [1 / 3, 1 / 3, 1 / 3]), (30, [1e-300, 1.0]), (12, [1e6, 1e-6, 0.5]),
             (99, [0.3, 0.3, 0.3, 0.1]), (3, [2.0, 2.0, 2.0, 2.0, 2.0])]
    for _ in range(20):
        k = rng.randint(1, 64)
        cases.append((rng.randint(1, 100000), [rng.choice([0.0, rng.random(), rng.uniform(0, 1e6)]) for _ in range(k)]))
    class_cases = []
    for n, shares in cases:
        if sum(shares) <= 0:
            shares[0] = 1.0
        ids = sorted({0, 1, n // 3, n // 2, n - 2 if n > 1 else 0, n - 1, n, n + 1, n + 2, n + 7, n + 1000}
                     | {rng.randrange(n) for _ in range(20)})
        class_cases.append({"n": n, "shares": shares, "counts": class_counts(n, shares), "ids": ids,
                            "classes": [class_of(i, n, shares) for i in ids]})

    def wp(x, y, r, beta=None, mu=None):
        return Waypoint(x, y, r, 1.5, 2.5, beta, mu)

    # A position where Python's d**2 (the C library's pow) is not d*d and that decides `reached`.
    d = pow_case(rng)
    routes = [
        ([wp(0.0, 0.0, 1.0, beta=5.0), wp(10.0, 0.0, 1.0, mu=0.5), wp(10.0, 10.0, 2.0, beta=1.0, mu=0.0)], 2.0, 0.0,
         [(5.0, 5.0), (0.5, 0.5), (0.0, 0.0), (3.0, 4.0), (10.0, 1.0), (10.0, 1.0000000000000002), (10.0, 8.0),
          (10.0, 10.0), (0.0, 0.0)]),
        # reached at exactly r (3-4-5), chained waypoints passed in one call
        ([wp(3.0, 4.0, 5.0), wp(0.0, 0.0, 5.0, beta=7.0), wp(1.0, 1.0, 0.1, mu=3.0)], 2.0, 0.0,
         [(0.0, 0.0), (1.0, 1.0), (1.0, 1.05)]),
        ([wp(0.0, 0.0, 0.0, beta=9.0)], 3.0, 1.0, [(0.0, 0.0), (1e-300, 0.0), (-0.0, -0.0)]),
        ([wp(0.1, 0.2, 0.3), wp(0.7, 0.1, 0.2)], 2.0, 0.0,
         [(0.1 + 0.2, 0.2), (0.4, 0.2), (0.30000000000000004, 0.4), (0.5, 0.1), (0.7, 0.30000000000000004)]),
        ([wp(0.0, 0.0, d["r"], beta=8.0), wp(1.0, 1.0, 0.0)], 2.0, 0.0, [(d["x"], d["y"])]),
    ]
    route_cases = []
    for route, beta, mu, positions in routes:
        f = RouteFollower(route, beta, mu)
        outs = []
        for x, y in positions:
            state = np.zeros(NFIELDS)
            state[0], state[1] = x, y
            c = f.control(state, 0)
            outs.append({"position": [x, y], "control": control_list(c), "index": f.index})
        route_cases.append({"route": [[w.x, w.y, w.r, w.s, w.alpha, w.beta, w.mu] for w in route], "beta": beta,
                            "mu": mu, "steps": outs})
    return {"class_of": class_cases, "route_follower": route_cases}


def pow_case(rng) -> dict:
    """A position (x, y) and radius r around the origin with x**2 + y**2 <= r*r for Python's `**` (the C
    library's pow, which rounds x**2 below x*x here) but x*x + y*y > r*r."""
    while True:
        x = rng.uniform(0.5, 2.0)
        if not x ** 2 < x * x:
            continue
        r = x
        for _ in range(8):
            r = math.nextafter(r, math.inf)
            y = math.sqrt(r * r - x ** 2)
            for _ in range(8):
                if x ** 2 + y ** 2 <= r * r < x * x + y * y:
                    return {"x": x, "y": y, "r": r}
                y = math.nextafter(y, math.inf)


# ----------------------------------------------------------------------------------------------------------
# the fill law and the crossing check

def fill_vectors() -> dict:
    rng = random.Random(13)
    photo = photo_command().fill
    shapes = [
        ("square_with_hole", (((0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)),
                              ((4.0, 4.0), (6.0, 4.0), (6.0, 6.0), (4.0, 6.0))), 80.0, 0.2),
        ("photo", photo.rings, photo.alpha, photo.s, photo.zones),
        ("square_with_overlapping_zones", (((0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)),), 80.0, 0.2,
         (Zone(3.0, 4.0, 0.6, 0.8, 3.0, 1.5, 20.0, 1.0), Zone(5.0, 5.0, 1.0, 0.0, 2.0, 2.0, 5.0, 0.0))),
        ("u_shape_clockwise", (((0.0, 0.0), (0.0, 6.0), (1.0, 6.0), (1.0, 1.0), (3.0, 1.0), (3.0, 6.0), (4.0, 6.0),
                                (4.0, 0.0)),), 50.0, 0.5),
        ("triangle_duplicate_vertex_and_spike", (((0.1, 0.2), (0.1, 0.2), (3.3, 0.7), (1.7, 2.9), (1.7, 4.0),
                                                  (1.7, 2.9)),), 1e4, 0.0),
        ("two_islands", (((-5.0, -5.0), (-1.0, -5.0), (-3.0, -1.0)), ((1.0, 1.0), (5.0, 1.0), (5.0, 5.0), (1.0, 5.0))),
         0.0, 1.0),
    ]
    cases = []
    for name, rings, alpha, s, *rest in shapes:
        zones = rest[0] if rest else ()
        pts = {(x, y) for ring in rings for x, y in ring}  # on the vertices
        for z in zones:  # on the zones' axes' ends and just inside/outside them
            for t in (1.0, math.nextafter(1.0, 0.0), math.nextafter(1.0, 2.0)):
                pts |= {(z.x + t * z.a * z.ux, z.y + t * z.a * z.uy), (z.x - t * z.b * z.uy, z.y + t * z.b * z.ux)}
        for ring in rings:  # on and next to the edges' midpoints, and on the horizontal lines of the vertices
            for k in range(len(ring)):
                (x1, y1), (x2, y2) = ring[k], ring[(k + 1) % len(ring)]
                mx, my = x1 + 0.5 * (x2 - x1), y1 + 0.5 * (y2 - y1)
                pts |= {(mx, my), (math.nextafter(mx, math.inf), my), (mx, math.nextafter(my, -math.inf)),
                        (mx + 0.05, my + 0.05), (mx - 0.3, y1)}
        xs = [x for ring in rings for x, _ in ring]
        ys = [y for ring in rings for _, y in ring]
        x0, x1, y0, y1 = min(xs) - 2.0, max(xs) + 2.0, min(ys) - 2.0, max(ys) + 2.0
        for _ in range(60):
            pts.add((rng.uniform(x0, x1), rng.uniform(y0, y1)))
        pts |= {(x0 - 1e3, y0), (0.1 + 0.2, 0.30000000000000004), (-0.0, -0.0)}
        f = FillFollower(Fill(rings, alpha, s, zones), 2.0, 0.2)
        steps = []
        for x, y in sorted(pts):
            state = np.zeros(NFIELDS)
            state[0], state[1] = x, y
            steps.append({"position": [x, y], "inside": inside(rings, x, y), "nearest": list(nearest_point(rings, x, y)),
                          "control": control_list(f.control(state, 0))})
        cases.append({"name": name, "rings": [[list(v) for v in ring] for ring in rings], "alpha": alpha, "s": s,
                      "zones": [zone_list(z) for z in zones], "beta": 2.0, "mu": 0.2, "steps": steps})
    assert any(st["inside"] for c in cases for st in c["steps"]) and not all(st["inside"] for c in cases for st in c["steps"])

    crossing = [
        [[[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]]],  # bow-tie
        [square(0.0, 0.0, 2.0), square(1.0, 1.0, 2.0)],
        [square(0.0, 0.0, 1.0), square(1.0, 1.0, 1.0)],  # touching at a vertex
        [square(0.0, 0.0, 10.0), square(4.0, 4.0, 2.0)],  # a hole
        [[[0.0, 0.0], [4.0, 0.0], [2.0, 0.0], [2.0, 3.0]]],  # collinear spike
        [[[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]], [[2.0, 0.0], [3.0, -1.0], [1.0, -1.0]]],  # a vertex on an edge
        [[[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]], [[2.0, 1e-300], [3.0, -1.0], [1.0, -1.0]]],  # just across
        [[[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]], [[2.0, -1e-300], [3.0, -1.0], [1.0, -1.0]]],  # just outside
        [[[0.1, 0.1], [0.7, 0.1], [0.7, 0.30000000000000004]], [[0.30000000000000004, 0.1], [0.5, -0.2], [0.2, -0.2]]],
        [[list(v) for v in ring] for ring in photo.rings],
    ]
    for _ in range(30):  # random quadrilaterals and triangles: some cross, some do not
        crossing.append([[[round(rng.uniform(-1, 1), rng.randint(1, 17)), round(rng.uniform(-1, 1), rng.randint(1, 17))]
                          for _ in range(rng.choice([3, 4, 5]))] for _ in range(rng.choice([1, 2]))])
    cross_cases = [{"rings": rings, "cross": edges_cross([[tuple(v) for v in ring] for ring in rings])}
                   for rings in crossing]
    assert any(c["cross"] for c in cross_cases) and not all(c["cross"] for c in cross_cases)
    return {"followers": cases, "edges_cross": cross_cases}


# ----------------------------------------------------------------------------------------------------------
# repr(float)

def float_reprs() -> list:
    rng = random.Random(11)
    values = [0.0, -0.0, 1.0, -1.0, 0.1, 0.30000000000000004, 1e-05, 0.0001, 0.00012345, 1e-4 * (1 - 2**-53),
              1e16, 9999999999999998.0, 1e16 - 2, 1.5e16, 1234567890123456.0, 123.456, 5e-324, 2.2250738585072014e-308,
              1.7976931348623157e308, 2**53, 2**53 + 2, 1e22, 1e23, 9007199254740993.0, 100.0, 1e15, 0.5, 1 / 3]
    for _ in range(400):
        bits = rng.getrandbits(64)
        v = struct.unpack("<d", struct.pack("<Q", bits))[0]
        if math.isfinite(v):
            values.append(v)
    for _ in range(400):  # decimal-looking values, as coordinates are, across the positional/exponent edges
        values.append(round(rng.uniform(-1, 1) * 10 ** rng.randint(-8, 20), rng.randint(0, 12)))
    # Binary fractions, as the fill controller's vertices are (multiples of 2^-17 m): many lie exactly halfway
    # between two shortest candidates, which Python breaks to the even digit (0.87348175048828125 -> ...812).
    values += [0.87348175048828125, 2.5 * 2**-52 + 1 - 2**-52]
    for _ in range(400):
        values.append(rng.randint(1, 2**24) * 2.0 ** rng.randint(-30, 10))
    return [[struct.pack("<d", v).hex(), repr(v)] for v in map(float, values)]


def main() -> None:
    write("state_records.json", state_vectors())
    vectors = command_vectors()
    write("commands.json", {"secret_hex": SECRET.hex(), "vectors": vectors})
    payloads = {v["name"]: bytes.fromhex(v["payload_hex"]) for v in vectors}
    write("command_sequences.json", {"secret_hex": SECRET.hex(), "sequences": follower_sequences(payloads)})
    write("route.json", route_vectors())
    write("fill.json", fill_vectors())
    write("float_repr.json", float_reprs())


def write(name: str, obj) -> None:
    text = json.dumps(obj, indent=1, ensure_ascii=True, allow_nan=False) + "\n"
    (HERE / name).write_text(text)
    print(f"{name}: {len(text)} bytes")


if __name__ == "__main__":
    main()
