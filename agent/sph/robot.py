"""Robots as fluid particles (thesis §7.2): what a real robot's body and drive make of the SPH step.

The SPH step of a particle (agent/sph/particle.py) yields an acceleration a_i; its velocity update
u_i = v_i + dt a_i is the velocity the fluid *wants* the particle to have. A `point` (the thesis' ideal
particle, the default) takes it as it is. A robot cannot:

holonomic   (omnidirectional wheels) takes u_i with its acceleration and speed limited:
            v' = v + clip(u - v, a_max dt),  |v'| <= v_max,  x' = x + dt v'.
unicycle    (differential drive: e-puck, Kilobot, TurtleBot) has a heading theta and drives forward at a
            speed s with a turn rate w. The SPH particle is the point P = C + l (cos theta, sin theta) a
            distance l (`offset`) ahead of the wheel axle's centre C; P's velocity is
                P' = R(theta) [s, l w]^T,
            which is invertible for l > 0, so the desired velocity u is tracked exactly by
                s = u_x cos theta + u_y sin theta,   w = (-u_x sin theta + u_y cos theta) / l
            (feedback linearisation of the point-offset, "hand position" kinematics: Lawton, Beard &
            Young, IEEE T-RA 19(6) 2003, eq. 2-4; the same near-identity transformation as Olfati-Saber,
            ACC 2002). Then the drive's limits: |s' - s| <= a_max dt, |s'| <= v_max, |w| <= w_max, and
            the wheels move the body: theta' = theta + dt w, C' = C + dt s' (cos theta', sin theta'),
            P' = C' + l (cos theta', sin theta'); the state's velocity is P's, (P' - P) / dt.

The body is a disc of `radius` around C (the centre of a holonomic robot is its particle). A point
has a radius too, for what a robot user measures (collisions), and no limits.

Bodies keep apart: the SPH pressure spaces a settled fluid at about h, but a fluid pulled into a shape
is compressed where it meets the boundary, and two robots of the swarm came within 0.44 m (bodies of
0.25 m radius touch at 0.5 m). Robots therefore repel each other's bodies at close range with the
repulsive boundary force of Monaghan (J. Comput. Phys. 110, 1994, eq. 4.4), a Lennard-Jones form:
    f_ij = D ((r0/d)^p1 - (r0/d)^p2) x_ij / d^2  for d < r0, else 0,   p1 = 12, p2 = 4,
between body centres d = |x_ij| apart, with D = v_max^2 (Monaghan takes D of the order of the square of
the largest speed) and the onset (`contact_onset`)
    r0 = 2 radius + CONTACT_MARGIN h + v_max^2 / (2 a_max),
the obstacles' rule (agent/sph/obstacles.py) for two bodies: they touch at d = 2 radius, and a robot's
drive brakes at a_max, so the force has to begin its braking distance (`braking_distance`) before the
margin, or a robot driving at v_max into a crowd cannot stop in time. The e-puck default:
0.5 + 0.125 + 0.86^2 / 3.4 = 0.843 m. Measured: with r0 = 1.25 x 2 radius = 0.625 m (the force beginning
0.125 m before contact, less than the 0.22 m braking distance) 60 unicycles of the obstacle course
(scenarios/obstacle_course.toml) touched 4 times where they crowd at the wall's gaps. A neighbour's body
centre comes from its published pose (wire v2: heading).

Defaults: the e-puck (Mondada et al., "The e-puck, a robot designed for education in engineering",
Proc. 9th Conf. Autonomous Robot Systems and Competitions, 2009): a 75 mm disc, 41 mm wheels 53 mm
apart, stepper motors of 1000 steps/s at 20 steps/mm of wheel travel -> 0.129 m/s top speed and
2 x 0.129 / 0.053 = 4.9 rad/s top turn rate. Scaled to the domain by lengths only (x 6.67, so its radius
0.0375 m becomes 0.25 h with the SPH smoothing length h = 1 m): radius 0.25 m, v_max 0.86 m/s,
w_max 4.9 rad/s (a rate does not scale with length). The datasheet gives no acceleration; a_max =
1.7 m/s^2 (top speed in half a second) is our choice. The offset l = 0.1 m sits inside the body.

All functions are pure: numbers in, numbers out, so the agent process (agent/native/src/robot.rs)
and the reference drivers evaluate the same arithmetic in the same order.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from enum import StrEnum

import numpy as np


class RobotKind(StrEnum):
    """Which body and drive a particle has (RobotModel.kind)."""

    POINT = "point"
    HOLONOMIC = "holonomic"
    UNICYCLE = "unicycle"


ROBOT_KINDS = tuple(k.value for k in RobotKind)


@dataclass(frozen=True)
class RobotModel:
    """kind: point | holonomic | unicycle; radius [m] of the body disc; v_max [m/s] top speed; a_max
    [m/s^2] top acceleration (of the forward speed, for a unicycle); omega_max [rad/s] top turn rate and
    offset [m] the tracked point's distance ahead of the axle (unicycle). Defaults: the e-puck scaled to
    the domain (module docstring)."""

    kind: str = RobotKind.POINT.value
    radius: float = 0.25
    v_max: float = 0.86
    a_max: float = 1.7
    omega_max: float = 4.9
    offset: float = 0.1

    def __post_init__(self) -> None:
        if self.kind not in ROBOT_KINDS:
            raise ValueError(f"robot.kind: must be one of {ROBOT_KINDS}, got {self.kind!r}")
        for f in fields(self):
            if f.name == "kind":
                continue
            v = getattr(self, f.name)
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
                raise ValueError(f"robot.{f.name}: must be a finite number, got {v!r}")
            if f.name == "radius" and v < 0:
                raise ValueError(f"robot.radius: must be >= 0, got {v!r}")
            if f.name != "radius" and v <= 0:
                raise ValueError(f"robot.{f.name}: must be > 0, got {v!r}")
            object.__setattr__(self, f.name, float(v))
        if self.kind != RobotKind.POINT and self.radius <= 0:
            raise ValueError(f"robot.radius: a {self.kind} robot needs a body, must be > 0, got {self.radius!r}")

    @property
    def is_point(self) -> bool:
        return self.kind == RobotKind.POINT

    @property
    def top_particle_speed(self) -> float:
        """Fastest the tracked point can move [m/s]: v_max, plus offset * omega_max for a unicycle."""
        if self.kind == RobotKind.UNICYCLE:
            return self.v_max + self.offset * self.omega_max
        return self.v_max

    def check_fits(self, v_max: float) -> None:
        """The neighbour protocol bounds a particle's step by the fluid's v_max dt (docs/protocol.md): a
        robot must not be faster than that."""
        if not self.is_point and self.top_particle_speed > v_max:
            raise ValueError(
                f"robot.v_max: the robot's point can move {self.top_particle_speed:g} m/s, more than "
                f"the fluid's v_max {v_max:g} m/s"
            )

    def as_dict(self) -> dict:
        return asdict(self)


POINT = RobotModel()
CONTACT_MARGIN = 0.125  # x h: how far beyond contact (plus the braking distance) the bodies' repulsion begins


def braking_distance(robot: RobotModel) -> float:
    """How far a robot driving at v_max rolls while its drive brakes at a_max [m]: v_max^2 / (2 a_max); a point
    particle stops at once (0). Where the boundary forces begin, the bodies' and the obstacles'."""
    return 0.0 if robot.kind == RobotKind.POINT else robot.v_max * robot.v_max / (2.0 * robot.a_max)


def contact_onset(robot: RobotModel, h: float) -> float:
    """r0 of the bodies' repulsion [m]: 2 radius + CONTACT_MARGIN h + braking distance (module docstring)."""
    return 2.0 * robot.radius + CONTACT_MARGIN * h + braking_distance(robot)


def robot_from(kind: str | None = None, table: dict | None = None) -> RobotModel:
    """A RobotModel from a kind name and/or a table of its fields (a scenario's [robot]), validated."""
    values = dict(table or {})
    unknown = sorted(set(values) - {f.name for f in fields(RobotModel)})
    if unknown:
        raise ValueError(f"robot.{unknown[0]}: unknown key (known: {', '.join(f.name for f in fields(RobotModel))})")
    if kind is not None:
        values["kind"] = kind
    return RobotModel(**values)


def wrap_angle(theta: float) -> float:
    """theta in (-pi, pi], for |theta| < 3 pi (one step's turn never exceeds that)."""
    if theta > math.pi:
        return theta - 2.0 * math.pi
    if theta <= -math.pi:
        return theta + 2.0 * math.pi
    return theta


def clip(value: float, lo: float, hi: float) -> float:
    return lo if value < lo else min(value, hi)


def initial_pose(vx: float, vy: float, robot: RobotModel) -> tuple[float, float]:
    """(heading [rad], forward speed [m/s]) at step 0: a unicycle faces the way it moves (at rest: +x);
    the others keep heading 0 and speed 0 (nothing of the point model changes)."""
    if robot.kind != RobotKind.UNICYCLE:
        return 0.0, 0.0
    speed = math.hypot(vx, vy)
    return (math.atan2(vy, vx) if speed > 0.0 else 0.0), speed


def holonomic_velocity(vx: float, vy: float, ux: float, uy: float, robot: RobotModel, dt: float) -> tuple[float, float]:
    """v' = v + clip(u - v, a_max dt), then |v'| <= v_max (module docstring)."""
    dvx, dvy = ux - vx, uy - vy
    dv = math.hypot(dvx, dvy)
    most = robot.a_max * dt
    if dv > most:
        dvx, dvy = dvx * (most / dv), dvy * (most / dv)
    nvx, nvy = vx + dvx, vy + dvy
    speed = math.hypot(nvx, nvy)
    if speed > robot.v_max:
        nvx, nvy = nvx * (robot.v_max / speed), nvy * (robot.v_max / speed)
    return nvx, nvy


def offset_tracking(ux: float, uy: float, heading: float, offset: float) -> tuple[float, float]:
    """(s, w): the forward speed and turn rate that give the point `offset` ahead of the axle the
    velocity (ux, uy) (Lawton, Beard & Young 2003, eq. 4): s = u . e, w = u . n / l with e = (cos, sin)
    the heading and n = (-sin, cos) its normal."""
    c, s = math.cos(heading), math.sin(heading)
    return ux * c + uy * s, (-ux * s + uy * c) / offset


def unicycle_step(
    x: float, y: float, heading: float, speed: float, ux: float, uy: float, robot: RobotModel, dt: float
) -> tuple[float, float, float, float, float, float]:
    """(x', y', vx', vy', heading', speed') of a unicycle whose tracked point is at (x, y) and should move at
    (ux, uy): the tracking law, the drive's limits, the wheels' motion (module docstring)."""
    s_cmd, w_cmd = offset_tracking(ux, uy, heading, robot.offset)
    most = robot.a_max * dt
    s_new = clip(clip(s_cmd, speed - most, speed + most), -robot.v_max, robot.v_max)
    w = clip(w_cmd, -robot.omega_max, robot.omega_max)
    h_new = wrap_angle(heading + dt * w)
    l = robot.offset
    # C = P - l e(theta); C' = C + dt s' e(theta'); P' = C' + l e(theta')
    reach = dt * s_new + l
    nx = x - l * math.cos(heading) + reach * math.cos(h_new)
    ny = y - l * math.sin(heading) + reach * math.sin(h_new)
    return nx, ny, (nx - x) / dt, (ny - y) / dt, h_new, s_new


def contact_terms(dx, dy, r0: float, strength: float):
    """Per-pair accelerations of Monaghan's (1994) repulsive Lennard-Jones force between bodies whose
    centres are (dx, dy) = x_i - x_j apart: D ((r0/d)^12 - (r0/d)^4) x_ij / d^2 for d < r0, else 0
    (module docstring). Arrays in, arrays out."""
    d2 = dx * dx + dy * dy
    close = (d2 < r0 * r0) & (d2 > 0.0)
    safe = np.where(close, d2, 1.0)
    q = r0 / np.sqrt(safe)
    mag = np.where(close, strength * (q**12 - q**4) / safe, 0.0)
    return mag * dx, mag * dy


def contact_acceleration(own, neighbours, robot: RobotModel, h: float) -> tuple[float, float]:
    """The sum of `contact_terms` on the body of `own` from the bodies of `neighbours` (state rows), h the
    smoothing length."""
    c = body_centres(np.asarray(own, dtype=float)[None, :], robot)[0]
    cn = body_centres(neighbours, robot) if len(neighbours) else np.empty((0, 2))
    tx, ty = contact_terms(c[0] - cn[:, 0], c[1] - cn[:, 1], contact_onset(robot, h), robot.v_max**2)
    return float(np.sum(tx)), float(np.sum(ty))


def body_centres(states: np.ndarray, robot: RobotModel, x: int = 0, y: int = 1, heading: int = 10) -> np.ndarray:
    """(N, 2) centres of the bodies of state rows: a unicycle's axle centre C = P - l e(theta); the others'
    particle."""
    pos = np.asarray(states, dtype=float)[:, [x, y]]
    if robot.kind != RobotKind.UNICYCLE:
        return pos
    th = np.asarray(states, dtype=float)[:, heading]
    return pos - robot.offset * np.stack([np.cos(th), np.sin(th)], axis=1)


def closest_pair(centres: np.ndarray) -> float:
    """The smallest distance between two of `centres` [m] (inf for fewer than two)."""
    c = np.asarray(centres, dtype=float).reshape(-1, 2)
    if len(c) < 2:
        return math.inf
    best = math.inf
    for k in range(0, len(c), 256):  # blocks of rows: O(N^2) work in O(256 N) memory
        d2 = ((c[k : k + 256, None, :] - c[None, :, :]) ** 2).sum(axis=2)
        d2[np.arange(len(d2)), np.arange(k, k + len(d2))] = math.inf
        best = min(best, float(d2.min()))
    return math.sqrt(best)


def check_layout(centres: np.ndarray, robot: RobotModel) -> None:
    """A robot's body must fit the start layout: no two bodies overlap at step 0."""
    if robot.radius <= 0:
        return
    closest = closest_pair(centres)
    if closest < 2.0 * robot.radius:
        raise ValueError(
            f"robot.radius: {robot.radius:g} m does not fit the start layout (two start positions are "
            f"{closest:.3g} m apart, bodies need {2 * robot.radius:g} m)"
        )
