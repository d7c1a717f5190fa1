"""`fluidswarm imitate --camera DEVICE|URL|FILE`: the swarm follows a person or a hand watched live.

The coordinator process reads the camera (coordinator/camera.py) and puts its notes on the run's bus
(agent/protocol/imitation.py, heard here by coordinator/handover.py `Notes`): from the subject's first
observation this process plans the imitation itself (imitation_setup.py `imitation_for`, pure: the same map
and first command the coordinator built), places the swarm and starts the recorder, then the agents follow
each new command as the gesture changes, paced to the wall clock (simulated time = wall time, never
faster; the record's `realtime_factor` says what was reached). The run lasts `steps` steps, or until a
video file's last frame: then the coordinator exits 0 and the swarm finishes a few steps later, all agents
at the same step (the MCAP complete). If a device or URL ends or stalls, the coordinator exits with a
one-line error: the swarm finishes the same way and that line is raised as a UserError. The record lists
the subject, each command's gesture and when it came (`gestures`), and what was not found (`notes`).
"""

from __future__ import annotations

import math
import subprocess
import threading
import time
from dataclasses import dataclass, replace

import numpy as np

from agent.protocol.errors import UserError
from agent.protocol.imitation import Commanded, End, Missing, Subject
from agent.protocol.spec import SyncMode
from agent.sph.radio import PERFECT
from agent.sph.robot import POINT
from coordinator import handover
from coordinator.control.fidelity import fidelity
from coordinator.control.imitation_setup import imitation_for
from coordinator.control.observe import Observation
from fluidswarm.orchestration.imitate import run_options, score_formation, start_coordinator
from fluidswarm.orchestration.run import Run, RunRecord, SwarmPlan
from fluidswarm.orchestration.run_config import Access, Camera, RunConfig
from fluidswarm.recording.render import preload_figures

FIRST_SECONDS = 30.0  # s for the first observation beyond opening the stream (the background needs frames)
END_LEAD_SECONDS = 0.5  # s of stepping between the coordinator's failure and the agents' common last step


def _coordinator_error(coord: subprocess.Popen, source: str) -> str:
    """The coordinator's one-line error, without its program prefix."""
    return handover.error_line(coord) or f"camera {source}: the coordinator stopped (code {coord.returncode})"


def _nothing_seen(notes: handover.Notes, source: str, timeout: float, subject: str) -> str:
    """What to say when no subject was seen in time: the last reason the coordinator gave."""
    what = "hand or person" if subject == "auto" else subject
    last = notes.last_missing()
    return f"camera {source}: no {what} seen in {timeout:.0f} s" + (f" ({last})" if last else "")


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
    """Imitate the person seen by `camera` (run_config.py Camera: its source, at most `fps` frames
    observed per second, a stall of `stall_seconds` an error, the subject, a ROS 2 topic's router) with the
    swarm `config` describes (RunConfig: its agents for its steps, controller, the robots' body and drive and
    what their radios make of the states they receive, as for an input file, imitate.py
    FileImitation); the gesture sequence comes as it happens."""

    camera: Camera
    config: RunConfig
    kind: str = "camera"

    @property
    def agents(self) -> int:
        """The swarm's size (RunKind): its configuration's."""
        return self.config.agents

    def drive(self, run: Run) -> None:
        o = run.options
        tmp = run.scratch
        # heard from before the coordinator starts: none of its notes is said before we listen
        self.notes = notes = handover.Notes(run.launcher.session, run.launcher.run)
        run.on_stop(notes.close)
        coord = start_coordinator(
            run,
            [
                "--camera",
                str(self.camera.source),
                "--fps",
                repr(float(self.camera.fps)),
                "--stall-seconds",
                repr(float(self.camera.stall_seconds)),
                "--agents",
                str(self.config.agents),
                "--controller",
                self.config.controller,
                "--subject",
                self.camera.subject,
                *(["--ros2-router", self.camera.ros2_router] if self.camera.ros2_router else []),
            ],
        )
        run.launcher.helpers.forget(coord)  # its end is the stream's end, handled here: not a lost helper
        self.watch = watch = CoordinatorWatch(run.launcher, coord)
        run.on_start(watch.start)
        run.on_stop(watch.stop)
        run.on_stop(preload_figures)  # the formation picture's imports, while the processes stop (imitate.py)
        wait = FIRST_SECONDS + self.camera.stall_seconds
        seen = notes.wait_seen(
            coord,
            wait,
            lambda: _nothing_seen(notes, self.camera.source, wait, self.camera.subject),
            what=f"the coordinator of camera {self.camera.source}",
        )
        # planned here, from what the coordinator saw: its map and first command are the ones it built
        first = Observation(seen.observed, seen.mask, seen.label, None, seen.parts, seen.index)
        self.im = im = imitation_for([first], self.config.agents, self.config.controller)
        if self.config.robot != POINT:
            try:  # before the recorder and the agents start
                im.setup = im.setup.with_robot(self.config.robot)
            except ValueError as exc:
                raise UserError(f"--robot: {exc}") from None
        if self.config.radio != PERFECT:
            im.setup = replace(im.setup, radio=self.config.radio.with_seed(o.seed))
        target, image = tmp / "target.npz", tmp / "input.jpg"
        t = im.transform
        np.savez(target, mask=im.mask, scale=t.scale, x0=t.x0, y0=t.y0)
        image.write_bytes(seen.picture)  # the frame as the coordinator encoded it (what cv2.imwrite writes)
        heard = notes.notes()
        # the subject the coordinator chose (said before its first observation): with `auto`, not "auto"
        chosen = next((n for _t, n in heard if isinstance(n, Subject)), Subject(self.camera.subject, "given"))
        meta = {
            "scenario": o.recording.name,
            "camera": str(self.camera.source),
            "fps": self.camera.fps,
            "gesture": im.command.gesture,
            "controller": self.config.controller,
            "agents": self.config.agents,
            "steps": self.config.steps,
            "sync": SyncMode.LOCKSTEP,
            "seed": o.seed,
            "params": im.setup.params.as_dict(),
            "robot": im.setup.robot.as_dict(),
            "radio": im.setup.radio.as_dict(),
            "agent_ids": list(range(self.config.agents)),
            "transform": im.transform.as_dict(),
            "subject": chosen.subject,
            "subject_chosen": chosen.how,
            "realtime": True,
        }
        # The recorder follows the coordinator's notes and commands (its score is the last gesture's, as ours);
        # what was said before it listens is handed to it.
        early = tuple(n.what for _t, n in heard if isinstance(n, Missing))
        run.record_to(meta, im.setup.params.dt, target=str(target), image=str(image), coordinator_notes=early)
        run.swarm(SwarmPlan(im.setup, self.config.steps))
        self.heard = notes.notes()
        commanded = [n for _t, n in self.heard if isinstance(n, Commanded)]
        self.latest = commanded[-1].mask if commanded else im.mask  # the last gesture commanded
        self.dt = im.setup.params.dt

    def account(self, run: Run) -> None:
        """The subject, each command's gesture and simulated time, and what was not found, into the record."""
        r, t0 = run.record, run.launcher.pacer.started_at
        for heard_at, note in self.heard:
            # Simulated time of a note: the wall time since the start, at the reached real-time factor.
            t = max(0.0, heard_at - t0) * min(1.0, r.realtime_factor or 1.0) if t0 is not None else 0.0
            if isinstance(note, Subject):
                r.subject = f"{note.subject} ({note.how})"
            elif isinstance(note, Commanded):
                r.gestures.append({"seq": note.seq, "gesture": note.gesture, "t": round(t, 2), "why": note.why})
            elif isinstance(note, Missing):
                r.notes.append(f"t={t:.2f} s: {note.what}")
            elif isinstance(note, End):
                r.notes.append(f"t={t:.2f} s: camera {self.camera.source}: the video ended after {note.frames} frames")

    def score(self, run: Run) -> None:
        self.account(run)
        coord = run.coordinator
        assert coord is not None  # drive() started it
        if self.watch.failed or coord.returncode not in (0, -15, None):
            raise UserError(f"{_coordinator_error(coord, self.camera.source)} (recorded so far: {run.mcap})")
        # Against the last gesture commanded, from the final reports (the recorder scores the same target,
        # followed from the coordinator's notes, on the last step it wrote).
        _ids, pos = run.record.done_positions()
        score = fidelity(self.latest, self.im.transform, pos)
        score_formation(run, run.record, self.latest, self.im, f"camera {self.camera.source}", score)


def imitate_camera(camera: Camera, config: RunConfig) -> RunRecord:
    """`fluidswarm imitate --camera SOURCE [--subject hand|person|auto]` as `config` says, paced to the wall
    clock (on this host only: a camera's run has no workers)."""
    kind = CameraImitation(camera, config)
    with Run(kind, run_options(replace(config, access=Access()), realtime=True)) as run:
        kind.drive(run)
    return run.record
