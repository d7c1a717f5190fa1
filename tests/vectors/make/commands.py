"""commands.json: agent.protocol.command.decode on envelopes (raw bytes in hex), accepted (parsed fields, the
fill shape when there is one) or rejected (reason)."""

from __future__ import annotations

import json

from agent.protocol.command import (
    MAX_BYTES,
    MAX_DEPTH,
    CommandRejected,
    GestureCommand,
    ParticleClass,
    Waypoint,
    decode,
)

from .common import (
    HEAD,
    OTHER_SECRET,
    SECRET,
    STANDARD,
    body,
    canonical,
    framed,
    one_class,
    relaid,
    reserialised,
    sig_raw,
    sign,
    sign_raw,
    waypoint,
)
from .fill_commands import fill_command_cases
from .shapes import fill_list


def raw(text: bytes, where: str = "extra") -> bytes:
    """The standard body with `text` written verbatim as extra's value (or as the top-level beta or seq),
    signed over those bytes."""
    b = canonical(body(extra={"k": "@@"}) if where == "extra" else body(**{where: "@@"}))
    assert b.count(b'"@@"') == 1
    return sign_raw(b.replace(b'"@@"', text))


def spelled(b: bytes, *changes: tuple[bytes, bytes]) -> bytes:
    """`b` with each (old, new) replaced once (each old found exactly once)."""
    for old, new in changes:
        assert b.count(old) == 1, old
        b = b.replace(old, new)
    return b


def nested(depth: int) -> dict:
    """The standard body with containers nested `depth` deep (the body counting 1)."""
    deep: list = []
    for _ in range(depth - 3):  # body, extra, and the innermost list
        deep = [deep]
    return body(extra={"deep": deep})


def command_vectors() -> list:
    std = STANDARD.encode(SECRET)
    canon = canonical(STANDARD.body())
    std_sig = sig_raw(canon)
    exotic = GestureCommand(
        seq=2**62 - 1,
        gesture='Zeichen ✌ 日本 😀 "q" \\ \t\x7f\u2028',
        n_agents=100000,
        classes=(
            ParticleClass(
                "ünïcode",
                1e6,
                (
                    Waypoint(1e-05, 123.456, 0.0001, 1e6, 1e4, beta=0.0, mu=1e4),
                    Waypoint(-1e6, 0.30000000000000004, 5e-324, 0.0, 0.0),
                ),
            ),
            ParticleClass("", 0.0, (Waypoint(-0.0, 1.0, 2.0, 3.0, 4.0),)),
        ),
        beta=1e4,
        mu=1.5e-7,
        extra={
            "big": 1.5e16,
            "e16": 1e16,
            "under": 1e-16,
            "int": 12345678901234567890123456789,
            "neg": -7,
            "tiny": 5e-324,
            "max": 1.7976931348623157e308,
            "list": [True, False, None, "", {}],
            "fixed": 1234567890123456.0,
            "e300": 10**300,
            "\u00e9": "key sorts after ascii",
            "\U0001f600": "astral key",
            "\uffff": "bmp key",
        },
    )
    forged = bytearray(std)
    forged[std.index(b'"n_agents":30') + len(b'"n_agents":3')] = ord("1")  # 30 -> 31, same signature
    big_pad = "x" * (MAX_BYTES - len(std) + 100)
    v2 = b'{"v":2,"body":'

    cases = (
        [
            ("valid_standard", std),
            # signed over Python json's bytes: the one encoder refuses integers beyond 64 bits, a receiver reads them
            ("valid_exotic", sign(exotic.body())),
            # Signed over the bytes sent, a body may be written any way JSON allows
            (
                "valid_body_other_whitespace",
                sign_raw(b"\r\n\t " + reserialised(STANDARD.body(), indent="\t").replace(b"\n", b"\r\n") + b" \n"),
            ),
            (
                "valid_body_keys_unsorted_raw_utf8",
                sign_raw(reserialised(dict(reversed(list(body(gesture="é ✌ 😀").items()))), ensure_ascii=False)),
            ),
            # 10.0 with 21 more digits, 2.0 as 20E-1, 0.0 as 0.000e5: the same values
            (
                "valid_float_other_spellings",
                sign_raw(
                    spelled(
                        canon,
                        (b'"mu":0.0', b'"mu":0.000e5'),
                        (b'"beta":2.0', b'"beta":20E-1'),
                        (b'"x":10.0', b'"x":10.000000000000000000001'),
                    )
                ),
            ),
            (
                "valid_escaped_text",
                sign_raw(canonical(body(gesture="é/\n")).replace(b"\\n", b"\\u000A").replace(b"/", b"\\/")),
            ),
            ("valid_depth_max", sign(nested(MAX_DEPTH))),
            ("valid_int_10_300", sign(body(extra={"n": 10**300}))),
            ("valid_share_int", sign(body(classes=[one_class(share=1, route=[waypoint(x=3, alpha=0)])]))),
            ("valid_gesture_64_astral", sign(body(gesture="😀" * 64))),
            ("valid_surrogate_pair_escape", raw(b'"\\ud83d\\ude00"')),
            (
                "valid_duplicate_key_last_wins",  # signed over these bytes: {"seq": 1}
                sign_raw(spelled(canon, (b'"seq":1}', b'"seq":7,"seq":1}'))),
            ),
            ("valid_raw_minus_zero_int", raw(b"-0")),
            ("valid_raw_exponent_float", raw(b"1E5")),
            ("valid_raw_float_underflow", raw(b"-1e-400")),
            ("valid_raw_big_negative_int", raw(b"-123456789012345678901234567890")),
            ("valid_raw_escapes", raw(b'"\\"\\/\\b\\f\\n\\r\\t\\u00E9\\uD83D\\uDE00 x"')),
            ("valid_raw_whitespace_inside", raw(b' [ 1 ,\t{ "a" :\r\nnull } , [ ] , { } , true ] ')),
            (
                "valid_beta_mu_boundaries",
                sign(
                    body(
                        beta=0,
                        mu=10000,
                        classes=[
                            one_class(
                                route=[waypoint(x=-1000000, y=1e6, r=0, s=1000000.0, alpha=10000, beta=1e4, mu=0)]
                            )
                        ],
                    )
                ),
            ),
            (
                "valid_no_gesture_no_name_no_extra",
                sign(
                    {
                        k: v
                        for k, v in body(classes=[{"share": 0.5, "route": [waypoint()]}]).items()
                        if k not in ("gesture", "extra")
                    }
                ),
            ),
            ("valid_classes_64", sign(body(classes=[one_class()] * 64))),
            ("valid_route_32", sign(body(classes=[one_class(route=[waypoint()] * 32)]))),
            (
                "valid_shares_one_nonzero",
                sign(body(classes=[one_class(share=0), one_class(share=0.0), one_class(share=1e-300)])),
            ),
            # The signature covers the bytes sent: the same values in other bytes are a forgery
            ("forged_body_byte", bytes(forged)),
            ("forged_reserialised_other_whitespace", framed(reserialised(STANDARD.body(), indent=1), std_sig)),
            (
                "forged_reserialised_keys_unsorted",
                framed(reserialised(dict(reversed(list(STANDARD.body().items()))), separators=(",", ":")), std_sig),
            ),
            ("forged_reserialised_float_spelling", framed(spelled(canon, (b'"beta":2.0', b'"beta":2')), std_sig)),
            ("forged_duplicate_key_added", framed(spelled(canon, (b'"seq":1}', b'"seq":7,"seq":1}')), std_sig)),
            ("forged_not_json", framed(b"not json", std_sig)),  # refused before it is read
            ("wrong_secret", STANDARD.encode(OTHER_SECRET)),
            ("sig_uppercase", framed(canon, std_sig.upper())),
            ("sig_63", framed(canon, std_sig[:63])),
            ("sig_65", framed(canon, std_sig + b"0")),
            ("sig_non_ascii", framed(canon, std_sig[:63] + "é".encode())),
            ("sig_not_hex", framed(canon, b"z" * 64)),
            ("sig_empty", framed(canon, b"")),
            ("sig_not_string", HEAD + canon + b',"sig":5}'),
            ("unsigned", HEAD + canon + b"}"),
            ("envelope_trailing_whitespace", std + b" "),
            ("envelope_unknown_field_after_sig", std[:-1] + b',"note":1}'),
            ("v_2", framed(canon, sig_raw(canon), v2)),
            ("v_2_anything_after", v2 + b"1,2,3"),
            ("v_0", b'{"v":0,"body":{},"sig":""}'),
            ("v_10", framed(canon, std_sig, b'{"v":10,"body":')),
            # Not the envelope's framing: what a v1 receiver once parsed as JSON first
            ("envelope_relaid", relaid(STANDARD.body())),
            ("envelope_relaid_v_2", relaid(STANDARD.body(), v=2)),
            ("envelope_spaced", json.dumps({"v": 1, "body": STANDARD.body(), "sig": std_sig.decode()}).encode()),
            ("envelope_leading_whitespace", b" " + std),
            ("envelope_utf8_bom", b"\xef\xbb\xbf" + std),
            ("envelope_utf16_le", std.decode().encode("utf-16-le")),
            ("envelope_utf32_be_bom", b"\x00\x00\xfe\xff" + std.decode().encode("utf-32-be")),
            ("v_string", framed(canon, std_sig, b'{"v":"1","body":')),
            ("v_float", framed(canon, std_sig, b'{"v":1.0,"body":')),
            ("v_true", framed(canon, std_sig, b'{"v":true,"body":')),
            ("v_missing", b'{"body":' + canon + b',"sig":"' + std_sig + b'"}'),
            ("v_1_no_body", b'{"v":1,"sig":"' + std_sig + b'"}'),
            ("envelope_unknown_field_first", framed(canon, std_sig, b'{"v":1,"note":1,"body":')),
            ("envelope_not_object", b"[1]"),
            ("not_json", b"hello"),
            ("empty", b""),
            ("only_whitespace", b" \n"),
            ("deep_nesting_10000", b"[" * 10000 + b"]" * 10000),
            # Signed, but not a body serde_json and Python's json both read
            ("body_not_object", sign_raw(b"[1]")),
            ("body_empty", sign_raw(b"")),
            ("body_not_json", sign_raw(b"not json")),
            ("body_trailing_garbage", sign_raw(canon + b" x")),
            ("body_two_values", sign_raw(canon + b"{}")),
            ("body_utf8_bom", sign_raw(b"\xef\xbb\xbf" + canon)),
            ("body_utf16_le", sign_raw(canon.decode().encode("utf-16-le"))),
            ("invalid_utf8", raw(b'"\xff"')),
            ("overlong_utf8", raw(b'"\xc0\xaf"')),
            ("surrogate_utf8", raw(b'"x\xed\xa0\x80y"')),
            ("lone_surrogate_escape", sign(body(gesture="a\ud800b"))),
            ("lone_surrogate_escape_in_key", sign(body(extra={"\udc00": 1}))),
            ("reversed_surrogate_pair_escape", raw(b'"\\uDE00\\uD83D"')),
            ("raw_control_char", raw(b'"\x01"')),
            ("bad_escape", raw(b'"\\x41"')),
            ("bad_unicode_escape", raw(b'"\\u12g4"')),
            ("nan", raw(b"NaN", "beta")),
            ("infinity", raw(b"Infinity", "beta")),
            ("minus_infinity", raw(b"-Infinity", "beta")),
            ("float_1e400", raw(b"1e400")),
            ("float_minus_1e400", raw(b"-1e400")),
            ("int_10_309", raw(b"1" + b"0" * 309)),  # no binary64 holds it: serde_json refuses it
            ("int_4300_digits", raw(b"9" * 4300)),
            ("int_4301_digits", raw(b"9" * 4301)),
            ("seq_minus_zero", raw(b"-0", "seq")),  # serde_json reads -0 as the float -0.0
            ("seq_exponent", raw(b"1E0", "seq")),
            ("leading_zero", raw(b"01")),
            ("dangling_point", raw(b"1.")),
            ("trailing_comma", raw(b"[1,]")),
            ("single_quotes", raw(b"'a'")),
            ("depth_max_plus_1", sign(nested(MAX_DEPTH + 1))),
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
            (
                "waypoint_missing_s",
                sign(body(classes=[one_class(route=[{"x": 1.0, "y": 2.0, "r": 0.5, "alpha": 3.0}])])),
            ),
            ("beta_missing", sign({k: v for k, v in body().items() if k != "beta"})),
            ("mu_missing", sign({k: v for k, v in body().items() if k != "mu"})),
            ("beta_1e4_plus", sign(body(beta=10000.000000000002))),
            ("mu_bool", sign(body(mu=False))),
            ("extra_not_object", sign(body(extra=[]))),
            ("extra_null", sign(body(extra=None))),
        ]
        + fill_command_cases()
    )
    out = []
    for name, data in cases:
        try:
            cmd = decode(data, SECRET)
        except CommandRejected as exc:
            expect = {"reject": exc.reason}
        else:
            assert name.startswith("valid"), name
            classes = [
                [c.name, c.share, [[w.x, w.y, w.r, w.s, w.alpha, w.beta, w.mu] for w in c.route]] for c in cmd.classes
            ]
            expect = {
                "accept": True,
                "seq": cmd.seq,
                "gesture": cmd.gesture,
                "n_agents": cmd.n_agents,
                "classes": classes,
                "beta": cmd.beta,
                "mu": cmd.mu,
            }
            if cmd.fill is not None:  # only then: the v1 vectors keep their expectations
                expect["fill"] = fill_list(cmd.fill)
        if not name.startswith("valid"):
            assert "reject" in expect, name
        out.append({"name": name, "payload_hex": bytes(data).hex(), "expect": expect})
    return out
