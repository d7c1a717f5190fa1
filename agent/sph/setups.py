"""Initial particle layouts and per-particle controls of the thesis' experiments (pure, no I/O).

Used by `fluidswarm simulate`, `fluidswarm verify`, the agents' launcher and the tests, so every path
starts from the same deterministic set-up.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from agent.sph.obstacles import Obstacle, check_start
from agent.sph.params import Border, SPHParams
from agent.sph.particle import HEADING, SPEED, VX, VY, Control, X, Y, initial_state
from agent.sph.radio import PERFECT, RadioModel
from agent.sph.robot import POINT, RobotModel, body_centres, check_layout, initial_pose


@dataclass
class Setup:
    """A deterministic set-up: ids, initial states (N, NFIELDS), a Control per particle, class labels, and
    the particles' body and drive (`robot`, agent/sph/robot.py; `with_robot` gives another) and what their
    radios make of the states they receive (`radio`, agent/sph/radio.py) and the domain's static obstacles
    (`obstacles`, agent/sph/obstacles.py; `with_obstacles` checks them against the start layout)."""

    ids: np.ndarray
    states: np.ndarray
    controls: list
    classes: np.ndarray  # small integer label per particle (for colouring and per-class statistics)
    class_names: tuple[str, ...]
    params: SPHParams
    robot: RobotModel = POINT
    radio: RadioModel = PERFECT
    obstacles: tuple[Obstacle, ...] = ()

    def with_robot(self, robot: RobotModel) -> Setup:
        """This set-up with `robot` bodies: their initial poses, checked against the fluid's speed limit and
        the start layout (ValueError naming the robot's key)."""
        robot.check_fits(self.params.v_max)
        states = np.array(self.states, dtype=float)
        for row in states:
            row[HEADING], row[SPEED] = initial_pose(row[VX], row[VY], robot)
        check_layout(body_centres(states, robot), robot)
        if self.obstacles:
            check_start(body_centres(states, robot), self.obstacles, robot.radius)
        return replace(self, states=states, robot=robot)

    def with_obstacles(self, obstacles: tuple[Obstacle, ...]) -> Setup:
        """This set-up among `obstacles`: no body of the start layout may overlap one (ValueError naming it)."""
        check_start(body_centres(self.states, self.robot), obstacles, self.robot.radius)
        return replace(self, obstacles=tuple(obstacles))

    def obstacle_dicts(self) -> list[dict]:
        """The obstacles as the agent spec, the MCAP metadata and the scenario files write them."""
        return [o.as_dict() for o in self.obstacles]

    def moved_to(self, centre: tuple[float, float], margin: float = 3.0) -> Setup:
        """This set-up with its start layout moved to be centred on `centre` [m] (a scenario's `start`), the
        domain grown to hold it with `margin` m to spare."""
        states = np.array(self.states, dtype=float)
        shift = np.asarray(centre, dtype=float) - states[:, [X, Y]].mean(axis=0)
        states[:, X] += shift[0]
        states[:, Y] += shift[1]
        xmin, xmax, ymin, ymax = self.params.domain
        lo = states[:, [X, Y]].min(axis=0) - margin
        hi = states[:, [X, Y]].max(axis=0) + margin
        domain = (min(xmin, lo[0]), max(xmax, hi[0]), min(ymin, lo[1]), max(ymax, hi[1]))
        return replace(self, states=states, params=replace(self.params, domain=domain))


def lattice(n: int, columns: int, spacing: float = 1.0, origin: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
    """n points on a square lattice `columns` wide, row by row from `origin` (positions (n, 2))."""
    k = np.arange(n)
    return np.stack([origin[0] + spacing * (k % columns), origin[1] + spacing * (k // columns)], axis=1).astype(float)


BRANCHING_BETA_MIDDLE = 20.0  # N/m: the branching experiment's stiffer middle band (thesis §4.6)


def branching(
    n: int = 200,
    beta_middle: float = BRANCHING_BETA_MIDDLE,
    beta_edge: float | None = None,
    rows: int = 10,
    speed: float = 1.0,
    params: SPHParams | None = None,
) -> Setup:
    """Stiffness-only branching (thesis §4.6): a block moving along +x, middle band stiffer than edges.

    The particles fill a block `rows` high, row by row; the middle 40% of the rows form the middle band.
    All start at `speed` along +x and are kept moving by a push balanced by the drag (terminal speed =
    `speed`), with no waypoint. We found that a *stiffer middle* (beta_middle = 20 > beta_edge = 2, as
    the thesis' text and ch. 6 say, not the printed beta_middle = 2) splits the block: the middle band's
    pressure pushes the two edge bands apart into two branches (tests/test_physics_experiments.py).
    The edges are the fluid itself: beta_edge defaults to params.beta (2).
    """
    params = params or SPHParams(drag=0.5, domain=(-20.0, 100.0, -40.0, 50.0))
    beta_edge = params.beta if beta_edge is None else beta_edge
    columns = max(1, int(np.ceil(n / rows)))
    pos = lattice(n, columns)
    row = np.arange(n) // columns
    nrows = int(row.max()) + 1
    lo, hi = int(round(nrows * 0.3)), int(round(nrows * 0.7))
    middle = (row >= lo) & (row < hi)
    states = np.array([initial_state(x, y, speed, 0.0, params) for x, y in pos])
    push = params.drag * speed
    controls = [Control(beta=beta_middle if m else beta_edge, push_x=push) for m in middle]
    classes = np.where(middle, 1, np.where(row < lo, 0, 2))
    return Setup(np.arange(n), states, controls, classes, ("lower edge", "middle", "upper edge"), params)


def branch_gap(classes: np.ndarray, states: np.ndarray) -> float:
    """Distance in y between the upper and lower edge bands (median heights, classes 2 and 0) in the
    central 40 % of the flow's length: how far the two branches have moved apart."""
    x = states[:, X]
    lo, hi = np.percentile(x, [30, 70])
    slab = (x >= lo) & (x <= hi)
    up, down = slab & (classes == 2), slab & (classes == 0)
    if not up.any() or not down.any():
        return float("nan")
    return float(np.median(states[up, Y]) - np.median(states[down, Y]))


def spread_block(n: int = 64, spacing: float = 1.0, params: SPHParams | None = None, seed: int = 0) -> Setup:
    """A compact block with small deterministic velocity perturbations and a waypoint pull to its centre.

    The default set-up of `fluidswarm verify`: every term of the model is active (pressure, artificial
    viscosity, viscous stress, body force) so a decentralised run is compared on all of them.
    """
    params = params or SPHParams(mu=0.5, drag=0.2, domain=(-30.0, 60.0, -30.0, 60.0), border=Border.REFLECT)
    columns = max(1, int(round(np.sqrt(n))))
    pos = lattice(n, columns, spacing)
    rng = np.random.default_rng(seed)
    vel = rng.uniform(-0.5, 0.5, size=(n, 2))
    states = np.array([initial_state(x, y, vx, vy, params) for (x, y), (vx, vy) in zip(pos, vel)])
    centre = pos.mean(axis=0)
    betas = np.where(np.arange(n) % 3 == 0, 20.0, 2.0)
    controls = [Control(wx=centre[0], wy=centre[1], r=1.0, s=3.0, alpha=0.5, beta=b, mu=params.mu) for b in betas]
    classes = (betas > 2).astype(int)
    return Setup(np.arange(n), states, controls, classes, ("beta 2", "beta 20"), params)


def drag(n: int = 49, mu: float = 2.0, push: float = 1.0, params: SPHParams | None = None) -> Setup:
    """Viscosity drag (thesis §4.7): a square block at rest; only its centre particle is pushed along +x.
    Every particle has the fluid's viscosity and stiffness: params.mu and params.beta (`mu` when no params)."""
    params = params or SPHParams(mu=mu, domain=(-50.0, 80.0, -50.0, 80.0), border=Border.REFLECT)
    columns = max(1, int(round(np.sqrt(n))))
    pos = lattice(n, columns)
    centre = int(np.argmin(np.hypot(pos[:, 0] - pos[:, 0].mean(), pos[:, 1] - pos[:, 1].mean())))
    states = np.array([initial_state(x, y, 0.0, 0.0, params) for x, y in pos])
    controls = [Control(mu=params.mu, beta=params.beta, push_x=push if k == centre else 0.0) for k in range(n)]
    classes = np.where(np.arange(n) == centre, 1, 0)
    return Setup(np.arange(n), states, controls, classes, ("fluid", "pushed"), params)
