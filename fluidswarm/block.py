"""The plainest kind of run: a spread block of agents (launch, verify, bench), optionally checked."""

from __future__ import annotations

import sys
from dataclasses import dataclass, replace

import numpy as np

from agent.sph.obstacles import Obstacle
from agent.sph.radio import PERFECT, RadioModel
from agent.sph.robot import POINT, RobotModel
from fluidswarm.orchestration.run import Run, SwarmPlan, Sync

EXACT = 1e-9  # m: the agents' positions must match the reference driver's to this (float rounding only)


@dataclass
class Block:
    """`agents` agent processes on a spread block (agent/sph/setups.py) for `steps` steps; `ids` the slice
    started on this host (None: all); `record` an MCAP file to write (None: none); `reference`: compare the
    final states with the per-particle reference driver (`figures["max_position_error"]` [m]); `robot` the
    particles' body and drive (agent/sph/robot.py; checked against the block by `setup()` before the run);
    `radio` what their radios make of the states they receive (agent/sph/radio.py); `obstacles` the static
    obstacles in its domain (agent/sph/obstacles.py; checked against the block's start layout)."""

    agents: int
    steps: int
    sync: Sync = Sync()
    ids: list[int] | None = None
    record: str | None = None
    reference: bool = False
    startup_timeout: float | None = None
    run_timeout: float | None = None
    kind: str = "launch"
    robot: RobotModel = POINT
    radio: RadioModel = PERFECT
    obstacles: tuple[Obstacle, ...] = ()

    def make_setup(self):
        """The block with its robots (ValueError naming the robot's key when they do not fit it)."""
        from agent.sph.setups import spread_block

        setup = spread_block(self.agents)
        setup = setup if self.robot == POINT else setup.with_robot(self.robot)
        setup = setup.with_obstacles(self.obstacles) if self.obstacles else setup
        return setup if self.radio == PERFECT else replace(setup, radio=self.radio)

    def drive(self, run: Run) -> None:
        run.launcher.check_ids(range(self.agents))  # before the recorder: nothing starts for a swarm too large
        self.setup = setup = self.make_setup()
        if self.record:
            run.record_to(
                {
                    "scenario": "launch",
                    "agents": self.agents,
                    "steps": self.steps,
                    "params": setup.params.as_dict(),
                    "robot": setup.robot.as_dict(),
                    "radio": setup.radio.as_dict(),
                    "obstacles": setup.obstacle_dicts(),
                },
                setup.params.dt,
                path=self.record,
            )
        run.swarm(
            SwarmPlan(
                setup,
                self.steps,
                self.sync,
                ids=self.ids,
                swarm_ids=list(setup.ids),
                startup_timeout=self.startup_timeout,
                run_timeout=self.run_timeout,
            )
        )

    def score(self, run: Run) -> None:
        if not self.reference:
            return
        from agent.sph.particle import X, Y
        from agent.sph.reference import PerParticleDriver

        s, r = self.setup, run.record
        ids = self.ids if self.ids is not None else [int(i) for i in s.ids]
        reference = PerParticleDriver(s.ids, s.states, s.controls, s.params, s.robot, s.radio, s.obstacles).run(
            self.steps
        )
        missing = [i for i in ids if i not in r.finals or not r.finals[i].done]
        r.figures["agents_missing"] = len(missing)
        if missing:
            why = ", ".join(_why_unfinished(i, r.finals.get(i)) for i in missing[:5])
            print(f"fluidswarm verify: {len(missing)} agents did not finish (first: {why})", file=sys.stderr)
            error = float("inf")
        else:
            got = np.array([r.finals[i].state for i in ids])
            error = float(np.abs(got[:, [X, Y]] - reference[ids][:, [X, Y]]).max())
        r.figures["max_position_error"] = error
        if not error <= EXACT:
            r.passed = False
            r.why.append(f"max_position_error {error:.3e} > {EXACT:g} m")


def _why_unfinished(i: int, report) -> str:
    """`7 (fell_behind after 41 steps, 3 neighbour timeouts)` or `7 (no report)`: which end a missing agent came to."""
    if report is None:
        return f"{i} (no report)"
    return f"{i} ({report.status.value} after {report.steps} steps, {report.timeouts} neighbour timeouts)"
