"""Imitation runs of a file (image, folder of frames, video): one frame, or a gesture sequence.

The imitation is planned here, in the process that runs the swarm: perception observes the input once and
coordinator/control/imitation_setup.py `imitation_for` (pure) gives the swarm's start, the transform and the
commands. The coordinator process is handed the commands, signed with the run's key, as a plan on the bus
(agent/protocol/imitation.py, coordinator/handover.py `hand_plan`) and broadcasts them, paced by the run's
clock. The run is a `run.Run`; this module is its `RunKind` (drive: plan, start the coordinator,
record, run the swarm with the settle watch; score: fidelity of the final formation, the formation PNG).
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np

from agent.protocol.errors import UserError
from agent.protocol.imitation import Plan
from agent.sph.obstacles import Obstacle
from agent.sph.radio import PERFECT
from agent.sph.robot import POINT
from coordinator import handover
from coordinator.control.fidelity import Fidelity
from coordinator.control.fill import ShapeError
from coordinator.control.imitation_setup import Imitation, imitation_of_input
from coordinator.control.settle import SettleRule, SettleWatch
from fluidswarm.orchestration.run import Run, RunOptions, RunRecord, SwarmPlan, Sync, busy_with_failures
from fluidswarm.orchestration.run_config import RunConfig
from fluidswarm.recording.reader import recorded_fidelity
from fluidswarm.recording.render import plot_formation, preload_figures
from perception.io import InputError
from perception.segmentation import SegmentationError
from swarmhost.supervisor import die_with_parent

PLAN_SECONDS = 120.0  # s for the coordinator to start and command the plan (a loaded 2-core machine)


def start_coordinator(run: Run, args: list[str]) -> subprocess.Popen:
    """The coordinator process on the run's bus (`python -m coordinator ARGS`), with the run's command key and
    its credentials in its environment; its one-line error is read from its stderr (handover.error_line)."""
    la = run.launcher
    # the run's command key and the coordinator's credentials (docs/security.md) travel in its environment
    env = dict(os.environ, FLUIDSWARM_SECRET=la.secret, **la.access.env_for("coordinator"))
    cmd = [sys.executable, "-m", "coordinator", "--connect", la.endpoint, "--run", la.run]
    proc = subprocess.Popen(
        cmd + args,
        env=env,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        preexec_fn=die_with_parent,  # noqa: PLW1509  # only prctl(PR_SET_PDEATHSIG): no locks, no allocation
    )
    run.add_coordinator(proc)
    return proc


def command_plan(run: Run, plan: Plan) -> subprocess.Popen:
    """The run's coordinator, commanding `plan`: started, and handed the plan on the bus until it commands
    (coordinator/handover.py hand_plan; one that fails first is its own one-line CoordinatorFailed).

    The hand-over runs beside the recorder's and the agents' start-up (the coordinator's own start, ~0.8 s of
    a 300-agent imitation, used to come before them); the swarm's first step waits for it (Run.before_start),
    so no agent steps before the plan is commanded, as before."""
    proc = start_coordinator(run, ["--plan"])
    failed: list[Exception] = []

    def hand() -> None:
        try:
            handover.hand_plan(run.launcher.session, run.launcher.run, plan, proc, PLAN_SECONDS)
        except Exception as exc:  # noqa: BLE001  # re-raised on the caller's thread, before the first step
            failed.append(exc)

    handing = threading.Thread(target=hand, name="plan-handover", daemon=True)
    handing.start()

    def commanded() -> None:
        handing.join()
        if failed:
            raise failed[0]

    run.before_start(commanded)
    return proc


class PerceptionFailed(UserError):
    """The input could not be perceived or imitated: one line naming the input and why."""


def perceive(input_path: str, agents: int, controller: str, frame: int | None) -> Imitation:
    """The imitation of `input_path` (coordinator/control/imitation_setup.py, pure), planned here where the
    swarm runs: its frame `frame`, or with None all its frames as a gesture sequence."""
    try:
        return imitation_of_input(input_path, agents, controller, frame)
    except (InputError, SegmentationError, ShapeError) as exc:
        raise PerceptionFailed(str(exc) if str(input_path) in str(exc) else f"{input_path}: {exc}") from None


def write_target(folder: Path, im: Imitation, frame_bgr: np.ndarray) -> tuple[str, str]:
    """The recorder's target (mask + transform, .npz) and input picture (.jpg) in `folder`."""
    target, image = folder / "target.npz", folder / "input.jpg"
    t = im.transform
    np.savez(target, mask=im.mask, scale=t.scale, x0=t.x0, y0=t.y0)
    cv2.imwrite(str(image), frame_bgr)
    return str(target), str(image)


def score_formation(
    run: Run,
    record: RunRecord,
    mask: np.ndarray,
    im: Imitation,
    title: str,
    score: Fidelity,
    waypoints=None,
    outline=(),
) -> None:
    """The formation's `score` into the record, and the formation PNG of the finished agents over `mask`."""
    ids, pos = record.done_positions()
    classes = np.array([record.finals[i].particle_class for i in ids], dtype=int)
    record.fidelity = score
    t = im.transform
    rows, cols = mask.shape
    extent = (t.x0, t.x0 + cols * t.scale, t.y0 - rows * t.scale, t.y0)
    assert run.options.recording.out is not None  # an imitation writes its formation picture (Recording.out)
    png = plot_formation(
        Path(run.options.recording.out) / f"{run.options.recording.name}_formation.png",
        pos,
        classes,
        [c.name for c in im.command.classes],
        f"{title}: {len(ids)} agents, iou {record.fidelity.iou:.2f}",
        background=mask.astype(float),
        extent=extent,
        waypoints=waypoints,
        outline=outline,
    )
    record.pictures.append(str(png))
    last_step = max((r.steps for r in record.finals.values() if r.done), default=0)
    if record.formation_seconds is None:
        record.formation_seconds = last_step * im.setup.params.dt
        record.formation_wall_seconds = record.wall_seconds
        record.formation_settled = False


@dataclass
class FileImitation:
    """Imitate `input_path` with the swarm `config` describes (run_config.py RunConfig: its agents,
    steps, controller, the robots' body and drive, what their radios make of the states they receive, the
    radio's draws seeded from the run's seed): one frame (`frame`, default 0) until the formation settles
    (`settle`; None: always its steps), or with `frame_steps` > 0 the gesture sequence of all its frames, each
    shown for `frame_steps` swarm steps. `sph`/`dt` override the imitation's SPH parameters; `drop`: agent id ->
    fraction of its states it drops (failure injection)."""

    input_path: str
    config: RunConfig
    frame: int | None = None
    frame_steps: int = 0
    sph: dict | None = None
    dt: float = 0.0
    sync: Sync = Sync()
    drop: dict | None = None
    settle: SettleRule | None = SettleRule()
    kind: str = "imitation"
    obstacles: tuple[Obstacle, ...] = ()  # the domain's static obstacles (agent/sph/obstacles.py)
    start: tuple[float, float] | None = None  # the start layout's centre [m]; None: the silhouette's interior
    source: str = "--obstacles"  # what bad obstacles or a bad start are named after (a scenario file)

    @property
    def agents(self) -> int:
        """The swarm's size (RunKind): its configuration's."""
        return self.config.agents

    def __post_init__(self):
        if self.frame_steps > 0:
            self.kind = "sequence"

    def drive(self, run: Run) -> None:
        sequence = self.frame_steps > 0
        frame = None if sequence else (0 if self.frame is None else self.frame)
        im = perceive(self.input_path, self.config.agents, self.config.controller, frame)
        if self.sph or self.dt:
            im.setup.params = im.setup.params.with_overrides(self.sph or {}, self.dt)
        if self.start is not None:
            im.setup = im.setup.moved_to(self.start)
        if self.config.robot != POINT:
            try:  # before the recorder and the agents start
                im.setup = im.setup.with_robot(self.config.robot)
            except ValueError as exc:
                raise UserError(f"--robot: {exc}") from None
        if self.obstacles:
            im.setup = self._among_obstacles(im)
        o = run.options
        if self.config.radio != PERFECT:
            im.setup = replace(im.setup, radio=self.config.radio.with_seed(o.seed))
        self.im = im
        # its coordinator broadcasts the planned commands (signed with the run's key), paced by the run's clock
        plan = Plan(tuple((first, c.encode(bytes.fromhex(run.launcher.secret))) for first, c in im.commands))
        command_plan(run, replace(plan, frame_steps=self.frame_steps if sequence else 0))
        tmp = run.scratch
        assert im.observation.frame is not None  # observe() keeps the picture of every frame it read
        target, image = write_target(tmp, im, im.observation.frame)
        meta = {
            "scenario": o.recording.name,
            "input": str(self.input_path),
            "frame": frame,
            "frame_steps": self.frame_steps,
            "gesture": im.command.gesture,
            "controller": self.config.controller,
            "agents": self.config.agents,
            "steps": self.config.steps,
            "seed": o.seed,
            "sync": self.sync.mode,
            "params": im.setup.params.as_dict(),
            "robot": im.setup.robot.as_dict(),
            "radio": im.setup.radio.as_dict(),
            "obstacles": im.setup.obstacle_dicts(),
            "agent_ids": list(range(self.config.agents)),
            "transform": im.transform.as_dict(),
            "failures": [getattr(f, "__dict__", str(f)) for f in o.failures],
        }
        run.record_to(meta, im.setup.params.dt, target=target, image=image)
        self.watch = None
        if self.settle is not None and not sequence:
            # the formation may settle before the failures are due: not before they have all happened
            self.watch = SettleWatch(
                run.launcher, im.mask, im.transform, im.setup.params.dt, self.settle, busy_with_failures(run)
            )
            run.on_start(self.watch.start)
            run.on_stop(self.watch.stop)
        run.on_stop(preload_figures)  # the formation picture's imports, while the processes stop
        first = im.command.classes[0].route[0]  # late joiners start at the palm / torso centre
        layout = None
        if (
            o.access.workers and o.access.shares == "formation" and not sequence
        ):  # a sequence's later gestures are not known yet
            from fluidswarm.orchestration.share_layout import formation_ahead

            layout = formation_ahead(im.setup, im.command)
        run.swarm(
            SwarmPlan(
                im.setup,
                self.config.steps,
                self.sync,
                per_agent={i: {"drop_out": f} for i, f in (self.drop or {}).items()},
                joiners_at=(first.x, first.y),
                share_layout=layout,
            )
        )

    def _among_obstacles(self, im):
        """The set-up among the obstacles: refused (one line naming the obstacle) when one overlaps a start body
        or they cover more than MAX_COVERED of the target silhouette."""
        from agent.sph.obstacles import MAX_COVERED, covered_share

        try:
            setup = im.setup.with_obstacles(self.obstacles)
        except ValueError as exc:
            key, _, problem = str(exc).partition(": ")
            raise UserError(f"{self.source}: key '{key}': {problem}") from None
        vs, us = np.nonzero(im.mask)
        pick = np.linspace(0, len(us) - 1, min(len(us), 4000)).astype(int) if len(us) else np.array([], int)
        points = im.transform.to_domain(np.stack([us[pick] + 0.5, vs[pick] + 0.5], axis=1)) if len(pick) else []
        share = covered_share(points, self.obstacles)
        if share > MAX_COVERED:
            raise UserError(
                f"{self.source}: key 'obstacle': the obstacles cover {share:.0%} of the target silhouette "
                f"(at most {MAX_COVERED:.0%}: the swarm must have room to form it)"
            )
        return setup

    def score(self, run: Run) -> None:
        record, im = run.record, self.im
        w = self.watch
        if w is not None and w.settled_step is not None:
            record.formation_seconds = w.settled_step * im.setup.params.dt
            record.formation_wall_seconds = w.settled_wall_seconds
            record.formation_settled = True
        sequence = self.frame_steps > 0
        fill = im.command.fill
        wps = None if sequence or fill else np.array([[c.route[-1].x, c.route[-1].y] for c in im.command.classes])
        # Scored once, by the recorder, which sees every state: the last recorded step against the target
        # (for a sequence, the last frame's silhouette); nothing recorded, nothing formed.
        assert run.mcap is not None  # an imitation is always recorded (drive() started the recorder)
        score = recorded_fidelity(run.mcap) or Fidelity(0.0, 0.0, 0.0)
        score_formation(
            run,
            record,
            im.mask,
            im,
            Path(self.input_path).name,
            score,
            waypoints=wps,
            outline=fill.rings if fill is not None and not sequence else (),
        )


def run_options(config: RunConfig, realtime: bool | None = None, progress: bool = False) -> RunOptions:
    """What the `Run` of an imitation needs of its configuration (`realtime`: None for the configuration's)."""
    from agent.protocol.spec import NEIGHBOUR_TIMEOUT

    return RunOptions(
        config.recording,
        NEIGHBOUR_TIMEOUT.imitation,
        commands=True,
        progress=progress,
        access=config.access,
        realtime=config.realtime if realtime is None else realtime,
    )


def imitate(input_path: str, config: RunConfig, frame: int | None = None, progress: bool = False) -> RunRecord:
    """`fluidswarm imitate INPUT`: one frame of `input_path` imitated as `config` says (run_config.py);
    with workers in its access (and connect, run, the users file) this host runs region 1 of 1 + workers and
    `fluidswarm worker`s on other hosts the rest (docs/multi-host.md)."""
    kind = FileImitation(str(input_path), config, frame)
    with Run(kind, run_options(config, progress=progress)) as this:
        kind.drive(this)
    return this.record
