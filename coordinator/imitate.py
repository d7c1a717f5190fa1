"""`fluidswarm imitate`: perception -> coordinator process -> N agent processes -> formation, MCAP, fidelity."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from agent.launcher import Launcher, _die_with_parent, run_swarm
from coordinator.control.imitation_setup import DEFAULT_CONTROLLER, DEFAULT_STEPS, prepare_input
from coordinator.control.settle import SettleRule, SettleWatch
from fluidswarm.plotting import plot_formation
from coordinator.control.fidelity import fidelity, format_fidelity


def stop_coordinator(coord: subprocess.Popen) -> None:
    """SIGTERM the coordinator process (it closes its session), SIGKILL after 10 s."""
    if coord.poll() is None:
        coord.terminate()
    try:
        coord.wait(10)
    except subprocess.TimeoutExpired:
        coord.kill()
        coord.wait()


@dataclass
class ImitationResult:
    mcap: Path
    png: Path
    fidelity: object
    finals: dict
    steps_per_second: float
    command_json: str
    launcher_events: list = field(default_factory=list)
    coordinator_code: int | None = None
    formation_seconds: float = 0.0  # simulated time until the formation settled (or the cap)
    formation_wall_seconds: float = 0.0  # wall time from the start signal to that moment
    settled: bool = False


def imitate(input_path: str, agents: int = 60, steps: int = DEFAULT_STEPS, out: str | Path = "out/imitate",
            controller: str = DEFAULT_CONTROLLER, failures=(), seed: int = 0, name: str = "imitate",
            on_started=None, progress=None, per_agent=None, launcher_hook=None, frame: int | None = None,
            frame_steps: int = 0, sph: dict | None = None, dt: float = 0.0, mode: str = "lockstep",
            rate: float = 12.0, max_age: float = 1.0, agent_timeout: float = 5.0,
            settle: SettleRule | None = SettleRule(), settle_hold=lambda: False, live: str = "") -> ImitationResult:
    """Imitate one frame of `input_path` (or, with `frame_steps` > 0, the gesture sequence of all its frames,
    each shown for `frame_steps` swarm steps). `sph`/`dt` override the imitation's SPH parameters; `mode`,
    `rate`, `max_age` choose lockstep or asynchronous agents (docs/protocol.md). `launcher_hook(launcher, im)`
    runs before the agents start; `launcher.spawn_late(count)` then starts late joiners. A single frame ends
    when its formation has settled (`settle`, coordinator/control/settle.py; None: always `steps` steps); a sequence
    runs its `steps`, switching gestures on the run's clock. `live` (HOST:PORT): the recorder also streams
    the run to Foxglove (fluidswarm/recording/live.py)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    sequence = frame_steps > 0
    frame = None if sequence else (0 if frame is None else frame)
    im = prepare_input(input_path, agents, controller=controller, frame=frame, sequence=sequence)
    if sph or dt:
        im.setup.params = im.setup.params.with_overrides(sph or {}, dt)
    mcap = out / f"{name}.mcap"
    with tempfile.TemporaryDirectory() as tmp:
        target = Path(tmp) / "target.npz"
        t = im.transform
        np.savez(target, mask=im.mask, scale=t.scale, x0=t.x0, y0=t.y0)
        image = Path(tmp) / "input.jpg"
        cv2.imwrite(str(image), im.observation.frame)
        meta = {"scenario": name, "input": str(input_path), "frame": frame, "frame_steps": frame_steps,
                "gesture": im.command.gesture, "controller": controller, "agents": agents, "steps": steps,
                "seed": seed, "sync": mode, "params": im.setup.params.as_dict(), "agent_ids": list(range(agents)),
                "transform": t.as_dict(), "failures": [getattr(f, "__dict__", str(f)) for f in failures]}
        with Launcher(agent_timeout=agent_timeout, commands=True) as launcher:
            launcher.start_recorder(str(mcap), meta, im.setup.params.dt, target=str(target), image=str(image),
                                    live=live)
            env = dict(os.environ, FLUIDSWARM_SECRET=launcher.secret, **launcher.access.env_for("coordinator"))
            cmd = [sys.executable, "-m", "coordinator", "--connect", launcher.endpoint, "--run", launcher.run,
                   "--input", str(input_path), "--agents", str(agents), "--controller", controller]
            cmd += ["--frame-steps", str(frame_steps)] if sequence else ["--frame", str(frame)]
            coord = subprocess.Popen(cmd, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.PIPE, preexec_fn=_die_with_parent)
            launcher.coordinator = coord
            first = im.command.classes[0].route[0]  # late joiners start at the palm / torso centre
            launcher.spawn_late = lambda count: launcher.spawn_joiners(
                count, (first.x, first.y), im.setup.controls[0], im.setup.params, steps, mode=mode, rate=rate,
                max_age=max_age)
            watch = None
            if settle is not None and not sequence:
                watch = SettleWatch(launcher, im.mask, im.transform, im.setup.params.dt, settle, settle_hold)

            def started(la):
                if watch is not None:
                    watch.start()
                if on_started is not None:
                    on_started(la)

            try:
                launcher.track_progress()
                if launcher_hook is not None:
                    launcher_hook(launcher, im)
                res = run_swarm(im.setup, steps, launcher=launcher, on_started=started, progress=progress,
                                per_agent=per_agent, mode=mode, rate=rate, max_age=max_age)
            finally:
                if watch is not None:
                    watch.stop()
                stop_coordinator(coord)
    done = {i: r for i, r in res.finals.items() if r.get("status") == "done"}
    ids = sorted(done)
    pos = np.array([done[i]["state"][:2] for i in ids]) if ids else np.empty((0, 2))
    classes = np.array([done[i].get("particle_class", 0) for i in ids], dtype=int)
    fid = fidelity(im.mask, im.transform, pos)
    rows, cols = im.mask.shape
    extent = (t.x0, t.x0 + cols * t.scale, t.y0 - rows * t.scale, t.y0)
    fill = im.command.fill
    wps = None if sequence or fill else np.array([[c.route[-1].x, c.route[-1].y] for c in im.command.classes])
    png = plot_formation(out / f"{name}_formation.png", pos, classes, [c.name for c in im.command.classes],
                         f"{Path(input_path).name}: {len(ids)} agents, iou {fid.iou:.2f}",
                         background=im.mask.astype(float), extent=extent, waypoints=wps,
                         outline=fill.rings if fill is not None and not sequence else ())
    settled = watch is not None and watch.settled_step is not None
    last_step = max((int(r.get("steps", 0)) for r in done.values()), default=0)
    return ImitationResult(mcap, png, fid, res.finals, res.steps_per_second(), im.command.body().__repr__(),
                           res.events, coord.returncode,
                           formation_seconds=(watch.settled_step if settled else last_step) * im.setup.params.dt,
                           formation_wall_seconds=watch.settled_wall_seconds if settled else res.wall_seconds,
                           settled=settled)
