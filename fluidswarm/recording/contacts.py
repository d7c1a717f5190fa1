"""What a robot user measures on a recorded swarm: collisions between bodies and the closest approach.

A collision is a pair of bodies closer than the sum of their radii (both `robot.radius`, centres from
agent/sph/robot.py body_centres); it is counted once per pair and episode: a pair that stays in contact
over consecutive recorded steps is one collision, a pair that parts and touches again is two.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from agent.sph.robot import RobotModel, body_centres


class ContactCounter:
    """Fed every recorded step (ids, full state rows); `collisions` and `min_separation_m` so far."""

    def __init__(self, robot: RobotModel):
        self.robot = robot
        self.touching: set[tuple[int, int]] = set()
        self.collisions = 0
        self.min_separation_m = math.inf

    def update(self, ids: np.ndarray, states: np.ndarray) -> None:
        if len(ids) < 2:
            self.touching = set()
            return
        centres = body_centres(states, self.robot)
        tree = cKDTree(centres)
        d, _ = tree.query(centres, k=2)
        self.min_separation_m = min(self.min_separation_m, float(d[:, 1].min()))
        now = set()
        if self.robot.radius > 0:
            for a, b in tree.query_pairs(2.0 * self.robot.radius, output_type="ndarray"):
                # query_pairs counts "<= r"; a collision is closer than the sum of the radii
                if float(np.hypot(*(centres[a] - centres[b]))) < 2.0 * self.robot.radius:
                    now.add((int(min(ids[a], ids[b])), int(max(ids[a], ids[b]))))
        self.collisions += len(now - self.touching)
        self.touching = now

    def figures(self) -> dict:
        """The metadata record `robots` of the MCAP (fluidswarm/recording/writer.py)."""
        return {
            "robot": self.robot.kind,
            "radius_m": self.robot.radius,
            "collisions": self.collisions,
            "min_separation_m": self.min_separation_m,
        }
