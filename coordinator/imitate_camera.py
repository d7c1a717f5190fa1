"""`fluidswarm imitate --camera DEVICE|URL|FILE`: the swarm follows a person watched live.

The coordinator process reads the camera (coordinator/camera.py) and says where the person is first seen
(`first.npz`); the swarm is placed and the recorder started from that observation, then the agents follow
each new command as the gesture changes. The run lasts `steps` steps. If the camera stream ends or stalls
first, the coordinator exits with a one-line error: the swarm is told to finish a few steps later (all
agents at the same step, so the MCAP stays complete), the recording is finished, and that line is raised
as a UserError.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import cv2
import numpy as np

from agent.launcher import Launcher, _die_with_parent, run_swarm
from coordinator.camera import load_observation
from coordinator.imitate import ImitationResult, stop_coordinator
from coordinator.control.imitation_setup import DEFAULT_CONTROLLER, DEFAULT_STEPS, prepare_observation
from agent.protocol.errors import UserError
from fluidswarm.plotting import plot_formation
from coordinator.control.fidelity import fidelity

FIRST_SECONDS = 30.0  # s for the first observation beyond opening the stream (the background needs frames)
END_LEAD_SECONDS = 0.5  # s of stepping between the coordinator's failure and the agents' common last step


def _coordinator_error(coord: subprocess.Popen, source: str) -> str:
    """The coordinator's one-line error, without its program prefix."""
    try:
        err = coord.stderr.read().decode("utf-8", "replace") if coord.stderr else ""
    except (OSError, ValueError):
        err = ""
    # Its own error line, not whatever a library logged after it (FFmpeg does, closing a network stream).
    lines = [line for line in err.splitlines() if line.startswith("fluidswarm coordinator: error: ")]
    if not lines:
        return f"camera {source}: the coordinator stopped (code {coord.returncode})"
    return lines[-1].split("error: ", 1)[1]


def _wait_first(coord: subprocess.Popen, path: Path, source: str, timeout: float) -> Path:
    deadline = time.monotonic() + timeout
    while not path.exists():
        if coord.poll() is not None:
            raise UserError(_coordinator_error(coord, source))
        if time.monotonic() > deadline:
            raise UserError(f"camera {source}: no person seen in {timeout:.0f} s")
        time.sleep(0.05)
    return path


class CoordinatorWatch:
    """Ends the swarm together (ctl/end a little ahead of the fastest agent) if the coordinator exits."""

    def __init__(self, launcher, coord: subprocess.Popen):
        self.launcher, self.coord = launcher, coord
        self.failed = False
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, daemon=True)

    def start(self) -> None:
        self._t0 = time.monotonic()
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(5)

    def _watch(self) -> None:
        while not self._stop.wait(0.1):
            if self.coord.poll() is None:
                continue
            self.failed = self.coord.returncode != 0
            if self.failed:
                step = max(self.launcher.max_step, 0)
                rate = step / max(time.monotonic() - self._t0, 1e-3)
                self.launcher.end_at(step + 5 + math.ceil(rate * END_LEAD_SECONDS))
            return


def imitate_camera(source: str, agents: int = 60, steps: int = DEFAULT_STEPS, out: str | Path = "out/imitate",
                   controller: str = DEFAULT_CONTROLLER, fps: float = 5.0, stall_seconds: float = 5.0,
                   live: str = "", name: str = "camera", progress=None) -> ImitationResult:
    """Imitate the person seen by `source` for `steps` steps; the gesture sequence comes as it happens."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    mcap = out / f"{name}.mcap"
    with tempfile.TemporaryDirectory() as tmp, Launcher(agent_timeout=5.0, commands=True) as launcher:
        tmp = Path(tmp)
        env = dict(os.environ, FLUIDSWARM_SECRET=launcher.secret, **launcher.access.env_for("coordinator"))
        cmd = [sys.executable, "-m", "coordinator", "--connect", launcher.endpoint, "--run", launcher.run,
               "--camera", str(source), "--fps", repr(float(fps)), "--stall-seconds", repr(float(stall_seconds)),
               "--agents", str(agents), "--controller", controller, "--observations", str(tmp)]
        coord = subprocess.Popen(cmd, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                 stderr=subprocess.PIPE, preexec_fn=_die_with_parent)
        launcher.coordinator = coord
        watch = CoordinatorWatch(launcher, coord)
        try:
            first = load_observation(_wait_first(coord, tmp / "first.npz", source, FIRST_SECONDS + stall_seconds))
            im = prepare_observation(first, agents, controller=controller)
            t = im.transform
            target, image = tmp / "target.npz", tmp / "input.jpg"
            np.savez(target, mask=im.mask, scale=t.scale, x0=t.x0, y0=t.y0)
            cv2.imwrite(str(image), first.frame)
            meta = {"scenario": name, "camera": str(source), "fps": fps, "gesture": im.command.gesture,
                    "controller": controller, "agents": agents, "steps": steps, "sync": "lockstep",
                    "params": im.setup.params.as_dict(), "agent_ids": list(range(agents)), "transform": t.as_dict()}
            launcher.start_recorder(str(mcap), meta, im.setup.params.dt, target=str(target), image=str(image), live=live)
            res = run_swarm(im.setup, steps, launcher=launcher, on_started=lambda la: watch.start(), progress=progress)
            latest = load_observation(tmp / "latest.npz")
        finally:
            watch.stop()
            stop_coordinator(coord)
    if watch.failed or (coord.returncode not in (0, -15, None)):
        raise UserError(f"{_coordinator_error(coord, source)} (recorded so far: {mcap})")
    done = {i: r for i, r in res.finals.items() if r.get("status") == "done"}
    ids = sorted(done)
    pos = np.array([done[i]["state"][:2] for i in ids]) if ids else np.empty((0, 2))
    classes = np.array([done[i].get("particle_class", 0) for i in ids], dtype=int)
    fid = fidelity(latest.mask, t, pos)  # against the last gesture commanded
    rows, cols = latest.mask.shape
    extent = (t.x0, t.x0 + cols * t.scale, t.y0 - rows * t.scale, t.y0)
    png = plot_formation(out / f"{name}_formation.png", pos, classes, [c.name for c in im.command.classes],
                         f"camera {source}: {len(ids)} agents, iou {fid.iou:.2f}",
                         background=latest.mask.astype(float), extent=extent)
    last_step = max((int(r.get("steps", 0)) for r in done.values()), default=0)
    return ImitationResult(mcap, png, fid, res.finals, res.steps_per_second(), repr(im.command.body()), res.events,
                           coord.returncode, formation_seconds=last_step * im.setup.params.dt,
                           formation_wall_seconds=res.wall_seconds)
