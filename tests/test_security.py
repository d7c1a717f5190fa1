"""Only the swarm speaks on the swarm's bus (issue 18, docs/security.md).

(a) an outsider on the same host (a Zenoh client that found the router's loopback port, no credentials)
    cannot open a session, so `verify` stays exact while it tries; with an open router the same attack
    (republishing neighbours' states shifted by 0.3 m) breaks exactness, so the test can fail.
(b) a rogue *agent* holding valid credentials (agent 16's) forges states under the ids of the real agents
    and ctl/command messages: the router refuses all of them, the swarm's result is the reference's. The
    same forgeries on wildcard keys (`fluidswarm/<run>/**`, which the router's default-allow deny rules
    cannot name) reach the receivers, which take none of them (exact keys only).

One concept, so one module over 300 lines: the attacks, the attacker helpers they share and each role's rights
tried on a router with the rules.
"""

from __future__ import annotations

import json
import os
import signal
import struct
import subprocess
import sys
import time
from dataclasses import astuple

import numpy as np
import pytest
import zenoh

from agent.protocol import keys
from agent.protocol.access import AGENT_CAPACITY, AuthFileError, RunKey, acl_config, read_users_file, write_users_file
from agent.protocol.imitation import note_key, plan_key
from agent.protocol.session import client_config
from agent.sph.particle import X, Y
from agent.sph.reference import PerParticleDriver
from agent.sph.setups import spread_block
from swarmhost.launcher import Launcher, run_swarm
from swarmhost.supervisor import stop_process
from tests.swarm_helpers import children_of

FS = [sys.executable, "-m", "fluidswarm"]
MARK = 0x7777  # the particle class the rogues stamp on their forgeries (a valid u16: the record stays well-formed)

# The attack: subscribe to every state and republish, for one agent in seven, a well-formed copy with
# x shifted by 0.3 m under the same key. Keeps trying to connect until SIGTERM, then prints what it did.
OUTSIDER = r"""
import json, os, signal, struct, sys, threading, time, zenoh
stop = threading.Event()
signal.signal(signal.SIGTERM, lambda *a: stop.set())
did = {"attempts": 0, "connected": 0, "forged": 0}
session = None
while not stop.is_set() and session is None:
    conf = zenoh.Config()
    conf.insert_json5("mode", '"client"')
    conf.insert_json5("connect/endpoints", json.dumps([sys.argv[1]]))
    conf.insert_json5("connect/timeout_ms", "300")
    conf.insert_json5("scouting/multicast/enabled", "false")
    did["attempts"] += 1
    try:
        session = zenoh.open(conf)
    except Exception:
        time.sleep(0.02)
if session is not None:
    did["connected"] = 1
    def forge(sample):
        data = bytearray(sample.payload.to_bytes())
        if len(data) != 104 or struct.unpack_from("<H", data, 12)[0] == 0x7777:
            return
        agent, = struct.unpack_from("<I", data, 4)
        if agent % 7 == 3:
            x, = struct.unpack_from("<d", data, 16)
            struct.pack_into("<d", data, 16, x + 0.3)
            struct.pack_into("<H", data, 12, 0x7777)
            session.put(sample.key_expr, bytes(data))
            did["forged"] += 1
    # REMOTE: not handed its own forgeries back inside put() (see ROGUE_AGENT: that deadlocks under load)
    sub = session.declare_subscriber("fluidswarm/*/state/**", forge, allowed_origin=zenoh.Locality.REMOTE)
    stop.wait()
print(json.dumps(did), flush=True)
os._exit(0)  # without closing: the router may be gone already
"""


def _stop(rogue: subprocess.Popen | None) -> tuple[str, str]:
    """SIGTERM the rogue (it prints its tally and exits); killed, never left behind, if it does not exit."""
    if rogue is None:
        return "", ""
    stop_process(rogue, 30.0)
    out, err = rogue.communicate()
    if rogue.returncode == -signal.SIGKILL:
        pytest.fail(f"the rogue did not exit within 30 s of SIGTERM; its stderr: {err[-2000:]}")
    return out, err


def _listening_ports(pid: int) -> list[int]:
    """TCP ports a process listens on, as any local process can find them (/proc/net/tcp + its fds)."""
    inodes = set()
    try:
        for fd in os.listdir(f"/proc/{pid}/fd"):
            try:
                link = os.readlink(f"/proc/{pid}/fd/{fd}")
            except OSError:
                continue
            if link.startswith("socket:["):
                inodes.add(link[8:-1])
    except OSError:
        return []
    ports = []
    with open("/proc/net/tcp") as f:
        for line in f.read().splitlines()[1:]:
            cols = line.split()
            if cols[3] == "0A" and cols[9] in inodes:  # 0A: LISTEN
                ports.append(int(cols[1].split(":")[1], 16))
    return ports


def _verify_with_outsider(access: str) -> tuple[float, dict]:
    """`fluidswarm verify` (16 agents) with the outsider attacking its router; (max_position_error, rogue's tally)."""
    env = dict(os.environ, FLUIDSWARM_ACCESS=access)
    verify = subprocess.Popen(
        FS + ["verify", "--agents", "16", "--steps", "250", "--timeout", "15"],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    rogue = None
    try:
        deadline = time.monotonic() + 30
        ports: list[int] = []
        while not ports and time.monotonic() < deadline and verify.poll() is None:
            # the verify process's own router, or (level acl) its compiled router's: a child of it
            ports = [p for pid in [verify.pid, *children_of(verify.pid)] for p in _listening_ports(pid)]
            time.sleep(0.02)
        assert ports, "neither the verify process nor a child of it ever listened on a TCP port"
        rogue = subprocess.Popen(
            [sys.executable, "-c", OUTSIDER, f"tcp/127.0.0.1:{ports[0]}"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        out, err = verify.communicate(timeout=120)
    finally:
        if verify.poll() is None:
            verify.kill()
        r_out, r_err = _stop(rogue)
    tally = json.loads(r_out.strip().splitlines()[-1]) if r_out.strip() else {"error": r_err[-500:]}
    figures = dict(line.split("=", 1) for line in out.split() if "=" in line)
    assert "max_position_error" in figures, out + err
    return float(figures["max_position_error"]), tally


@pytest.mark.swarm
def test_an_outsider_without_credentials_cannot_connect_and_verify_stays_exact():
    # acl (the default: the compiled router, per-process rights) and auth (credentials only, the launcher's router)
    for level in ("acl", "auth"):
        error, tally = _verify_with_outsider(level)
        print(f"{level}: max_position_error={error:.2e}, outsider {tally}")
        assert tally.get("attempts", 0) >= 3 and tally["connected"] == 0 and tally["forged"] == 0
        assert error <= 1e-9
    # The same outsider against an open router (as before issue 18) connects and breaks exactness.
    error_open, tally_open = _verify_with_outsider("none")
    print(f"open router: max_position_error={error_open:.2e}, outsider {tally_open}")
    assert tally_open["connected"] == 1 and tally_open["forged"] > 0
    assert error_open > 1e-3


# A rogue agent process with agent 16's valid credentials (from its environment, as a real agent gets them).
# It forges states under the real agents' ids (shifted copies of theirs, on their keys and on their cells'
# keys without id), the same forgeries under its own key and on wildcard keys, and ctl/stop, ctl/end,
# ctl/clock, ctl/gone and command messages on their keys and on wildcard keys.
ROGUE_AGENT = r"""
import json, os, signal, struct, sys, threading, time, zenoh
from agent.protocol import keys
from agent.protocol.session import client_config
run = sys.argv[2]
stop = threading.Event()
signal.signal(signal.SIGTERM, lambda *a: stop.set())
session = zenoh.open(client_config([sys.argv[1]]))  # FLUIDSWARM_ZENOH_USER/PASSWORD: agent-16's
did = {"forged_other_ids": 0, "forged_own_key": 0, "ctl": 0, "command": 0, "wildcard": 0, "batch": 0, "inbox": 0}
WILD = [f"fluidswarm/{run}/state/**", f"fluidswarm/{run}/state/*", f"fluidswarm/{run}/**", "fluidswarm/**"]
def forge(sample):
    data = bytearray(sample.payload.to_bytes())
    if len(data) != 104 or struct.unpack_from("<H", data, 12)[0] == 0x7777:
        return
    x, y = struct.unpack_from("<2d", data, 16)
    struct.pack_into("<d", data, 16, x + 0.3)
    struct.pack_into("<H", data, 12, 0x7777)
    key = str(sample.key_expr)
    session.put(key, bytes(data))  # under the real agent's id
    session.put(keys.cell_key(run, int(x // 1.0), int(y // 1.0)), bytes(data))  # on its cell's key (h = 1), no id
    did["forged_other_ids"] += 2
    session.put(keys.state_key(run, 16), bytes(data))  # the real agent's record under our own key
    did["forged_own_key"] += 1
    session.put(WILD[did["wildcard"] % len(WILD)], bytes(data))
    did["wildcard"] += 1
    # as if a router's relay batched it (a zid of digits: no id letter, so no bit rule denies it)
    session.put(f"fluidswarm/{run}/batch/0123456789", bytes(data))
    did["batch"] += 1
    # straight into a real agent's inbox (one record, and two), its own and on the wildcard; another's cells
    sender = keys.id_from_key(key)
    if sender is not None:
        session.put(keys.inbox_key(run, sender), bytes(data) * (1 + did["inbox"] % 2))
        session.put(f"fluidswarm/{run}/inbox/*", bytes(data))
        session.put(keys.watch_key(run, sender), bytes([1, 2, 0, 0]))  # it watches nothing (FORGED_WATCH)
        did["inbox"] += 3
# REMOTE: its own puts on matching keys are not handed back to it: zenoh delivers a session's puts to its own
# subscribers inside put(), so put() in forge() (and on the wildcard keys) would wait on forge()'s queue: deadlock
sub = session.declare_subscriber(f"fluidswarm/{run}/state/**", forge, allowed_origin=zenoh.Locality.REMOTE)
def speak_for_the_launcher():
    while True:
        time.sleep(0.01)
        for what, payload in (("stop", b"stop"), ("end", struct.pack("<Q", 3)), ("clock", struct.pack("<Q", 77777)),
                              ("gone", struct.pack("<I", 99))):
            session.put(f"fluidswarm/{run}/ctl/{what}", payload)
            did["ctl"] += 1
            for wild in (f"fluidswarm/{run}/ctl/*", f"fluidswarm/{run}/**"):
                session.put(wild, payload)
                did["wildcard"] += 1
        session.put(f"fluidswarm/{run}/command", b'{"v":1}')
        did["command"] += 1
# on a thread: SIGTERM's handler runs on the main thread, which then never waits inside a put()
threading.Thread(target=speak_for_the_launcher, daemon=True).start()
print("ready", flush=True)
while not stop.wait(0.1):
    pass
print(json.dumps(did), flush=True)
os._exit(0)
"""


# The watch record the rogue puts on the real agents' watch keys: no cell (a real agent watches its own at least)
FORGED_WATCH = bytes([1, 2, 0, 0])

# What the rogue sends on ctl: the launcher itself never sends these (no agent 99, no step 77777 in a 150-step
# run, no ctl/end in run_swarm, ctl/stop only once the run is over).
ROGUE_CTL = {
    ("stop", b"stop"),
    ("end", struct.pack("<Q", 3)),
    ("clock", struct.pack("<Q", 77777)),
    ("gone", struct.pack("<I", 99)),
}


@pytest.mark.swarm
def test_a_rogue_agent_with_valid_credentials_cannot_speak_for_others_or_the_launcher(monkeypatch):
    monkeypatch.setenv("FLUIDSWARM_ACCESS", "acl")  # per-process rights (states then carry the id in the key)
    setup = spread_block(16)
    steps = 150
    seen = {"forged_other_ids": 0, "forged_own_key": 0, "ctl": 0, "command": 0, "wildcard": 0, "batch": 0}
    seen |= {"inbox": 0, "watch": 0}

    def observe(sample):  # on the router's own session: what the router let through
        key, data = str(sample.key_expr), sample.payload.to_bytes()
        if "*" in key:
            seen["wildcard"] += 1
        elif "/state/" in key and len(data) == 104 and int.from_bytes(data[12:14], "little") == MARK:
            seen["forged_own_key" if keys.id_from_key(key) == 16 else "forged_other_ids"] += 1
        elif "/batch/" in key and len(data) % 104 == 0:  # the relay's batches hold no forged record
            seen["batch"] += any(
                int.from_bytes(data[k + 12 : k + 14], "little") == MARK for k in range(0, len(data), 104)
            )
        elif "/inbox/" in key:  # nor do the agents' inboxes (the relay's own messages reach us too)
            records = data[16:]  # after the inbox header (agent/native/src/relay/inboxes.rs)
            seen["inbox"] += (
                data[:2] != b"\x01\x03"
                or len(records) % 104 != 0
                or any(int.from_bytes(records[k + 12 : k + 14], "little") == MARK for k in range(0, len(records), 104))
            )
        elif "/watch/" in key and data == FORGED_WATCH:  # the real agents' own watch records pass
            seen["watch"] += 1
        elif "/ctl/" in key and (key.rsplit("/", 1)[1], data) in ROGUE_CTL:  # not the launcher's own
            seen["ctl"] += 1
        elif key.endswith("/command"):
            seen["command"] += 1

    with Launcher(agent_timeout=15.0) as la:
        assert la.access.state_key_ids
        observer = la.session.declare_subscriber(f"{keys.PREFIX}/{la.run}/**", observe)
        env = dict(os.environ, **la.access.env_for_agent(16))
        la.relay.add(16, setup.params.h)  # a compromised agent of this launcher's: its states are relayed
        rogue = subprocess.Popen(
            [sys.executable, "-c", ROGUE_AGENT, la.endpoint, la.run],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            assert rogue.stdout.readline().strip() == "ready", rogue.stderr.read()
            res = run_swarm(setup, steps, launcher=la)
            time.sleep(0.3)
            observer.undeclare()
            seen_during_run = dict(seen)
            relay_rejected = dict(la.relay.rejected)
        finally:
            r_out, _r_err = _stop(rogue)
    sent = json.loads(r_out.strip().splitlines()[-1])
    rejected: dict[str, int] = {}
    for r in res.finals.values():
        for k, v in r.rejected.items():
            rejected[k] = rejected.get(k, 0) + v
    print(
        f"rogue sent {sent}; the router let through {seen_during_run}; the relay rejected {relay_rejected}; "
        f"agents rejected {rejected}"
    )
    ref = PerParticleDriver(setup.ids, setup.states, setup.controls, setup.params).run(steps)
    got = np.array([res.finals[i].state for i in setup.ids])
    assert sent["forged_other_ids"] > 100 and sent["ctl"] > 100 and sent["command"] > 10 and sent["wildcard"] > 100
    assert sent["batch"] > 50
    # refused by the router: none reached even its own session (nor a batch for the recorder)
    assert seen_during_run["forged_other_ids"] == 0 and seen_during_run["ctl"] == 0 and seen_during_run["command"] == 0
    assert seen_during_run["batch"] == 0
    assert sent["inbox"] > 100 and seen_during_run["inbox"] == 0 and seen_during_run["watch"] == 0
    # under its own id the router lets it speak (it may lie about itself): a record naming someone else under
    # its key is dropped by the launcher's relay, which puts only records naming their key's agent on the cell
    # keys (agents hear states there only); wildcard keys pass the router (its deny rules name key patterns,
    # not every wildcard) and the agents take states only from their exact cell keys and ignore ctl on a
    # wildcard key (they would stop, end or jump the clock)
    assert seen_during_run["forged_own_key"] > 0 and relay_rejected.get("id", 0) > 0
    assert seen_during_run["wildcard"] > 0 and rejected.get("key", 0) > 0
    assert all(r.status == "done" for r in res.finals.values()) and len(res.finals) == 16
    assert np.abs(got[:, [X, Y]] - ref[:, [X, Y]]).max() <= 1e-9


@pytest.mark.swarm
def test_a_client_with_wrong_credentials_or_none_cannot_open_a_session():
    with Launcher() as la:
        good = la.access.env_for("recorder")
        for user, password in (("", ""), ("recorder", "0" * 32), ("agent-99999", good["FLUIDSWARM_ZENOH_PASSWORD"])):
            conf = client_config([la.endpoint], user or "nobody", password or "nothing-at-all")
            if not user:
                conf = zenoh.Config()
                conf.insert_json5("mode", '"client"')
                conf.insert_json5("connect/endpoints", json.dumps([la.endpoint]))
                conf.insert_json5("scouting/multicast/enabled", "false")
            conf.insert_json5("connect/timeout_ms", "1000")
            with pytest.raises(zenoh.ZError):
                zenoh.open(conf)
        # and the right ones do (the same code path the recorder takes)
        s = zenoh.open(client_config([la.endpoint], good["FLUIDSWARM_ZENOH_USER"], good["FLUIDSWARM_ZENOH_PASSWORD"]))
        s.close()


def test_users_file_errors_are_one_line_naming_the_line(tmp_path):
    f = tmp_path / "users.txt"
    cases = {
        "swarm s3cret-password\n": "line 1: expected user:password",
        "# comment\nbob:s3cret-password\n": "line 2: user 'bob' is not a role",
        "agent-1:short\n": "line 1: the password must be 8-128",
        "agent-1:a-long-enough-pw\nagent-1:a-long-enough-pw\n": "line 2: user 'agent-1' listed twice",
        "\n# nothing\n": "no user:password line",
    }
    for text, message in cases.items():
        f.write_text(text)
        with pytest.raises(AuthFileError, match=message) as exc:
            read_users_file(str(f))
        assert "\n" not in str(exc.value)
    out = tmp_path / "new.txt"
    key = RunKey()
    write_users_file(str(out), key.users(4))
    assert oct(out.stat().st_mode & 0o777) == "0o600"
    assert [c.user for c in read_users_file(str(out))][-1] == "agent-3"
    assert AGENT_CAPACITY >= 1000


def test_a_state_is_taken_only_from_its_senders_key_or_an_exact_cell_key():
    # the recorder and the launcher's pacer take a state record only on a key that vouches for it (the Rust
    # agent takes states only on the exact cell keys it subscribed to: agent/step.rs update_cells, shell.rs subscribe)
    run = "r"
    assert keys.state_key(run, 7) == "fluidswarm/r/state/bdfgikmoqsuwy"
    assert keys.state_key_vouches(keys.state_key(run, 7), 7) and keys.state_key_vouches(keys.cell_key(run, -1, 2), 7)
    for key in (
        keys.state_key(run, 8),
        keys.state_key(run, 7) + "/1",
        f"fluidswarm/{run}/state/*",
        f"fluidswarm/{run}/state/**",
        "fluidswarm/**",
        keys.cell_key(run, -1, 2) + "/x",
        f"fluidswarm/{run}/state/01/2",
        keys.event_key(run, 7),
    ):
        assert not keys.state_key_vouches(key, 7), key
    # observers take each state once: from the id keys under per-process rights (not the relay's copies)
    assert keys.state_observed_expr(run, True) == "fluidswarm/r/state/*"
    assert keys.state_observed_expr(run, False) == "fluidswarm/r/state/*/*"


def test_an_id_chunk_holds_none_of_the_letters_another_ids_rules_deny():
    # the router forbids agent i the keys whose last chunk holds a letter of a bit i does not have: every
    # other id's chunk holds one, i's own none; and only an exact chunk decodes to an id
    chunks = [keys.id_chunk(i) for i in range(keys.MAX_AGENTS)]
    assert all(keys.id_of_chunk(c) == i for i, c in enumerate(chunks)) and len(set(chunks)) == keys.MAX_AGENTS
    for i in (0, 5, 1279, keys.MAX_AGENTS - 1):
        denied = {keys.bit_letter(k, 1 - ((i >> k) & 1)) for k in range(keys.ID_BITS)}
        assert not denied & set(chunks[i])
        assert all(denied & set(c) for j, c in enumerate(chunks) if j != i)
    for bad in ("*", "**", "$*", chunks[3][:-1], chunks[3] + "a", chunks[3][:-1] + "a", "3", ""):
        assert keys.id_of_chunk(bad) is None
    with pytest.raises(ValueError, match="ids 0..8191 only"):
        keys.id_chunk(keys.MAX_AGENTS)


# What each role may do on a router with the run's access control (agent/protocol/access.py), tried with real
# sessions: user -> [(put or token, key, passes?)]
RUN = "R"
RIGHTS = {
    "agent-5": [
        ("put", keys.state_key(RUN, 5), True),
        ("put", keys.event_key(RUN, 5), True),
        ("put", keys.final_key(RUN, 5), True),
        ("put", keys.watch_key(RUN, 5), True),
        ("token", keys.alive_key(RUN, 5), True),
        ("put", keys.watch_key(RUN, 4), False),
        ("put", keys.inbox_key(RUN, 5), False),  # only the router's relay fills inboxes, its own too
        ("put", keys.inbox_key(RUN, 4), False),
        ("put", f"fluidswarm/{RUN}/inbox/*", False),
        ("put", keys.state_key(RUN, 5) + "/1", False),
        ("put", keys.state_key(RUN, 4), False),
        ("put", keys.state_key(RUN, 7), False),
        ("put", keys.state_key(RUN, 5 + 4096), False),
        ("put", keys.cell_key(RUN, 1, -2), False),
        ("put", keys.event_key(RUN, 6), False),
        ("put", keys.final_key(RUN, 13), False),
        ("put", f"fluidswarm/**/{keys.id_chunk(4)}", False),
        ("put", keys.ctl_key(RUN, "stop"), False),
        ("put", keys.command_key(RUN), False),
        ("put", keys.alive_key(RUN, 5), False),
        ("put", plan_key(RUN), False),
        ("put", note_key(RUN), False),
        ("token", keys.alive_key(RUN, 4), False),
        ("token", f"fluidswarm/{RUN}/recorder", False),
        ("delete", keys.event_key(RUN, 5), False),
    ],
    "coordinator": [
        ("put", keys.command_key(RUN), True),
        ("token", f"fluidswarm/{RUN}/coordinator", True),
        ("put", note_key(RUN), True),
        ("put", plan_key(RUN), False),  # the plan is the launcher's
        ("put", keys.ctl_key(RUN, "stop"), False),
        ("put", keys.state_key(RUN, 5), False),
        ("token", f"fluidswarm/{RUN}/recorder", False),
        ("put", keys.cell_key(RUN, 1, -2), False),
    ],
    "recorder": [
        ("token", f"fluidswarm/{RUN}/recorder", True),
        ("put", keys.command_key(RUN), False),
        ("put", keys.event_key(RUN, 5), False),
        ("put", note_key(RUN), False),
        ("token", keys.alive_key(RUN, 4), False),
    ],
    "launcher": [
        ("put", keys.ctl_key(RUN, "stop"), True),
        ("put", plan_key(RUN), True),
        ("put", note_key(RUN), False),  # the notes are the coordinator's
        ("put", keys.cell_key(RUN, 1, -2), False),  # only the routers' relays put on cells
        ("put", keys.state_key(RUN, 5), False),
        ("put", keys.cell_key(RUN, 1, -2) + "/x", False),
        ("put", keys.command_key(RUN), False),
        ("token", keys.alive_key(RUN, 4), False),
        ("put", keys.inbox_key(RUN, 5), False),
        ("put", keys.watch_key(RUN, 5), False),
    ],
}


@pytest.mark.swarm
def test_the_routers_rules_let_each_role_do_its_part_and_nothing_else(tmp_path):
    from agent.protocol.access import UsersFile
    from agent.protocol.session import router_config_dict
    from swarmhost.router_host import free_port
    from swarmhost.router_process import RouterProcess

    key = RunKey()
    creds = key.users(8)
    users = UsersFile(creds)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    process = RouterProcess(
        None, router_config_dict([endpoint], dictionary_file=users.path, acl=acl_config([c.user for c in creds]))
    )
    users.remove()
    # What passed the router's ingress rules: an observer with the `router` role, which no rule limits
    router = zenoh.open(client_config([endpoint], *astuple(key.credential("router"))))
    got, tokens, held = [], [], []
    router.declare_subscriber("fluidswarm/**", lambda s: got.append(str(s.key_expr)))
    router.liveliness().declare_subscriber("fluidswarm/**", lambda s: tokens.append(str(s.key_expr)))
    time.sleep(0.3)  # the observer's subscriptions reach the router before anything is put
    sessions = {u: zenoh.open(client_config([endpoint], *astuple(key.credential(u)))) for u in RIGHTS}
    wrong = []
    try:
        for user, tries in RIGHTS.items():
            for what, k, passes in tries:
                got.clear(), tokens.clear()
                if what == "put":
                    sessions[user].put(k, b"x")
                elif what == "delete":
                    sessions[user].delete(k)
                else:
                    held.append(sessions[user].liveliness().declare_token(k))
                deadline = time.monotonic() + (1.0 if passes else 0.2)
                while not (got or tokens) and time.monotonic() < deadline:
                    time.sleep(0.01)
                if bool(got or tokens) != passes:
                    wrong.append((user, what, k, passes))
        # A host router's relay takes requests from launchers only (another role adding an agent to relay
        # would have its states relayed twice, or forged ones vouched for)
        # An agent hears its own inbox, not another's (the router refuses the subscription: the router's puts
        # on agent 4's inbox reach agent 4 only)
        heard: dict[int, list] = {4: [], 5: []}
        own = sessions["agent-5"].declare_subscriber(keys.inbox_key(RUN, 5), lambda s: heard[5].append(1))
        spy = sessions["agent-5"].declare_subscriber(keys.inbox_key(RUN, 4), lambda s: heard[4].append(1))
        time.sleep(0.3)
        for i in (4, 5):
            router.put(keys.inbox_key(RUN, i), b"x")
        deadline = time.monotonic() + 1.0
        while not heard[5] and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(0.2)
        if heard != {4: [], 5: [1]}:
            wrong.append(("agent-5", "declare_subscriber", keys.inbox_key(RUN, 4), heard))
        own.undeclare(), spy.undeclare()
        relay_key = f"{keys.PREFIX}/{RUN}/relay/{process.zid}"
        for user in RIGHTS:
            replies = list(sessions[user].get(relay_key, payload="add 5 0.5", timeout=1))
            if any(r.ok is not None for r in replies) != (user == "launcher"):
                wrong.append((user, "query", relay_key, user == "launcher"))
    finally:
        for s in sessions.values():
            s.close()
        router.close()
        process.close()
    assert not wrong, wrong
