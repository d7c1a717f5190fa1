"""What a robot user measures on a recorded swarm: collisions between bodies, the closest approach, and the
bodies' contacts with the domain's obstacles.

A collision is a pair of bodies closer than the sum of their radii (both `robot.radius`, centres from
agent/sph/robot.py body_centres); it is counted once per pair and episode: a pair that stays in contact
over consecutive recorded steps is one collision, a pair that parts and touches again is two.

An obstacle penetration is a body overlapping an obstacle (its centre closer to the obstacle's boundary than
its radius, or inside it; agent/sph/obstacles.py), counted once per agent and episode in the same way;
`min_obstacle_distance_m` is the closest approach of a body centre to an obstacle's boundary (negative:
inside), so a body touches an obstacle at `radius`.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from agent.sph.obstacles import Obstacle, clearances
from agent.sph.robot import RobotModel, body_centres


class ContactCounter:
    """Fed every recorded step (ids, full state rows); `collisions` and `min_separation_m` so far, and with
    `obstacles` `obstacle_penetrations` and `min_obstacle_distance_m`."""

    def __init__(self, robot: RobotModel, obstacles: tuple[Obstacle, ...] = ()):
        self.robot = robot
        self.obstacles = tuple(obstacles)
        self.touching: set[tuple[int, int]] = set()
        self.collisions = 0
        self.min_separation_m = math.inf
        self.overlapping: set[int] = set()
        self.obstacle_penetrations = 0
        self.min_obstacle_distance_m = math.inf

    def update(self, ids: np.ndarray, states: np.ndarray) -> None:
        if self.obstacles and len(ids):
            self._update_obstacles(ids, body_centres(states, self.robot))
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

    def _update_obstacles(self, ids: np.ndarray, centres: np.ndarray) -> None:
        gap = clearances(centres, self.obstacles)
        self.min_obstacle_distance_m = min(self.min_obstacle_distance_m, float(gap.min()))
        # overlapping: closer than the radius (a point of radius 0 only when inside: gap < 0)
        now = {int(i) for i, g in zip(ids, gap) if g < self.robot.radius or g < 0.0}
        self.obstacle_penetrations += len(now - self.overlapping)
        self.overlapping = now

    def figures(self) -> dict:
        """The metadata record `robots` of the MCAP (fluidswarm/recording/writer.py)."""
        out = {
            "robot": self.robot.kind,
            "radius_m": self.robot.radius,
            "collisions": self.collisions,
            "min_separation_m": self.min_separation_m,
        }
        if self.obstacles:
            out.update(
                obstacles=len(self.obstacles),
                obstacle_penetrations=self.obstacle_penetrations,
                min_obstacle_distance_m=self.min_obstacle_distance_m,
            )
        return out
