"""`fluidswarm imitate --camera DEVICE|URL|FILE`: the swarm follows a person or a hand watched live.

The coordinator process reads the camera (coordinator/camera.py) and hands over the imitation of the
subject's first observation (coordinator/handover.py); the swarm is placed and the recorder started from
it, then the agents follow
each new command as the gesture changes, paced to the wall clock (simulated time = wall time, never
faster; the record's `realtime_factor` says what was reached). The run lasts `steps` steps, or until a
video file's last frame: then the coordinator exits 0 and the swarm finishes a few steps later, all agents
at the same step (the MCAP complete). If a device or URL ends or stalls, the coordinator exits with a
one-line error: the swarm finishes the same way and that line is raised as a UserError. The record lists
the subject, each command's gesture and when it came (`gestures`), and what was not found (`notes`).
"""

from __future__ import annotations

import json
import math
import subprocess
import threading
import time
from dataclasses import dataclass, replace
from pathlib import Path

from agent.protocol.errors import UserError
from agent.protocol.spec import SyncMode
from agent.sph.radio import PERFECT, RadioModel
from agent.sph.robot import POINT, RobotModel
from coordinator import handover
from coordinator.camera import load_observation
from coordinator.control.fidelity import fidelity
from coordinator.control.imitation_setup import DEFAULT_CONTROLLER, DEFAULT_STEPS
from fluidswarm.imitate import run_options, score_formation, start_coordinator, write_target
from fluidswarm.run import Run, RunRecord, SwarmPlan
from fluidswarm.run_config import AGENTS, CAMERA_FPS, CAMERA_STALL_SECONDS, Access, Camera, RunConfig

FIRST_SECONDS = 30.0  # s for the first observation beyond opening the stream (the background needs frames)
END_LEAD_SECONDS = 0.5  # s of stepping between the coordinator's failure and the agents' common last step


def _coordinator_error(coord: subprocess.Popen, source: str) -> str:
    """The coordinator's one-line error, without its program prefix."""
    return handover.error_line(coord) or f"camera {source}: the coordinator stopped (code {coord.returncode})"


def _nothing_seen(folder: Path, source: str, timeout: float, subject: str) -> str:
    """What to say when no subject was seen in time: the last reason the coordinator logged."""
    what = "hand or person" if subject == "auto" else subject
    last = [e["what"] for e in read_events(folder) if e.get("event") == "missing"]
    return f"camera {source}: no {what} seen in {timeout:.0f} s" + (f" ({last[-1]})" if last else "")


def read_events(folder: Path) -> list[dict]:
    """The coordinator's events.jsonl (coordinator/camera.py EventLog); a torn last line is left out."""
    out: list[dict] = []
    try:
        lines = (folder / "events.jsonl").read_text().splitlines()
    except OSError:
        return out
    for line in lines:
        try:
            e = json.loads(line)
        except ValueError:
            continue
        if isinstance(e, dict) and isinstance(e.get("t"), (int, float)):
            out.append(e)
    return out


class CoordinatorWatch:
    """Ends the swarm together (ctl/end a little ahead of the fastest agent) if the coordinator exits: with
    an error (`failed`), or at the end of a video file."""

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
            step = max(self.launcher.max_step, 0)
            rate = step / max(time.monotonic() - self._t0, 1e-3)
            self.launcher.end_at(step + 5 + math.ceil(rate * END_LEAD_SECONDS))
            return


@dataclass
class CameraImitation:
    """Imitate the person seen by `source` for `steps` steps; the gesture sequence comes as it happens.
    fps [1/s]: at most this many frames observed per second; stall_seconds [s]: no new frame for this long
    is an error. `robot`, `radio`: the particles' body and drive and what their radios make of the states
    they receive, as for an input file (fluidswarm/imitate.py FileImitation)."""

    source: str
    agents: int = AGENTS
    steps: int = DEFAULT_STEPS
    controller: str = DEFAULT_CONTROLLER
    fps: float = CAMERA_FPS
    stall_seconds: float = CAMERA_STALL_SECONDS
    subject: str = "person"
    kind: str = "camera"
    robot: RobotModel = POINT
    radio: RadioModel = PERFECT
    ros2_router: str = ""  # a ROS 2 topic source (`ros2:/...`): the ROS 2 system's router (docs/ros2.md)

    def drive(self, run: Run) -> None:
        o = run.options
        tmp = run.scratch
        coord, pipe = start_coordinator(
            run,
            [
                "--camera",
                str(self.source),
                "--fps",
                repr(float(self.fps)),
                "--stall-seconds",
                repr(float(self.stall_seconds)),
                "--agents",
                str(self.agents),
                "--controller",
                self.controller,
                "--observations",
                str(tmp),
                "--subject",
                self.subject,
                *(["--ros2-router", self.ros2_router] if self.ros2_router else []),
            ],
        )
        run.launcher.helpers.forget(coord)  # its end is the stream's end, handled here: not a lost helper
        self.watch = watch = CoordinatorWatch(run.launcher, coord)
        run.on_start(watch.start)
        run.on_stop(watch.stop)
        wait = FIRST_SECONDS + self.stall_seconds
        self.im = im = handover.receive(
            pipe,
            coord,
            wait,
            lambda: _nothing_seen(tmp, self.source, wait, self.subject),
            what=f"the coordinator of camera {self.source}",
        )
        assert im.observation.frame is not None  # a camera's observation carries its picture
        if self.robot != POINT:
            try:  # before the recorder and the agents start
                im.setup = im.setup.with_robot(self.robot)
            except ValueError as exc:
                raise UserError(f"--robot: {exc}") from None
        if self.radio != PERFECT:
            im.setup = replace(im.setup, radio=self.radio.with_seed(o.seed))
        target, image = write_target(tmp, im, im.observation.frame)
        # the subject the coordinator chose (said before its first observation): with `auto`, not "auto"
        chosen = next((e for e in read_events(tmp) if e.get("event") == "subject"), {})
        meta = {
            "scenario": o.name,
            "camera": str(self.source),
            "fps": self.fps,
            "gesture": im.command.gesture,
            "controller": self.controller,
            "agents": self.agents,
            "steps": self.steps,
            "sync": SyncMode.LOCKSTEP,
            "seed": o.seed,
            "params": im.setup.params.as_dict(),
            "robot": im.setup.robot.as_dict(),
            "radio": im.setup.radio.as_dict(),
            "agent_ids": list(range(self.agents)),
            "transform": im.transform.as_dict(),
            "subject": str(chosen.get("subject", self.subject)),
            "subject_chosen": str(chosen.get("how", "given")),
            "realtime": True,
        }
        # the recorder follows the coordinator's notes and commands: its score is the last gesture's, as ours
        run.record_to(meta, im.setup.params.dt, target=target, image=image, coordinator_events=str(tmp))
        run.swarm(SwarmPlan(im.setup, self.steps))
        self.latest = load_observation(tmp / "latest.npz")
        self.events = read_events(tmp)  # before the run's scratch folder goes
        self.dt = im.setup.params.dt

    def account(self, run: Run) -> None:
        """The subject, each command's gesture and simulated time, and what was not found, into the record."""
        r, t0 = run.record, run.launcher.pacer.started_at
        for e in self.events:
            # Simulated time of an event: the wall time since the start, at the reached real-time factor.
            t = max(0.0, e["t"] - t0) * min(1.0, r.realtime_factor or 1.0) if t0 is not None else 0.0
            if e.get("event") == "subject":
                r.subject = f"{e.get('subject')} ({e.get('how')})"
            elif e.get("event") == "command":
                r.gestures.append(
                    {"seq": e.get("seq"), "gesture": str(e.get("gesture")), "t": round(t, 2), "why": str(e.get("why"))}
                )
            elif e.get("event") == "missing":
                r.notes.append(f"t={t:.2f} s: {e.get('what')}")
            elif e.get("event") == "end":
                r.notes.append(f"t={t:.2f} s: camera {self.source}: the video ended after {e.get('frames')} frames")

    def score(self, run: Run) -> None:
        self.account(run)
        coord = run.coordinator
        assert coord is not None  # drive() started it
        if self.watch.failed or coord.returncode not in (0, -15, None):
            raise UserError(f"{_coordinator_error(coord, self.source)} (recorded so far: {run.mcap})")
        # Against the last gesture commanded, from the final reports (the recorder scores the same target,
        # followed from the coordinator's events, on the last step it wrote).
        _ids, pos = run.record.done_positions()
        score = fidelity(self.latest.mask, self.im.transform, pos)
        score_formation(run, run.record, self.latest.mask, self.im, f"camera {self.source}", score)


def imitate_camera(camera: Camera, config: RunConfig) -> RunRecord:
    """`fluidswarm imitate --camera SOURCE [--subject hand|person|auto]` as `config` says, paced to the wall
    clock (on this host only: a camera's run has no workers)."""
    c = config
    kind = CameraImitation(
        camera.source,
        c.agents,
        c.steps,
        c.controller,
        camera.fps,
        camera.stall_seconds,
        camera.subject,
        robot=c.robot,
        radio=c.radio,
        ros2_router=camera.ros2_router,
    )
    with Run(kind, run_options(replace(config, access=Access()), realtime=True)) as run:
        kind.drive(run)
    return run.record
