"""Failure injection during a run: SIGKILL, SIGSTOP/SIGCONT, late joiners, coordinator kill.

Each failure fires when the run (followed by the launcher's progress tracking) reaches its step. Victims
are chosen deterministically from the seed, so a scenario replays the same failures.
"""

from __future__ import annotations

import os
import random
import signal
import threading
import time
from dataclasses import dataclass, field


@dataclass
class InjectionLog:
    injected: list[str] = field(default_factory=list)
    killed: set[int] = field(default_factory=set)
    frozen: set[int] = field(default_factory=set)
    joined: list[int] = field(default_factory=list)


# s a run keeps going after its last failure before it may end as settled (recovery is part of the test)
RECOVERY_SECONDS = 2.0


class FailureInjector:
    def __init__(self, launcher, failures, ids, seed: int, coordinator=None, spawn_late=None):
        self.launcher = launcher
        self.failures = sorted((f for f in failures if f.kind != "drop"), key=lambda f: f.at_step)
        self.ids = [int(i) for i in ids]
        self.rng = random.Random(seed)
        self.coordinator = coordinator
        self.spawn_late = spawn_late
        self.log = InjectionLog()
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self._pending = len(self.failures)
        self._calm_from = 0.0  # monotonic time from which the last failure (a freeze's end included) is past

    def busy(self, recovery: float = RECOVERY_SECONDS) -> bool:
        """A failure is still to come, or happened (or a frozen agent resumed) less than `recovery` s ago."""
        return self._pending > 0 or time.monotonic() < self._calm_from + recovery

    def start(self) -> None:
        if self.failures:
            self.thread.start()

    def stop(self) -> None:
        self._stop.set()

    def _victims(self, count: int) -> list[int]:
        pool = [i for i in self.ids if i not in self.log.killed and i not in self.log.frozen]
        return sorted(int(v) for v in self.rng.sample(pool, min(count, len(pool))))

    def _signal_victims(self, procs, count: int, sig: int) -> list[int]:
        victims = self._victims(count)
        for v in victims:
            _signal(procs[v].pid, sig)
        return victims

    def _run(self) -> None:
        for f in self.failures:
            while self.launcher.max_step < f.at_step:
                if self._stop.wait(0.01):
                    return
            procs = self.launcher.swarm.procs
            if f.kind == "kill":
                victims = self._signal_victims(procs, f.count, signal.SIGKILL)
                self.log.killed.update(victims)
                self.log.injected.append(f"step {f.at_step}: SIGKILL agents {victims}")
            elif f.kind == "freeze":
                victims = self._signal_victims(procs, f.count, signal.SIGSTOP)
                self.log.frozen.update(victims)
                self.log.injected.append(f"step {f.at_step}: SIGSTOP agents {victims} for {f.seconds:g} s")
                threading.Timer(f.seconds, _signal_each, (procs, victims, signal.SIGCONT)).start()
                self._calm_from = max(self._calm_from, time.monotonic() + f.seconds)
            elif f.kind == "kill_coordinator" and self.coordinator is not None:
                # planned: a survivable fault (agents keep their last command), not a lost helper
                self.launcher.helpers.expect_loss(self.coordinator)
                _signal(self.coordinator.pid, signal.SIGKILL)
                self.log.injected.append(f"step {f.at_step}: SIGKILL coordinator")
            elif f.kind == "late_join" and self.spawn_late is not None:
                new = self.spawn_late(f.count)
                self.log.joined += new
                self.log.injected.append(f"step {f.at_step}: {len(new)} late joiners {new}")
            self._calm_from = max(self._calm_from, time.monotonic())
            self._pending -= 1


def _signal_each(procs, ids: list[int], sig) -> None:
    for v in ids:
        _signal(procs[v].pid, sig)


def _signal(pid: int, sig) -> None:
    try:
        os.kill(pid, sig)
    except ProcessLookupError:
        pass
