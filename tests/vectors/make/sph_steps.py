"""sph_steps.json: agent.sph.particle.step_particle (numpy, the independent oracle of `fluidswarm verify`) on
one particle and its neighbour rows: the parameters, the robot, the control, the own state and the
neighbours in, the next state out. agent/native/tests/all/sph_vectors.rs checks the Rust step (sph.rs) against it.

Seeded: jittered lattices around the particle (some neighbours beyond the support, some frozen), every
border mode, drag, push, viscosity, a frozen particle, one leaving the domain, and the three robot kinds
(bodies close enough to touch), each also beside obstacles (a disc and a concave polygon, edges within and beyond
the sensing range and the boundary force's reach)."""

from __future__ import annotations

from dataclasses import asdict

import numpy as np

from agent.sph.obstacles import Circle, Obstacle, Polygon
from agent.sph.params import SPHParams
from agent.sph.particle import FROZEN, HEADING, NFIELDS, RHO, SPEED, VX, VY, Control, step_particle
from agent.sph.robot import RobotModel


def _neighbourhood(rng: np.random.Generator, own_xy, n: int, spread: float, rho0: float) -> np.ndarray:
    rows = np.zeros((n, NFIELDS))
    rows[:, :2] = own_xy + rng.uniform(-spread, spread, size=(n, 2))
    rows[:, VX : VY + 1] = rng.normal(scale=0.5, size=(n, 2))
    rows[:, RHO] = rho0 * rng.uniform(0.8, 1.3, size=n)
    rows[:, RHO + 1] = rng.normal(scale=0.3, size=n)  # p
    rows[:, RHO + 2 : RHO + 5] = rng.normal(scale=0.1, size=(n, 3))  # sxx, sxy, syy
    rows[:, HEADING] = rng.uniform(-np.pi, np.pi, size=n)
    rows[:, SPEED] = rng.uniform(0.0, 0.5, size=n)
    return rows


def _case(
    name: str,
    rng,
    params: SPHParams,
    control: Control,
    robot: RobotModel,
    own_xy,
    n=14,
    spread=2.5,
    shift=0.0,
    own_set: dict[int, float] | None = None,
    obstacles: tuple[Obstacle, ...] = (),
):
    own = _neighbourhood(rng, np.asarray(own_xy, float), 1, 0.0, params.rho0)[0]
    for field, value in (own_set or {}).items():
        own[field] = value
    nb = _neighbourhood(rng, own[:2] + (shift, 0.0), n, spread, params.rho0)
    nb[rng.uniform(size=n) < 0.15, FROZEN] = 1.0  # some frozen rows: the step skips them
    if robot.kind == "point":
        own[HEADING] = own[SPEED] = 0.0
        nb[:, HEADING] = nb[:, SPEED] = 0.0
    new = step_particle(own, nb, control, params, robot, obstacles)
    p = asdict(params)
    p["domain"] = list(p["domain"])
    return {
        "name": name,
        "params": p,
        "robot": asdict(robot),
        "control": asdict(control),
        "own": own.tolist(),
        "neighbours": nb.tolist(),
        "next": new.tolist(),
        "obstacles": [o.as_dict() for o in obstacles],
    }


def sph_step_vectors() -> list[dict]:
    rng = np.random.default_rng(34)
    out = []
    mid = (30.0, 15.0)
    for k in range(6):
        out.append(_case(f"fluid_{k}", rng, SPHParams(), Control(), RobotModel(), mid))
    for k in range(4):
        params = SPHParams(mu=0.5, drag=0.3, beta=20.0, beta_pi=2.0, h=0.8, dt=0.02)
        control = Control(wx=35.0, wy=12.0, r=0.5, s=2.0, alpha=40.0, beta=50.0, mu=1.5, push_x=0.3, push_y=-0.2)
        out.append(_case(f"viscous_controlled_{k}", rng, params, control, RobotModel(), mid))
    out.append(_case("alone", rng, SPHParams(), Control(wx=0.0, wy=0.0, alpha=5.0, s=1.0), RobotModel(), mid, n=0))
    out.append(_case("all_beyond_support", rng, SPHParams(), Control(), RobotModel(), mid, n=5, spread=0.1, shift=5.0))
    out.append(_case("frozen_self", rng, SPHParams(), Control(), RobotModel(), mid, own_set={FROZEN: 1.0}))
    fast = {VX: -4.0, VY: 3.0}
    for border in ("freeze", "reflect"):
        out.append(
            _case(
                f"leaves_{border}", rng, SPHParams(border=border), Control(), RobotModel(), (0.02, 29.99), own_set=fast
            )
        )
    out.append(
        _case(
            "speed_capped", rng, SPHParams(v_max=1.0), Control(alpha=500.0, wx=40.0, wy=15.0, s=1.0), RobotModel(), mid
        )
    )
    for kind in ("holonomic", "unicycle"):
        robot = RobotModel(kind=kind)
        params = SPHParams(drag=0.2)
        for k in range(4):
            control = Control(wx=31.0 + k, wy=14.0, s=1.0, alpha=20.0)
            out.append(_case(f"{kind}_{k}", rng, params, control, robot, mid, spread=0.9 if k % 2 else 2.5))
    # Beside obstacles: the particle 0.27-0.4 m from a disc's edge, from an L-shaped polygon's sides and its
    # concave corner (two sides push), from a convex vertex; a far wall (beyond r0 and the sensing range).
    ell = Polygon(((30.3, 14.0), (32.0, 14.0), (32.0, 14.7), (30.6, 14.7), (30.6, 16.5), (30.3, 16.5)))
    far = Polygon(((40.0, 10.0), (41.0, 10.0), (41.0, 20.0)))
    disc = Circle(29.0, 15.0, 0.7)
    spots = ((30.0, 15.0), (30.95, 15.05), (31.0, 14.4 - 0.75), (29.95, 13.8), (30.0, 16.0), (29.6, 15.5))
    for kind in ("point", "holonomic", "unicycle"):
        robot = RobotModel(kind=kind)
        params = SPHParams(drag=0.2)
        for k, spot in enumerate(spots):
            control = Control(wx=31.0, wy=15.0, s=1.0, alpha=20.0 * (k % 2))
            out.append(
                _case(f"{kind}_obstacles_{k}", rng, params, control, robot, spot, n=8, obstacles=(disc, ell, far))
            )
    return out
