"""Centralised reference solvers: the yardsticks the decentralised swarm is checked against.

`PerParticleDriver` calls `step_particle` for every particle with its neighbours sorted by id: the
bit-for-bit reference of a swarm of agents. `VectorisedDriver` evaluates the same pair equations for
all pairs at once with a cell-list neighbour search: fast, and equal to the reference up to rounding
(summation order differs).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

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
from agent.sph.obstacles import Obstacle
from agent.sph.params import SPHParams
from agent.sph.particle import (
    FROZEN,
    HEADING,
    RHO,
    SPEED,
    SXX,
    SXY,
    SYY,
    VX,
    VY,
    Control,
    P,
    X,
    Y,
    apply_border,
    cap_speed,
    step_particle,
)
from agent.sph.radio import PERFECT, RadioModel
from agent.sph.robot import (
    POINT,
    RobotKind,
    RobotModel,
    body_centres,
    contact_onset,
    contact_terms,
    holonomic_velocity,
    unicycle_step,
)


class ControlSource(Protocol):
    """Anything that gives a particle its Control for a step (a static Control, or a route follower)."""

    def control(self, state: np.ndarray, step: int) -> Control: ...


class StaticControl:
    """The same Control at every step."""

    def __init__(self, control: Control):
        self._control = control

    def control(self, state: np.ndarray, step: int) -> Control:
        return self._control


def cell_pairs(positions: np.ndarray, active: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """All ordered pairs (i, j), i != j, of active particles closer than `cell`, by a cell list.

    Particles are binned into square cells of side `cell`; each particle is compared only with the
    particles of its own and the 8 surrounding cells, so the work is O(N * neighbours), not O(N^2).
    """
    idx = np.flatnonzero(active)
    if idx.size == 0:
        return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
    pos = positions[idx]
    c = np.floor(pos / cell).astype(np.int64)
    c -= c.min(axis=0) - 1
    stride = int(c[:, 1].max()) + 2
    key = c[:, 0] * stride + c[:, 1]
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    firsts, seconds = [], []
    for ox in (-1, 0, 1):
        for oy in (-1, 0, 1):
            target = key + ox * stride + oy
            lo = np.searchsorted(sorted_key, target, "left")
            hi = np.searchsorted(sorted_key, target, "right")
            counts = hi - lo
            a = np.repeat(np.arange(idx.size), counts)
            starts = np.repeat(lo - np.cumsum(counts) + counts, counts)
            b = order[np.arange(a.size) + starts]
            firsts.append(a)
            seconds.append(b)
    a = np.concatenate(firsts)
    b = np.concatenate(seconds)
    d = pos[a] - pos[b]
    keep = (a != b) & (np.einsum("ij,ij->i", d, d) <= cell * cell)
    return idx[a[keep]], idx[b[keep]]


class Driver:
    """A centralised solver of the swarm: particles sorted by id (an agent's neighbour order), one
    `step()` a time step of all of them; `run(steps)` returns the states after the last. `robot`: every
    particle's body and drive (agent/sph/robot.py); `radio`: what their radios make of their neighbours'
    states (agent/sph/radio.py; the per-particle driver only); `obstacles`: the domain's static obstacles
    (agent/sph/obstacles.py; the per-particle driver only)."""

    def __init__(
        self,
        ids: Sequence[int] | np.ndarray,
        states: np.ndarray,
        controls: Sequence[ControlSource],
        params: SPHParams,
        robot: RobotModel = POINT,
        radio: RadioModel = PERFECT,
        obstacles: Sequence[Obstacle] = (),
    ):
        order = np.argsort(np.asarray(ids), kind="stable")
        self.ids = np.asarray(ids)[order]
        self.states = np.array(states, dtype=float)[order]
        self.controls = [controls[k] for k in order]
        self.params = params
        self.robot = robot
        self.radio = radio
        self.obstacles = tuple(obstacles)
        self.step_index = 0
        # the states of the last radio.latency + 1 steps, oldest first (the radio's latency)
        self.history: list[np.ndarray] = []

    def step(self) -> None:
        raise NotImplementedError

    def run(self, steps: int) -> np.ndarray:
        for _ in range(steps):
            self.step()
        return self.states


class PerParticleDriver(Driver):
    """Steps every particle with `step_particle`, neighbours sorted by id, exactly as an agent would."""

    def step(self) -> None:
        params = self.params
        current = self.states
        new = np.empty_like(current)
        i_idx, j_idx = cell_pairs(current[:, [X, Y]], current[:, FROZEN] == 0.0, params.support)
        by_particle = np.split(
            j_idx[np.lexsort((j_idx, i_idx))], np.cumsum(np.bincount(i_idx, minlength=len(current)))[:-1]
        )
        if not self.radio.is_perfect:
            self._radio_step(current, by_particle)
            return
        for k in range(len(current)):
            neighbours = current[np.sort(by_particle[k])]  # ids are sorted, so index order is id order
            control = self.controls[k].control(current[k], self.step_index)
            new[k] = step_particle(current[k], neighbours, control, params, self.robot, self.obstacles)
        self.states = new
        self.step_index += 1

    def _radio_step(self, current: np.ndarray, by_particle: list[np.ndarray]) -> None:
        """The step as agents with an imperfect radio take it (agent/sph/radio.py, agent/native/src/agent/step.rs
        `radio_rows`): the neighbours the step's states put within the support, each as its state of
        latency steps back (step 0 at the start), unless that state is lost to the receiver, with its
        localisation's error on the position."""
        radio, params, t = self.radio, self.params, self.step_index
        self.history = [*self.history, current][-(radio.latency + 1) :]
        old = self.history[0]
        s = max(t - radio.latency, 0)
        ids = [int(i) for i in self.ids]
        error = np.array([radio.position_error(j, s) for j in ids]).reshape(-1, 2)
        new = np.empty_like(current)
        for k in range(len(current)):
            near = np.sort(by_particle[k])
            own = current[k]
            dx, dy = own[X] - current[near, X], own[Y] - current[near, Y]
            support = params.support
            near = near[(dx * dx + dy * dy <= support * support) & (current[near, FROZEN] == 0.0)]
            near = near[[not radio.lost(ids[k], ids[j], s) for j in near]].astype(np.int64)
            rows = old[near].copy()
            rows[:, X] += error[near, 0]
            rows[:, Y] += error[near, 1]
            control = self.controls[k].control(own, t)
            new[k] = step_particle(own, rows, control, params, self.robot, self.obstacles)
        self.states = new
        self.step_index += 1


class VectorisedDriver(Driver):
    """All particles at once: pair arrays from a cell list, sums by `np.bincount`."""

    def _control_arrays(self) -> dict[str, np.ndarray]:
        cs = [c.control(self.states[k], self.step_index) for k, c in enumerate(self.controls)]
        names = ("wx", "wy", "r", "s", "alpha", "beta", "mu", "push_x", "push_y")
        return {n: np.array([getattr(c, n) for c in cs], dtype=float) for n in names}

    def step(self) -> None:
        if not self.radio.is_perfect:
            raise NotImplementedError("the vectorised driver has a perfect radio: use PerParticleDriver")
        if self.obstacles:
            raise NotImplementedError("the vectorised driver has no obstacles: use PerParticleDriver")
        params, s = self.params, self.states
        n = len(s)
        h, m = params.h, params.mass
        ctl = self._control_arrays()
        active = s[:, FROZEN] == 0.0
        i, j = cell_pairs(s[:, [X, Y]], active, params.support)
        dx, dy = s[i, X] - s[j, X], s[i, Y] - s[j, Y]
        dvx, dvy = s[i, VX] - s[j, VX], s[i, VY] - s[j, VY]
        dWdx, dWdy = kernel_gradient(dx, dy, h, params.kappa)
        pi_ij = artificial_viscosity(dx, dy, dvx, dvy, s[i, RHO], s[j, RHO], h, params.beta_pi)
        ax, ay = momentum_terms(
            dWdx,
            dWdy,
            m,
            s[i, RHO],
            s[j, RHO],
            s[i, P],
            s[j, P],
            pi_ij,
            s[i, SXX],
            s[i, SXY],
            s[i, SYY],
            s[j, SXX],
            s[j, SXY],
            s[j, SYY],
        )
        fx, fy = body_force(s[:, X], s[:, Y], ctl["wx"], ctl["wy"], ctl["r"], ctl["s"], ctl["alpha"])
        acc_x = np.bincount(i, ax, n) + fx + ctl["push_x"] - params.drag * s[:, VX]
        acc_y = np.bincount(i, ay, n) + fy + ctl["push_y"] - params.drag * s[:, VY]
        robot = self.robot
        if robot.kind != RobotKind.POINT:
            c = body_centres(s, robot)
            tx, ty = contact_terms(c[i, 0] - c[j, 0], c[i, 1] - c[j, 1], contact_onset(robot, params.h), robot.v_max**2)
            acc_x, acc_y = acc_x + np.bincount(i, tx, n), acc_y + np.bincount(i, ty, n)

        new = s.copy()
        new[:, VX] = s[:, VX] + params.dt * acc_x
        new[:, VY] = s[:, VY] + params.dt * acc_y
        if robot.kind == RobotKind.UNICYCLE:  # the drive is per robot: a loop, as the agents do it
            for k in range(n):
                new[k, [X, Y, VX, VY, HEADING, SPEED]] = unicycle_step(
                    s[k, X], s[k, Y], s[k, HEADING], s[k, SPEED], new[k, VX], new[k, VY], robot, params.dt
                )
        else:
            if robot.kind == RobotKind.HOLONOMIC:
                for k in range(n):
                    new[k, [VX, VY]] = holonomic_velocity(s[k, VX], s[k, VY], new[k, VX], new[k, VY], robot, params.dt)
            cap_speed(new, params)
            new[:, X] = s[:, X] + params.dt * new[:, VX]
            new[:, Y] = s[:, Y] + params.dt * new[:, VY]
        apply_border(new, params)

        rho = m * gaussian_kernel(0.0, h, params.kappa) + np.bincount(
            i, density_terms(np.hypot(dx, dy), m, h, params.kappa), n
        )
        exx, exy, eyy = stress_rate_terms(dWdx, dWdy, -dvx, -dvy, m, s[j, RHO])
        new[:, RHO] = rho
        new[:, P] = tait_pressure(rho, ctl["beta"], params.rho0, params.gamma)
        new[:, SXX] = ctl["mu"] * np.bincount(i, exx, n)
        new[:, SXY] = ctl["mu"] * np.bincount(i, exy, n)
        new[:, SYY] = ctl["mu"] * np.bincount(i, eyy, n)
        frozen_now = new[:, FROZEN] != 0.0
        new[np.ix_(frozen_now, [VX, VY, P, SXX, SXY, SYY, SPEED])] = 0.0
        new[~active] = s[~active]  # frozen particles stay as they were
        self.states = new
        self.step_index += 1
