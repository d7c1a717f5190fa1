"""commands.json: agent.protocol.command.decode on envelopes (raw bytes in hex), accepted (parsed fields, the
fill shape when there is one) or rejected (reason)."""

from __future__ import annotations

import hashlib
import hmac
import json

from agent.protocol.command import MAX_BYTES, CommandRejected, GestureCommand, ParticleClass, Waypoint, _canonical, decode

from .common import HEAD, OTHER_SECRET, SECRET, STANDARD, body, lossy, one_class, relaid, sig_of, sign, sign_raw, waypoint
from .fill_commands import fill_command_cases
from .shapes import fill_list

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
