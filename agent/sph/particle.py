"""One particle's step: the function every agent process runs, and the reference drivers too.

A particle's state is a row of `NFIELDS` float64 values (layout below). The density, pressure and
viscous stress in a state are those of the *previous* configuration: a particle can only evaluate its
density once it knows its neighbours' positions, and we want one exchange of messages per step, so the
forces at step n use the density, pressure and stress evaluated at step n-1 by each particle (its own
and its neighbours' alike, so the pair forces stay antisymmetric). The reference drivers use exactly
the same lag, so a swarm of agents reproduces them bit for bit (docs/protocol.md).

A second lag, in the stress: the stress rate of configuration n (eq. 3.11, weights m_j / rho_j) is built
with the neighbours' density as their states carry it, i.e. of configuration n-1, since their density of
configuration n is only published with their next state. That stress enters the forces at step n+1, so
there it uses the neighbours' density of two configurations before. The thesis' flow chart (Fig. 3.5,
two exchanges) would use the current one; `python -m research reproduce` measures both
(docs/thesis-reproduction.md).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from agent.sph.equations import (
    artificial_viscosity,
    body_force,
    density_terms,
    momentum_terms,
    stress_rate_terms,
    tait_pressure,
)
from agent.sph.kernel import gaussian_kernel, kernel_gradient
from agent.sph.obstacles import OBSTACLE_MARGIN, Obstacle, obstacle_acceleration
from agent.sph.params import Border, SPHParams
from agent.sph.robot import (
    POINT,
    RobotKind,
    RobotModel,
    braking_distance,
    contact_acceleration,
    holonomic_velocity,
    initial_pose,
    unicycle_step,
)

# State layout: position, velocity, then the lagged fluid quantities the neighbours need, then flags, then
# a robot's pose (agent/sph/robot.py): heading [rad] and forward speed [m/s] of a unicycle (0 otherwise).
X, Y, VX, VY, RHO, P, SXX, SXY, SYY, FROZEN, HEADING, SPEED = range(12)
NFIELDS = 12
FIELD_NAMES = ("x", "y", "vx", "vy", "rho", "p", "sxx", "sxy", "syy", "frozen", "heading", "speed")


@dataclass(frozen=True)
class Control:
    """What the controller sets for one particle at one step: its waypoint and its fluid parameters.

    wx, wy [m] waypoint; r [m] radius with no force; s [m] spread over which the force ramps up;
    alpha [1/s^2] gain (eq. 6.2). alpha = 0 means no body force. beta [N/m] stiffness, mu [kg/s]
    viscosity for this particle; their defaults are the fluid's (SPHParams.beta, .mu), written once there.
    push (fx, fy) [m/s^2] a constant extra body force (thesis §4.7 drag experiment, where one particle is
    pushed).
    """

    wx: float = 0.0
    wy: float = 0.0
    r: float = 0.0
    s: float = 0.0
    alpha: float = 0.0
    beta: float = SPHParams.beta
    mu: float = SPHParams.mu
    push_x: float = 0.0
    push_y: float = 0.0

    def control(self, state: np.ndarray, step: int) -> Control:
        """A Control is its own (static) control source."""
        return self


def initial_state(x: float, y: float, vx: float, vy: float, params: SPHParams, robot: RobotModel = POINT) -> np.ndarray:
    """State at step 0: density at rest (rho0), so zero pressure and zero stress until step 1; a robot's
    initial pose (robot.initial_pose)."""
    state = np.zeros(NFIELDS)
    state[[X, Y, VX, VY]] = x, y, vx, vy
    state[RHO] = params.rho0
    state[HEADING], state[SPEED] = initial_pose(vx, vy, robot)
    return state


def interacting(own: np.ndarray, neighbours: np.ndarray, params: SPHParams) -> np.ndarray:
    """Rows of `neighbours` that interact with `own`: within the support kappa*h and not frozen."""
    dx = own[X] - neighbours[:, X]
    dy = own[Y] - neighbours[:, Y]
    support = params.support
    return neighbours[(dx * dx + dy * dy <= support * support) & (neighbours[:, FROZEN] == 0.0)]


def step_particle(
    own: np.ndarray,
    neighbours: np.ndarray,
    control: Control,
    params: SPHParams,
    robot: RobotModel = POINT,
    obstacles: Sequence[Obstacle] = (),
) -> np.ndarray:
    """Next state of one particle from its own state and its neighbours' states (rows sorted by id).

    `neighbours` may hold any superset of the particles within kappa*h (self excluded): rows outside the
    support or frozen are dropped here, so every caller gets the same sums in the same order.
    Integration: symplectic Euler, v' = v + dt a, x' = x + dt v' (speed capped at v_max). A robot takes
    u = v + dt a as its desired velocity and moves as its drive allows (agent/sph/robot.py). `obstacles` push
    its body away with the boundary force of agent/sph/obstacles.py (none: the step is as without them).
    """
    if own[FROZEN] != 0.0:
        return own.copy()
    nb = interacting(own, neighbours, params)
    h, m = params.h, params.mass
    dx = own[X] - nb[:, X]
    dy = own[Y] - nb[:, Y]
    dvx = own[VX] - nb[:, VX]
    dvy = own[VY] - nb[:, VY]
    dWdx, dWdy = kernel_gradient(dx, dy, h, params.kappa)

    # Momentum equation (eq. 3.7-3.8) with the lagged rho, p and stress of step n-1.
    pi_ij = artificial_viscosity(dx, dy, dvx, dvy, own[RHO], nb[:, RHO], h, params.beta_pi)
    ax, ay = momentum_terms(
        dWdx,
        dWdy,
        m,
        own[RHO],
        nb[:, RHO],
        own[P],
        nb[:, P],
        pi_ij,
        own[SXX],
        own[SXY],
        own[SYY],
        nb[:, SXX],
        nb[:, SXY],
        nb[:, SYY],
    )
    fx, fy = body_force(own[X], own[Y], control.wx, control.wy, control.r, control.s, control.alpha)
    acc_x = float(np.sum(ax)) + float(fx) + control.push_x - params.drag * own[VX]
    acc_y = float(np.sum(ay)) + float(fy) + control.push_y - params.drag * own[VY]
    if robot.kind != RobotKind.POINT:  # robots keep their bodies apart (robot.py: contact_terms)
        cx, cy = contact_acceleration(own, nb, robot, params.h)
        acc_x, acc_y = acc_x + cx, acc_y + cy
    if obstacles:
        ox, oy = obstacle_push(own, obstacles, params, robot)
        acc_x, acc_y = acc_x + ox, acc_y + oy

    new = own.copy()
    new[VX], new[VY] = own[VX] + params.dt * acc_x, own[VY] + params.dt * acc_y
    if robot.kind == RobotKind.UNICYCLE:
        (new[X], new[Y], new[VX], new[VY], new[HEADING], new[SPEED]) = unicycle_step(
            own[X], own[Y], own[HEADING], own[SPEED], new[VX], new[VY], robot, params.dt
        )
    else:
        if robot.kind == RobotKind.HOLONOMIC:
            new[VX], new[VY] = holonomic_velocity(own[VX], own[VY], new[VX], new[VY], robot, params.dt)
        cap_speed(new, params)
        new[X], new[Y] = own[X] + params.dt * new[VX], own[Y] + params.dt * new[VY]
    apply_border(new, params)

    # Fluid quantities of the current configuration, published with the next state (eq. 3.5, 3.11, 3.13).
    rho = float(m * gaussian_kernel(0.0, h, params.kappa) + np.sum(density_terms(np.hypot(dx, dy), m, h, params.kappa)))
    exx, exy, eyy = stress_rate_terms(dWdx, dWdy, -dvx, -dvy, m, nb[:, RHO])
    new[RHO] = rho
    new[P] = tait_pressure(rho, control.beta, params.rho0, params.gamma)
    new[SXX] = control.mu * float(np.sum(exx))
    new[SXY] = control.mu * float(np.sum(exy))
    new[SYY] = control.mu * float(np.sum(eyy))
    if new[FROZEN] != 0.0:  # thesis: a particle leaving the domain loses its fluid parameters
        new[[VX, VY, P, SXX, SXY, SYY, SPEED]] = 0.0
    return new


def obstacle_push(own: np.ndarray, obstacles: Sequence[Obstacle], params: SPHParams, robot: RobotModel):
    """The obstacles' boundary force on the body of `own` (agent/sph/obstacles.py): from its body centre (a
    unicycle's axle centre), beginning OBSTACLE_MARGIN h plus a robot's braking distance beyond its radius, of
    strength v_max^2 (the robot's; the fluid's for a point), from the edges within the kernel support."""
    cx, cy = float(own[X]), float(own[Y])
    if robot.kind == RobotKind.UNICYCLE:
        heading = float(own[HEADING])
        cx, cy = cx - robot.offset * math.cos(heading), cy - robot.offset * math.sin(heading)
    top = params.v_max if robot.kind == RobotKind.POINT else robot.v_max
    # a robot's drive brakes at a_max: the force begins its braking distance earlier (a point stops at once)
    r0 = robot.radius + OBSTACLE_MARGIN * params.h + braking_distance(robot)
    return obstacle_acceleration(cx, cy, obstacles, r0, top * top, params.support)


def cap_speed(states: np.ndarray, params: SPHParams) -> None:
    """Scale velocities (rows or one row, in place) down to at most v_max."""
    speed = np.hypot(states[..., VX], states[..., VY])
    scale = np.where(speed > params.v_max, params.v_max / np.where(speed > 0, speed, 1.0), 1.0)
    states[..., VX] *= scale
    states[..., VY] *= scale


def apply_border(states: np.ndarray, params: SPHParams) -> None:
    """Domain border policy, in place, on one row or many.

    'freeze' (thesis §4.7): a particle whose new position leaves the domain is flagged frozen and
    stops there; 'reflect': the position is mirrored back inside and the normal velocity reversed.
    """
    xmin, xmax, ymin, ymax = params.domain
    x, y = states[..., X], states[..., Y]
    if params.border is Border.FREEZE:
        outside = (x < xmin) | (x > xmax) | (y < ymin) | (y > ymax)
        states[..., FROZEN] = np.where(outside, 1.0, states[..., FROZEN])
        return
    for pos, vel, lo, hi in ((X, VX, xmin, xmax), (Y, VY, ymin, ymax)):
        p = states[..., pos]
        below, above = p < lo, p > hi
        states[..., pos] = np.where(below, 2 * lo - p, np.where(above, 2 * hi - p, p))
        states[..., vel] = np.where(below | above, -states[..., vel], states[..., vel])
