"""When has the formation settled? Watch the swarm's states as the launcher sees them and end the run.

An imitation used to run a fixed 700 steps (14 s simulated) although its formation stopped changing after
about half of that. The watcher samples the newest state of every agent every `check_seconds` of simulated
time; the formation has settled when its fidelity (IoU with the target) changed by at most `iou_change`
(relative) over the last `window_seconds` and the mean speed is below `speed` (a tenth of the imitation's
v_max: a 300-particle fluid still creeps at 0.2-0.3 m/s once its IoU has stopped changing, the reference
solver on the three benchmark gestures). Then the launcher tells every
agent to finish a few steps later (ctl/end), so all of them end at the same step and the recording stays
complete. The step count given to the run stays the cap.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass

import numpy as np

from agent.protocol.wire import decode_state
from agent.sph.particle import VX, VY, X, Y
from coordinator.control.fidelity import fidelity


@dataclass(frozen=True)
class SettleRule:
    """check_seconds [s simulated] between samples; window_seconds [s] over which the IoU may change by at
    most iou_change (relative, 0.01 = 1 %); speed [m/s] the mean speed below which the swarm is at rest;
    min_seconds [s] before which nothing has settled; the agents' last step is the fastest one seen plus
    end_margin [steps] plus the steps the swarm makes in end_lead_seconds [s wall] (ctl/end must reach every
    agent before it gets there: a 60-agent swarm makes ~180 steps/s)."""

    check_seconds: float = 0.5
    window_seconds: float = 1.0
    iou_change: float = 0.01
    speed: float = 0.3
    min_seconds: float = 2.0
    end_margin: int = 5
    end_lead_seconds: float = 0.5


class SettleWatch:
    """A thread that ends `launcher`'s run when the formation (seen against `mask` through `transform`)
    has settled. `settled_step`/`settled_wall_seconds` say when (None: it ran to the cap)."""

    def __init__(
        self, launcher, mask: np.ndarray, transform, dt: float, rule: SettleRule = SettleRule(), hold=lambda: False
    ):
        """`hold()` true: not settled whatever the figures (a robustness scenario's failures still to come)."""
        self.launcher, self.mask, self.transform, self.dt, self.rule = launcher, mask, transform, dt, rule
        self.hold = hold
        self.samples: list[tuple[int, float, float]] = []  # (step, iou, mean speed)
        self.settled_step: int | None = None
        self.settled_wall_seconds: float | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        self._t0 = time.monotonic()
        self._thread = threading.Thread(target=self._watch, daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5)

    def _watch(self) -> None:
        every = max(1, round(self.rule.check_seconds / self.dt))
        window = max(1, round(self.rule.window_seconds / self.dt))
        next_step = every
        walls: list[tuple[float, int]] = []  # (wall time, fastest step) per sample: the swarm's pace
        while not self._stop.wait(0.05):
            seen = [s for s, _t in list(self.launcher.agent_steps.values())]
            if not seen or min(seen) < next_step:
                continue
            # Decoded here, once per sample, not per state on the launcher's clock thread; the records are
            # untrusted, so wire.decode_state validates them as an agent would.
            decoded = [decode_state(d) for d in list(self.launcher.newest.values())]
            rows = [(rec[1], rec[3]) for rec, _reason in decoded if rec is not None]
            if not rows:
                continue
            steps = np.array([s for s, _v in rows])
            step = int(steps.min())
            next_step = step + every
            v = np.array([v for _s, v in rows])
            iou = fidelity(self.mask, self.transform, v[:, [X, Y]]).iou
            speed = float(np.hypot(v[:, VX], v[:, VY]).mean())
            self.samples.append((step, iou, speed))
            now = time.monotonic()
            walls.append((now, int(steps.max())))
            if self._settled(step, window):
                self.settled_step = step
                self.settled_wall_seconds = now - self._t0
                (t0, s0), (t1, s1) = walls[max(0, len(walls) - 4)], walls[-1]
                rate = (s1 - s0) / (t1 - t0) if t1 > t0 else 0.0
                lead = self.rule.end_margin + math.ceil(rate * self.rule.end_lead_seconds)
                self.launcher.end_at(s1 + lead)
                return

    def _settled(self, step: int, window: int) -> bool:
        if step * self.dt < self.rule.min_seconds or self.hold():
            return False
        _, iou, speed = self.samples[-1]
        before = [s for s in self.samples if s[0] <= step - window]
        if not before or speed >= self.rule.speed:
            return False
        iou_then = before[-1][1]
        return abs(iou - iou_then) <= self.rule.iou_change * max(iou_then, 1e-9)
