"""Physics experiments of a scenario file (branching, drag) through agent processes: a `RunKind`."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from agent.protocol.errors import UserError
from agent.protocol.spec import SyncMode
from agent.sph.setups import branch_gap
from fluidswarm.orchestration.run import Run, SwarmPlan, Sync
from fluidswarm.scenario import Scenario

DEFAULT_STEPS = 400


def experiment_setup(sc: Scenario, agents: int):
    """The scenario's set-up (agent/sph/setups.py) for `agents` particles, with its [sph] and dt overrides and its
    [robot] (a UserError naming the key when the robots do not fit it), its [radio], its `start` and its
    [[obstacle]] tables (a UserError naming the obstacle that overlaps the start layout)."""
    from agent.sph import setups
    from agent.sph.robot import POINT

    bases: dict[str, Callable[..., setups.Setup]] = {"branching": setups.branching, "drag": setups.drag}
    base = bases[sc.experiment]
    setup = base(agents)
    if sc.sph or sc.dt:
        setup = base(agents, params=setup.params.with_overrides(sc.sph, sc.dt))
    if not sc.radio.is_perfect:
        setup = replace(setup, radio=sc.radio)
    if sc.start is not None:
        setup = setup.moved_to(sc.start)
    try:
        if sc.robot != POINT:
            setup = setup.with_robot(sc.robot)
        return setup.with_obstacles(sc.obstacles) if sc.obstacles else setup
    except ValueError as exc:
        key, _, problem = str(exc).partition(": ")
        raise UserError(f"{sc.path}: key '{key}': {problem}") from None


def scenario_sync(sc: Scenario) -> Sync:
    return Sync(SyncMode(sc.sync), sc.async_rate, sc.async_max_age)


@dataclass
class Experiment:
    """The scenario `sc` (experiment branching or drag) with `agents` agent processes, recorded, with the
    run's failures; scored by the branch gap [m] (branching) or the mean x velocity [m/s] (drag)."""

    sc: Scenario
    agents: int
    kind: str = "experiment"

    def drive(self, run: Run) -> None:
        sc = self.sc
        self.setup = setup = experiment_setup(sc, self.agents)
        steps = sc.steps or DEFAULT_STEPS
        meta = {
            "scenario": sc.name,
            "scenario_file": str(sc.path),
            "experiment": sc.experiment,
            "agents": self.agents,
            "steps": steps,
            "seed": sc.seed,
            "sync": sc.sync,
            "params": setup.params.as_dict(),
            "robot": setup.robot.as_dict(),
            "radio": setup.radio.as_dict(),
            "obstacles": setup.obstacle_dicts(),
            "agent_ids": [int(i) for i in setup.ids],
            "failures": [f.__dict__ for f in sc.failures],
        }
        run.record_to(meta, setup.params.dt)
        drop = {f.agent: {"drop_out": f.fraction} for f in sc.failures if f.kind == "drop"}
        run.swarm(SwarmPlan(setup, steps, scenario_sync(sc), per_agent=drop))

    def score(self, run: Run) -> None:
        record, setup = run.record, self.setup
        ids, pos = record.done_positions()
        # late joiners take the class of particle 0 (they were given its control)
        index = {int(i): k for k, i in enumerate(setup.ids)}
        classes = np.array([setup.classes[index.get(i, 0)] for i in ids], dtype=int)
        if self.sc.experiment == "branching":
            gap = branch_gap(classes, pos) if ids else math.nan
            record.figures["branch_gap"] = 0.0 if math.isnan(gap) else gap
        if self.sc.experiment == "drag":
            record.figures["mean_vx"] = float(np.mean([record.finals[i].state[2] for i in ids])) if ids else 0.0
