"""The fuzz targets of the Python decoders: each takes the bytes a peer, a file or a user could hand it and
fails (AssertionError, or the exception the decoder let escape) only on a bug: a decoder that raised
something other than its own error type with a reason, or accepted what it must refuse. `make fuzz` runs them
under atheris (coverage-guided, fuzz/run.py); tests/test_fuzz_decoders.py runs them briefly with hypothesis.

What each checks:
state     agent/protocol/wire.py   a record that decodes re-encodes to the same bytes (reserved u16 aside),
                                   values finite and bounded, density > 0; a refusal is one of three reasons
ctl       agent/protocol/ctl.py    first byte: the key's kind; an accepted message re-encodes to the payload
command   agent/protocol/command.py  first byte even: the whole envelope; odd: a body the harness signs with
                                   the run's secret (the fuzzer gets behind the HMAC). An accepted command is
                                   within docs/command.md's bounds and survives encode -> decode; another
                                   secret accepts nothing; a refusal is CommandRejected with its reason
event     agent/protocol/events.py an accepted event survives encode -> decode; else None
imitation agent/protocol/imitation.py  first byte even: a plan, odd: a coordinator's note; an accepted one
                                   survives encode -> decode (a note's silhouettes their size); else None
report    agent/protocol/report.py an accepted report is within its bounds and survives a re-encode; else None
spec      agent/protocol/spec.py   an accepted spec survives to_json -> from_json; a refusal is a one-line
                                   ValueError "agent spec: ..."
scenario  fluidswarm/scenario.py   (a TOML file) an accepted scenario is within its bounds; a refusal is one
                                   UserError line naming the file (load_scenario's parse_scenario, in memory)
users     agent/protocol/access.py (a users file) accepted lines are roles with valid, unique credentials;
                                   a refusal is one AuthFileError line naming the file (read_users_file's
                                   parse_users, in memory)
mcap      fluidswarm/recording/reader.py  what `replay --check` does: load_run and completeness (load_run's
                                   read_run, on an io.BytesIO: mcap's seeking reader, or the salvaging
                                   stream reader of a file without footer); a refusal is one UserError line
                                   naming the file
"""

from __future__ import annotations

import dataclasses
import io
import json
import math
from pathlib import Path

from agent.protocol import command as cmd_mod
from agent.protocol import ctl as ctl_mod
from agent.protocol import events as ev_mod
from agent.protocol import imitation as im_mod
from agent.protocol import report as rep_mod
from agent.protocol import wire
from agent.protocol.access import _PASSWORD_RE, ROLES, AuthFileError, agent_id_of, parse_users
from agent.protocol.errors import UserError
from agent.protocol.keys import MAX_AGENTS, valid_run_name
from agent.protocol.spec import AgentSpec
from agent.sph.particle import NFIELDS
from fluidswarm.recording.reader import completeness, read_run
from fluidswarm.scenario import parse_scenario

SECRET = bytes(range(32))  # the shared vectors' secret (tests/vectors/make/common.py): their envelopes seed
OTHER = b"another run's secret"
_HEAD = b'{"v":1,"body":'
_WHATS = (None, "start", "stop", "clock", "end", "gone", "", "clocks")


def _one_line(exc: BaseException, starts: str) -> None:
    text = str(exc)
    assert text.startswith(starts) and "\n" not in text, f"not one line starting {starts!r}: {text!r}"


def state(data: bytes) -> None:
    rec, reason = wire.decode_state(data)
    if rec is None:
        assert reason in (wire.REJECT_LENGTH, wire.REJECT_VERSION, wire.REJECT_VALUE), reason
        if reason != wire.REJECT_VALUE:
            assert wire.peek_id_position(data) == (None, reason)
        return
    agent_id, step, cls, values = rec
    assert reason is None and len(values) == 12  # v2: the 9 SPH fields, the frozen flag, heading, forward speed
    finite = values[:9] + values[10:]
    assert all(math.isfinite(v) and abs(v) <= wire.MAX_ABS for v in finite) and values[4] > 0
    assert -math.pi <= values[10] <= math.pi
    assert values[9] in (0.0, 1.0) and 0 <= agent_id <= wire.MAX_ID
    assert wire.encode_state(agent_id, step, values, cls) == data[:14] + b"\0\0" + data[16:], "re-encode"
    assert wire.peek_id_step(data) == (agent_id, step)
    assert wire.peek_id_position(data) == ((agent_id, values[0], values[1]), None)


def ctl(data: bytes) -> None:
    if not data:
        return
    what, payload = _WHATS[data[0] % len(_WHATS)], data[1:]
    msg = ctl_mod.decode_ctl(what, payload)
    if msg is not None:
        assert ctl_mod.kind_of(msg).what == what
        assert ctl_mod.encode_ctl(msg) == payload, (msg, payload)


def _signed(body: bytes) -> bytes:
    import hashlib
    import hmac

    return _HEAD + body + b',"sig":"' + hmac.new(SECRET, body, hashlib.sha256).hexdigest().encode() + b'"}'


def _in(v, lo, hi) -> bool:
    return isinstance(v, float) and math.isfinite(v) and lo <= v <= hi


def _check_command(c: cmd_mod.GestureCommand) -> None:
    assert 0 <= c.seq < 2**62 and 1 <= c.n_agents <= 100000 and len(c.gesture) <= 64
    assert 1 <= len(c.classes) <= cmd_mod.MAX_CLASSES and _in(c.beta, 0, 1e4) and _in(c.mu, 0, 1e4)
    assert sum(k.share for k in c.classes) > 0 and isinstance(c.extra, dict)
    for k in c.classes:
        assert len(k.name) <= 64 and _in(k.share, 0, 1e6) and 1 <= len(k.route) <= cmd_mod.MAX_ROUTE
        for w in k.route:
            assert _in(w.x, -1e6, 1e6) and _in(w.y, -1e6, 1e6) and _in(w.r, 0, 1e6) and _in(w.s, 0, 1e6)
            assert (
                _in(w.alpha, 0, 1e4) and (w.beta is None or _in(w.beta, 0, 1e4)) and (w.mu is None or _in(w.mu, 0, 1e4))
            )
    if c.fill is not None:
        rings = c.fill.rings
        assert 1 <= len(rings) <= cmd_mod.MAX_RINGS and sum(map(len, rings)) <= cmd_mod.MAX_VERTICES
        assert all(len(r) >= 3 for r in rings) and not cmd_mod.edges_cross(rings)
        assert all(_in(x, -1e6, 1e6) and _in(y, -1e6, 1e6) for r in rings for x, y in r)
        assert _in(c.fill.alpha, 0, 1e4) and _in(c.fill.s, 0, 1e6) and len(c.fill.zones) <= cmd_mod.MAX_ZONES
        for z in c.fill.zones:
            assert abs(z.ux**2 + z.uy**2 - 1) <= 1e-6 and z.a > 0 and z.b > 0


def command(data: bytes) -> None:
    if not data:
        return
    envelope = data[1:] if data[0] % 2 == 0 else _signed(data[1:])
    try:
        c = cmd_mod.decode(envelope, SECRET)
    except cmd_mod.CommandRejected as exc:
        assert exc.reason in ("malformed", "version", "signature"), exc.reason
        return
    _check_command(c)
    assert cmd_mod.decode(c.encode(SECRET), SECRET) == c, "encode -> decode changed the command"
    try:
        cmd_mod.decode(envelope, OTHER)
    except cmd_mod.CommandRejected:
        pass
    else:
        raise AssertionError("accepted under another secret")


def event(data: bytes) -> None:
    ev = ev_mod.decode_event(data)
    if ev is None:
        return
    assert 0 <= ev.id <= ev_mod.MAX_AGENT and 0 <= ev.step <= ev_mod.MAX_STEP
    assert ev_mod.decode_event(ev_mod.encode_event(ev)) == ev, "encode -> decode changed the event"


def imitation(data: bytes) -> None:
    if not data:
        return
    if data[0] % 2 == 0:
        plan = im_mod.decode_plan(data[1:])
        if plan is not None:
            assert plan.commands and plan.commands[0][0] == 0 and (plan.frame_steps or len(plan.commands) == 1)
            assert im_mod.decode_plan(im_mod.encode_plan(plan)) == plan, "encode -> decode changed the plan"
        return
    note = im_mod.decode_note(data[1:])
    if note is None:
        return
    again = im_mod.decode_note(im_mod.encode_note(note))
    assert type(again) is type(note) and repr(again) == repr(note), "encode -> decode changed the note"
    for mask in [getattr(note, "mask", None), *getattr(note, "parts", {}).values()]:
        assert mask is None or (mask.dtype == bool and mask.size <= im_mod.MAX_PIXELS), "a silhouette out of bounds"


def _report_json(r: rep_mod.FinalReport) -> bytes:
    d = dataclasses.asdict(r)
    d.update(v=rep_mod.VERSION, status=r.status.value, state=list(r.state))
    return json.dumps(d, allow_nan=False).encode()


def report(data: bytes) -> None:
    r = rep_mod.decode_report(data)
    if r is None:
        return
    assert 0 <= r.id < 2**31 and 9 <= len(r.state) <= NFIELDS and len(r.rejected) <= 64 and len(r.agent) <= 32
    assert all(math.isfinite(v) and abs(v) <= rep_mod.MAX_ABS for v in r.state)
    assert all(0 <= getattr(r, n) <= rep_mod.MAX_COUNT for n in ("steps", "msgs_received", "lost", "stale"))
    assert all(isinstance(k, str) and len(k) <= 64 and 0 <= v for k, v in r.rejected.items())
    assert rep_mod.decode_report(_report_json(r)) == r, "re-encode -> decode changed the report"


def spec(data: bytes) -> None:
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        return
    try:
        s = AgentSpec.from_json(text)
    except ValueError as exc:
        _one_line(exc, "agent spec: ")
        return
    assert valid_run_name(s.run) and 0 <= s.id < MAX_AGENTS and isinstance(s.params, dict)
    assert isinstance(s.control, dict) and all(math.isfinite(v) for v in s.initial)
    assert AgentSpec.from_json(s.to_json()) == s, "to_json -> from_json changed the spec"


# The file-reading targets hand the decoder the input's bytes in memory under this name (what it names in its
# errors): the same parsing and validation a file goes through (load_scenario = read + parse_scenario, ...),
# without a file written and opened per input.
_NAME = Path("fuzz-input")


def scenario(data: bytes) -> None:
    path = _NAME.with_suffix(".toml")
    try:
        sc = parse_scenario(data, path)
    except UserError as exc:
        _one_line(exc, f"{path}: ")
        return
    assert 1 <= sc.agents <= 2000 and sc.steps >= 0 and sc.dt >= 0 and sc.frame >= -1 and sc.frame_steps >= 0
    assert all(f.at_step >= 0 and f.seconds > 0 and 0 <= f.fraction < 1 for f in sc.failures)
    assert all(math.isfinite(v) and v >= 0 for v in dataclasses.astuple(sc.passing))


def users(data: bytes) -> None:
    path = str(_NAME.with_suffix(".users"))
    try:
        creds = parse_users(data, path)
    except AuthFileError as exc:
        _one_line(exc, f"{path}")
        return
    assert creds and len({c.user for c in creds}) == len(creds)
    for c in creds:
        assert c.user in ROLES or agent_id_of(c.user) is not None, c.user
        assert _PASSWORD_RE.match(c.password) and ":" not in c.password


def mcap(data: bytes) -> None:
    path = _NAME.with_suffix(".mcap")
    try:
        run = read_run(io.BytesIO(data), path, images=False)
    except UserError as exc:
        _one_line(exc, f"{path}: ")
        return
    c = completeness(run)
    assert c.steps <= len(run.frames) and c.missing_states >= 0
    assert list(run.steps) == sorted(run.steps)


TARGETS = {f.__name__: f for f in (state, ctl, command, event, imitation, report, spec, scenario, users, mcap)}
