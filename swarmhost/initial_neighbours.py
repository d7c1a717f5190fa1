"""Step-0 neighbours handed to each agent in its spec (docs/protocol.md, "Step 0").

At step 0 nobody has been heard yet, so an agent must be told whom to wait for. The launcher placed the swarm and
knows every initial position: it gives each agent the agents within reach (a superset), and the agent keeps those
whose initial cell it watches — the set its own liveliness queries for `born` tokens used to return, without the
N × ~25 queries that each walk every token in the router (they stalled N = 1000; docs/benchmarks/native.md).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from agent.sph.params import SPHParams


def reach(params: SPHParams) -> float:
    """Distance [m] beyond which no agent can be in a watched cell: R_sub (kernel support + 10 steps at v_max,
    agent/native/src/agent.rs) plus a cell's diagonal (cells are squares of side h)."""
    return params.support + 10.0 * params.max_step_displacement + 1.5 * params.h


def initial_neighbours(ids, positions: npt.ArrayLike, params: SPHParams) -> dict[int, list[list[float]]]:
    """For each id, [[j, x_j, y_j], ...] of the other agents within `reach`; positions[k] is ids[k]'s (x, y),
    written exactly as in that agent's own spec so both compute the same cell."""
    ids = [int(i) for i in ids]
    xy = np.asarray(positions, dtype=float).reshape(len(ids), 2)
    near = cKDTree(xy).query_ball_point(xy, reach(params)) if ids else []
    return {
        i: [[ids[k], float(xy[k, 0]), float(xy[k, 1])] for k in sorted(near[n]) if k != n] for n, i in enumerate(ids)
    }
