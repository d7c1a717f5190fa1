"""The helper processes of a run, watched: the embedded router, the recorder, the coordinator.

A run cannot go on without them: without the router no state moves (the agents wait for each other until
their timeouts, the launcher for their reports: a 2000-step run hung 200 s); without the recorder the run goes
unrecorded while the command says it recorded; without the coordinator no command comes. `Helpers.check()`
is called at every wake-up of the launcher's waits (swarmhost/supervisor.py, at most 0.2 s apart) and raises
`HelperLost` naming what was lost and when; the launcher then stops the swarm and keeps what was recorded.

A helper may be marked as expected to go (`expect_loss`): a coordinator killed on purpose by the
`kill_coordinator` failure is a survivable fault (the agents keep their last command, docs/scenarios.md),
one that dies on its own is a lost helper.
"""

from __future__ import annotations

import signal
import subprocess
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from agent.protocol.errors import SwarmError


class HelperLost(SwarmError, RuntimeError):
    """A helper process of the run ended while the run needed it; the message says which, when and how."""

    def __init__(self, name: str, how: str, seconds: float, step: int, why: str = ""):
        self.name, self.how, self.seconds, self.step = name, how, seconds, step
        at = f", at step {step}" if step >= 0 else ", before the first step"
        tail = f" ({why})" if why else ""
        super().__init__(f"lost the {name}: it {how} {seconds:.1f} s into the run{at}{tail}; the swarm was stopped")


def describe_exit(code: int) -> str:
    """`exited with code 1`, `was killed by signal 9 (SIGKILL)`."""
    if code < 0:
        try:
            return f"was killed by signal {-code} ({signal.Signals(-code).name})"
        except ValueError:
            return f"was killed by signal {-code}"
    return f"exited with code {code}"


@dataclass
class Watched:
    name: str  # what the one-line message calls it, e.g. "embedded router (fluidswarm-router, pid 123)"
    proc: subprocess.Popen
    why: Callable[[], str] = lambda: ""  # its last words (e.g. its stderr's last line), read when lost
    fine_exit: bool = False  # exit code 0 is not a loss (a helper that ends its job on its own)
    expected: bool = False  # its end is a planned failure (expect_loss)


@dataclass
class Helpers:
    """`step()`: the run's newest step (in the message). Times are from this object's creation."""

    step: Callable[[], int] = lambda: -1
    t0: float = field(default_factory=time.monotonic)
    watched: list[Watched] = field(default_factory=list)
    lost: HelperLost | None = None  # the first loss seen (raised again by every later check)

    def watch(
        self, name: str, proc: subprocess.Popen, why: Callable[[], str] = lambda: "", fine_exit: bool = False
    ) -> None:
        self.watched.append(Watched(name, proc, why, fine_exit))

    def expect_loss(self, proc: subprocess.Popen) -> None:
        """The end of `proc` is planned (a failure injected on purpose): not a loss."""
        for w in self.watched:
            if w.proc is proc:
                w.expected = True

    def forget(self, proc: subprocess.Popen) -> None:
        """`proc` is being stopped by the launcher itself: no longer watched."""
        self.watched = [w for w in self.watched if w.proc is not proc]

    def check(self) -> None:
        """Raise HelperLost if a watched helper has ended (and was not expected to)."""
        if self.lost is not None:
            raise self.lost
        for w in self.watched:
            code = w.proc.poll()
            if code is None or w.expected or (w.fine_exit and code == 0):
                continue
            try:
                why = w.why()
            except Exception:  # noqa: BLE001  # its last words are a courtesy, never a second failure
                why = ""
            self.lost = HelperLost(w.name, describe_exit(code), time.monotonic() - self.t0, self.step(), why)
            raise self.lost

    def lost_name(self) -> str:
        return self.lost.name if self.lost is not None else ""
