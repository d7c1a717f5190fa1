"""`fluidswarm simulate`: the centralised reference solver on the thesis' branching experiment."""

from __future__ import annotations

import time

from agent.protocol.errors import UserError
from agent.sph.params import SPHParams
from agent.sph.reference import VectorisedDriver
from agent.sph.setups import BRANCHING_BETA_MIDDLE, branching
from fluidswarm.recording.render import plot_formation


def register(sub) -> None:
    p = sub.add_parser("simulate", help="reference simulation of the stiffness-only branching experiment (thesis §4.6)")
    p.add_argument("--out", default="out/simulate.png", help="PNG of the final state (default: %(default)s)")
    p.add_argument("-n", "--particles", type=int, default=200, help="number of particles (default: %(default)s)")
    p.add_argument("--steps", type=int, default=800, help="time steps (default: %(default)s)")
    p.add_argument("--beta-middle", type=float, default=BRANCHING_BETA_MIDDLE)
    p.add_argument("--beta-edge", type=float, default=SPHParams.beta)  # the edges are the fluid itself
    p.set_defaults(func=run)


def run(args) -> int:
    if args.particles < 1:
        raise UserError(f"--particles: must be >= 1, got {args.particles}")
    if args.steps < 0:
        raise UserError(f"--steps: must be >= 0, got {args.steps}")
    if not str(args.out).lower().endswith(".png"):
        raise UserError(f"--out {args.out}: must be a .png file")
    try:
        setup = branching(args.particles, beta_middle=args.beta_middle, beta_edge=args.beta_edge)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    t0 = time.perf_counter()
    driver = VectorisedDriver(setup.ids, setup.states, setup.controls, setup.params)
    final = driver.run(args.steps)
    elapsed = time.perf_counter() - t0
    title = f"branching: beta middle {args.beta_middle:g}, edges {args.beta_edge:g}, {args.steps} steps"
    try:
        path = plot_formation(args.out, final[:, :2], setup.classes, setup.class_names, title)
    except OSError as exc:
        raise UserError(f"--out {args.out}: cannot write ({exc.strerror})") from None
    print(f"particles={args.particles}")
    print(f"steps={args.steps}")
    print(f"steps_per_second={args.steps / max(elapsed, 1e-9):.1f}")
    print(f"png={path}")
    return 0
