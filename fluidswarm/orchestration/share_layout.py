"""Where an imitation's swarm is going, for cutting it between hosts (`--workers M`, docs/multi-host.md).

A run with workers gives each host a compact region (agent/sph/regions.py). Cut by the start layout, the
regions do not stay compact: the swarm leaves its start block for the gesture, and over a whole imitation the
start layout's regions let as many neighbour pairs cross between hosts as ranges of ids do (1.02 × on the
three-host test's recording, scripts/share_cuts_over_run.py). Cut by the formation the swarm reaches, 0.67 ×.
The swarm is deterministic enough to say that formation ahead: the numpy oracle (agent/sph/reference.py
VectorisedDriver), following the command as every agent does (coordinator/control/route.py followers_for),
ends within 1.2 cm of the recorded swarm after 468 steps (90 agents, 0.6 s of one core).
"""

from __future__ import annotations

import time

import numpy as np

from agent.sph.reference import VectorisedDriver
from agent.sph.setups import Setup
from coordinator.control.route import followers_for

AHEAD_STEPS = 300  # the formation by then: regions of step 300 cut as few pairs as those of the last (468)
AHEAD_SECONDS = 20.0  # wall budget of the prediction (a large swarm stops early, at the step it reached)


def formation_ahead(
    setup: Setup, command, steps: int = AHEAD_STEPS, budget: float = AHEAD_SECONDS
) -> np.ndarray | None:
    """The swarm's positions (n, 2), in `setup`'s order, after `steps` steps of the oracle following `command`
    (or as many as `budget` s allow); None when the oracle does not model the set-up (an imperfect radio,
    obstacles): the caller then cuts the start layout."""
    if not setup.radio.is_perfect or setup.obstacles:
        return None
    driver = VectorisedDriver(setup.ids, setup.states, followers_for(command, setup.ids), setup.params, setup.robot)
    deadline = time.monotonic() + budget
    for _ in range(steps):
        driver.step()
        if time.monotonic() > deadline:
            break
    out = np.empty((len(setup.ids), 2))
    out[np.argsort(np.asarray(setup.ids), kind="stable")] = driver.states[:, :2]  # the driver sorts by id
    return out
