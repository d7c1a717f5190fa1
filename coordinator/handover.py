"""What crosses between an imitation's launcher and its coordinator process: records on the run's bus.

The imitation is planned where the swarm runs (docs/architecture.md, "One imitation run"): the launcher
places the swarm itself, and its coordinator process only observes and commands. What still crosses is a
versioned record of the agent crate (agent/protocol/imitation.py, imitation.rs), checked on receipt:

- for a file, the launcher's plan (`hand_plan` puts it until the coordinator commands it; `await_plan` is
  the coordinator's half: every command signed with the run's key, verified before it is taken);
- for a camera, the coordinator's notes (`Notes`: the launcher hears them all, waits for the first command's
  observation with `wait_seen`, and keeps the rest for the record and the score).

A coordinator that fails before it is heard is its own one-line `CoordinatorFailed` (its error line from
its stderr, or the deadline's message); nothing is polled on disk, nothing crosses a pipe.
"""

from __future__ import annotations

import subprocess
import threading
import time
from collections.abc import Callable

from agent.protocol import keys
from agent.protocol.command import CommandRejected
from agent.protocol.command import decode as decode_command
from agent.protocol.errors import UserError
from agent.protocol.imitation import (
    Missing,
    Note,
    Plan,
    Seen,
    decode_note,
    decode_plan,
    encode_plan,
    note_key,
    plan_key,
)

PLAN_PERIOD = 0.2  # s between the launcher's puts of its plan, until its coordinator commands
ERROR_PREFIX = "fluidswarm coordinator: error: "


class CoordinatorFailed(UserError):
    """The coordinator process was not heard as it should; the message says why (its own error line)."""


def error_line(proc: subprocess.Popen) -> str:
    """The coordinator's last one-line error (without its program prefix), or '' (read once it has ended)."""
    try:
        err = proc.stderr.read().decode("utf-8", "replace") if proc.stderr else ""
    except (OSError, ValueError):
        err = ""
    # Its own error line, not whatever a library logged after it (FFmpeg does, closing a network stream).
    lines = [line for line in err.splitlines() if line.startswith(ERROR_PREFIX)]
    if lines:
        return lines[-1][len(ERROR_PREFIX) :]
    return _uncaught(err)


def _uncaught(err: str) -> str:
    """An uncaught exception's traceback on stderr as one line: the exception and where it was raised (a bug's
    only trace once the process has ended; without it the launcher could only name the exit code), or ''."""
    lines = err.splitlines()
    starts = [i for i, line in enumerate(lines) if line.startswith("Traceback (most recent call last):")]
    if not starts:
        return ""
    tb = lines[starts[-1] + 1 :]
    frames = [line.strip() for line in tb if line.startswith("  File ")]
    # The exception is the traceback's first unindented line ("ValueError: ..."; chained ones repeat below).
    exc = next((line.strip() for line in tb if line.strip() and not line.startswith(" ")), "an exception")
    where = frames[-1].removeprefix("File ").replace('"', "") if frames else "?"
    return f"uncaught {exc} (at {where})"


def hand_plan(session, run: str, plan: Plan, proc: subprocess.Popen, timeout: float, what: str = "the coordinator"):
    """Put `plan` on the run's plan key every PLAN_PERIOD s until the coordinator `proc` commands: one of the
    plan's commands heard on the command key (a put before the coordinator subscribed is heard by nobody).
    CoordinatorFailed if it ends first (its error line) or says nothing within `timeout` s."""
    envelopes = {env for _first, env in plan.commands}
    heard = threading.Event()

    def on_command(sample) -> None:
        if sample.payload.to_bytes() in envelopes:
            heard.set()

    sub = session.declare_subscriber(keys.command_key(run), on_command)
    data, deadline = encode_plan(plan), time.monotonic() + timeout
    try:
        while not heard.is_set():
            code = proc.poll()
            if code is not None:
                raise CoordinatorFailed(error_line(proc) or f"{what} ended before it commanded (exit code {code})")
            if time.monotonic() > deadline:
                raise CoordinatorFailed(f"{what} did not command the launcher's plan within {timeout:.0f} s")
            session.put(plan_key(run), data)
            heard.wait(PLAN_PERIOD)
    finally:
        sub.undeclare()


def await_plan(session, run: str, secret: bytes, stop: threading.Event, timeout: float) -> Plan | None:
    """The coordinator's half: the first plan heard on the run's plan key whose commands are all signed with
    the run's key (`secret`) and valid (command.rs); anything else on that key is dropped. None if `stop` is
    set or nothing valid came within `timeout` s."""
    got: list[Plan] = []
    ready = threading.Event()

    def on_plan(sample) -> None:
        if ready.is_set() or str(sample.key_expr) != plan_key(run):
            return
        plan = decode_plan(sample.payload.to_bytes())
        if plan is None:
            return
        try:
            for _first, env in plan.commands:
                decode_command(env, secret)
        except CommandRejected:
            return
        got.append(plan)
        ready.set()

    sub = session.declare_subscriber(plan_key(run), on_plan)
    deadline = time.monotonic() + timeout
    try:
        while not ready.is_set() and not stop.is_set() and time.monotonic() < deadline:
            ready.wait(0.05)
    finally:
        sub.undeclare()
    return got[0] if got else None


class Notes:
    """The coordinator's notes of run `run`, heard by the launcher from before it starts the coordinator:
    each valid one with the time.monotonic() it was heard (`heard`); anything else on the key is dropped."""

    def __init__(self, session, run: str):
        self.key = note_key(run)
        self.heard: list[tuple[float, Note]] = []
        self.dropped = 0
        self._changed = threading.Condition()
        self._sub = session.declare_subscriber(self.key, self._on_sample)

    def _on_sample(self, sample) -> None:
        note = decode_note(sample.payload.to_bytes()) if str(sample.key_expr) == self.key else None
        with self._changed:
            if note is None:
                self.dropped += 1
            else:
                self.heard.append((time.monotonic(), note))
                self._changed.notify_all()

    def notes(self) -> list[tuple[float, Note]]:
        with self._changed:
            return list(self.heard)

    def last_missing(self) -> str | None:
        """The last reason the coordinator said it saw nothing to command."""
        said = [n.what for _t, n in self.notes() if isinstance(n, Missing)]
        return said[-1] if said else None

    def wait_seen(
        self, proc: subprocess.Popen, timeout: float, timed_out: Callable[[], str], what: str = "the coordinator"
    ) -> Seen:
        """The first command's observation, once heard within `timeout` s. CoordinatorFailed if the coordinator
        `proc` ends first (its error line) or at the deadline (`timed_out()` says what was awaited)."""
        deadline = time.monotonic() + timeout
        with self._changed:
            while True:
                seen = next((n for _t, n in self.heard if isinstance(n, Seen)), None)
                if seen is not None:
                    return seen
                if proc.poll() is not None:
                    break
                left = deadline - time.monotonic()
                if left <= 0:
                    raise CoordinatorFailed(timed_out())
                self._changed.wait(min(left, 0.1))
        code = proc.wait()
        raise CoordinatorFailed(error_line(proc) or f"{what} ended without a first observation (exit code {code})")

    def close(self) -> None:
        self._sub.undeclare()
