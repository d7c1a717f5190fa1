"""Seed inputs of every fuzz target, from the shared test vectors (tests/vectors/), the scenarios and small
records made here: the fuzzer starts from valid and near-valid inputs instead of from nothing."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
VECTORS = REPO / "tests" / "vectors"
WHATS = (None, "start", "stop", "clock", "end", "gone", "", "clocks")  # the ctl targets' first byte
HEAD = b'{"v":1,"body":'
_TAIL = 8 + 64 + 2  # ,"sig":"<64 hex>"}


def _json(name: str):
    return json.loads((VECTORS / name).read_text())


def state() -> list[bytes]:
    return [bytes.fromhex(v["hex"]) for v in _json("state_records.json")]


def ctl() -> list[bytes]:
    return [
        bytes([WHATS.index(v["what"]) if v["what"] in WHATS else 7]) + bytes.fromhex(v["payload_hex"])
        for v in _json("ctl.json")
    ]


def command() -> list[bytes]:
    payloads = [bytes.fromhex(v["payload_hex"]) for v in _json("commands.json")["vectors"]]
    for seq in _json("command_sequences.json")["sequences"]:
        payloads += [bytes.fromhex(s["offer_hex"]) for s in seq["steps"] if "offer_hex" in s]
    out = [b"\0" + p for p in payloads]
    # the bodies of the envelopes `encode` lays out, for the harness to sign (first byte odd)
    out += [b"\1" + p[len(HEAD) : -_TAIL] for p in payloads if p.startswith(HEAD) and len(p) > len(HEAD) + _TAIL]
    return out


def event() -> list[bytes]:
    return [bytes.fromhex(v["payload_hex"]) for v in _json("events.json")]


def imitation() -> list[bytes]:
    """A plan behind an even first byte, a coordinator's note behind an odd one (python_targets.imitation)."""
    cases = _json("imitation.json")
    return [b"\0" + bytes.fromhex(v["payload_hex"]) for v in cases["plans"] if len(v["payload_hex"]) < 4000] + [
        b"\1" + bytes.fromhex(v["payload_hex"]) for v in cases["notes"] if len(v["payload_hex"]) < 4000
    ]


def report() -> list[bytes]:
    state = [1.5, -2.0, 0.25, 0.0, 998.0, 3.0, 0.1, -0.2, 0.3, 0.0]
    base = {
        "v": 1,
        "id": 7,
        "status": "done",
        "steps": 12,
        "state": state,
        "msgs_received": 3,
        "neighbours": 40,
        "rejected": {"length": 1, "value": 2},
        "timeouts": 0,
        "deaths_seen": 0,
        "stale": 1,
        "dropped_out": 0,
        "lost": 0,
        "t_start": 1.0,
        "t_end": None,
        "session_opened_at": 0.5,
        "rss_mb": 9.0,
        "cpu_seconds": 0.25,
        "cpu_seconds_at_start": None,
        "agent": "native",
    }
    follower = {
        "commands_accepted": 2,
        "particle_class": 1,
        "waypoint_index": 0,
        "command_seq": 5,
        "first_command_at": 2.5,
    }
    return [json.dumps(base).encode(), json.dumps({**base, **follower, "status": "fell_behind"}).encode()]


def spec() -> list[bytes]:
    from agent.protocol.spec import AgentSpec

    full = AgentSpec(
        run="r1",
        id=3,
        connect=["tcp/127.0.0.1:7447"],
        steps=10,
        initial=[1.0, 2.0, 0.5, 0.0],
        control={"wx": 1.0, "wy": 2.0, "r": 0.5, "s": 2.0, "alpha": 0.5, "beta": 2.0, "mu": 0.1},
        params={"h": 1.0, "dt": 0.02, "domain": [0, 10, 0, 10], "border": "reflect"},
        secret="00ff",
        join=True,
        state_key_ids=True,
        mode="async",
        neighbours=[[4, 2.5, 3.0]],
    )
    short = AgentSpec(run="r-2", id=0, connect=["tcp/10.0.0.1:7447"], steps=0, initial=[0, 0, 0, 0])
    return [full.to_json().encode(), short.to_json().encode()]


def keys() -> list[bytes]:
    from agent.protocol import keys as k

    return [
        s.encode()
        for s in (
            k.state_key("r1", 7),
            k.alive_key("r1", 12),
            k.cell_key("r1", -1, 2),
            "fluidswarm/r1/ctl/stop",
            "fluidswarm/r1/ctl/*",
            k.id_chunk(8191),
            "r1",
        )
    ]


def scenario() -> list[bytes]:
    return [p.read_bytes() for p in sorted((REPO / "scenarios").glob("*.toml"))]


def users() -> list[bytes]:
    lines = [
        "# multi-host users",
        "launcher:launcher-pass-1",
        "coordinator:c00rdinator!",
        "recorder:rec0rder~~",
        "router:r0uter-pw",
        "agent-0:agent0-pass",
        "agent-8191:agent8191pw",
        "",
    ]
    return ["\n".join(lines).encode(), b"launcher:12345678\n"]


def mcap() -> list[bytes]:
    """Small synthetic runs as the recorder writes them (zstd chunks), and the same records uncompressed (so
    mutations reach the record parser, not only the decompressor); the smallest (2 steps of 2 agents, ~8 kB)
    keeps the fuzzer's inputs short."""
    from fluidswarm.recording.synthetic import write_synthetic_run

    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, (steps, n) in enumerate(((4, 5), (2, 2))):
            path = Path(tmp) / f"seed{k}.mcap"
            write_synthetic_run(path, steps=steps, n=n, classes=2, kill={1: 1})
            out += [path.read_bytes(), _uncompressed(path, Path(tmp) / f"plain{k}.mcap")]
    return out


def _uncompressed(path: Path, plain: Path) -> bytes:
    """The records of MCAP file `path` rewritten without compression, in small chunks."""
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    with open(path, "rb") as src, open(plain, "wb") as dst:
        reader = make_reader(src)
        w = Writer(dst, compression=CompressionType.NONE, chunk_size=2048)
        w.start(profile="", library="fluidswarm fuzz seed")
        schemas, channels = {}, {}
        for rec in reader.iter_metadata():
            w.add_metadata(rec.name, rec.metadata)
        for att in reader.iter_attachments():
            w.add_attachment(att.log_time, att.create_time, att.name, att.media_type, att.data)
        for schema, channel, message in reader.iter_messages():
            if schema.id not in schemas:
                schemas[schema.id] = w.register_schema(schema.name, schema.encoding, schema.data)
            if channel.id not in channels:
                channels[channel.id] = w.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id], channel.metadata
                )
            w.add_message(channels[channel.id], message.log_time, message.data, message.publish_time, message.sequence)
        w.finish()
    return plain.read_bytes()


# Which seeds each target starts from: Rust targets (agent/native/fuzz/fuzz_targets/) and Python ones
# (fuzz/python_targets.py) of the same decoder share them.
RUST = {"wire": state, "ctl": ctl, "command": command, "event": event, "report": report, "spec": spec, "keys": keys}
PYTHON = {
    "state": state,
    "ctl": ctl,
    "command": command,
    "event": event,
    "imitation": imitation,
    "report": report,
    "spec": spec,
    "scenario": scenario,
    "users": users,
    "mcap": mcap,
}
