"""`fluidswarm agent`, `fluidswarm launch` and `fluidswarm verify`."""

from __future__ import annotations

import sys

import numpy as np

from agent.protocol.errors import UserError
from fluidswarm.recording.live import add_live_argument, live_from_args


def register(sub) -> None:
    p = sub.add_parser("agent", help="run one particle agent process (normally started by the launcher)")
    p.add_argument("--spec", required=True, help="start-up parameters as JSON (agent/protocol/spec.py)")
    p.set_defaults(func=_agent)

    p = sub.add_parser("launch", help="start N agent processes on this host and run them in lockstep")
    p.add_argument("-n", "--agents", type=int, default=16)
    p.add_argument("--steps", type=int, default=100)
    p.add_argument("--connect", help="use the Zenoh router at tcp/HOST:PORT instead of an embedded one")
    p.add_argument("--ids", help="start only this slice of the swarm on this host, e.g. 0-19 (multi-host)")
    p.add_argument("--run", help="run name (must match on every host of a split run)")
    p.add_argument("--timeout", type=float, default=2.0, help="s before a silent neighbour is dropped")
    p.add_argument("--record", help="write the run to this MCAP file (passive recorder process)")
    p.add_argument("--user", default="", help="Zenoh user name (router with --auth-file)")
    p.add_argument("--password", default="")
    p.add_argument("--mode", choices=("lockstep", "async"), default="lockstep",
                   help="lockstep (reproducible) or async (each agent on its own clock, docs/protocol.md)")
    p.add_argument("--rate", type=float, default=12.0, help="async: steps/s each agent aims for")
    p.add_argument("--max-age", type=float, default=1.0, help="async: s after which a neighbour state is not used")
    add_live_argument(p)
    p.set_defaults(func=_launch)

    p = sub.add_parser("verify", help="N agent processes against the per-particle reference driver")
    p.add_argument("--agents", type=int, default=64)
    p.add_argument("--steps", type=int, default=300)
    p.add_argument("--connect", help="use the Zenoh router at tcp/HOST:PORT instead of an embedded one")
    p.add_argument("--timeout", type=float, default=15.0, help="s before a silent neighbour is dropped")
    p.add_argument("--ids", help="run only this slice of the swarm here (the other hosts run the rest), e.g. 0-19")
    p.add_argument("--run", help="run name shared by every host of a split run")
    p.add_argument("--user", default="", help="Zenoh user name (router with --auth-file)")
    p.add_argument("--password", default="")
    p.set_defaults(func=_verify)


def _agent(args) -> int:
    import os

    from agent.executable import agent_executable

    program = agent_executable()
    os.execv(program, [program, "--spec", args.spec])  # the compiled agent replaces this process


def parse_ids(text: str, n: int) -> list[int]:
    """'0-19,40,42-45' -> ids, each in [0, n)."""
    out: list[int] = []
    for part in text.split(","):
        part = part.strip()
        try:
            if "-" in part:
                a, b = (int(v) for v in part.split("-", 1))
                out.extend(range(a, b + 1))
            else:
                out.append(int(part))
        except ValueError:
            raise UserError(f"--ids {text!r}: expected ranges like 0-19,40") from None
    bad = [i for i in out if not 0 <= i < n]
    if bad:
        raise UserError(f"--ids {text!r}: id {bad[0]} is outside 0..{n - 1}")
    return sorted(set(out))


def _check_counts(agents: int, steps: int) -> None:
    if agents < 1:
        raise UserError(f"--agents: must be >= 1, got {agents}")
    if steps < 0:
        raise UserError(f"--steps: must be >= 0, got {steps}")


def _launch(args) -> int:
    from agent.launcher import Launcher, run_swarm
    from agent.sph.setups import spread_block

    _check_counts(args.agents, args.steps)
    for name in ("rate", "max_age"):
        v = getattr(args, name)
        if not (v > 0 and v < float("inf")):
            raise UserError(f"--{name.replace('_', '-')}: must be a positive number, got {v}")
    if args.live is not None and not args.record:
        raise UserError("--live needs --record FILE.mcap (the recorder process serves the live view)")
    live = live_from_args(args)
    setup = spread_block(args.agents)
    ids = parse_ids(args.ids, args.agents) if args.ids else None
    try:
        launcher = Launcher(run=args.run, connect=args.connect, agent_timeout=args.timeout,
                            user=args.user, password=args.password)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    with launcher:
        print(f"run={launcher.run} router={launcher.endpoint}", flush=True)
        if args.record:
            launcher.start_recorder(args.record, {"scenario": "launch", "agents": args.agents, "steps": args.steps,
                                                  "params": setup.params.as_dict()}, setup.params.dt, live=live)
        res = run_swarm(setup, args.steps, launcher=launcher, ids=ids, swarm_ids=list(setup.ids),
                        mode=args.mode, rate=args.rate, max_age=args.max_age)
    print(f"mode={args.mode}")
    print(f"agents={len(res.ids)}")
    print(f"finished={sum(1 for r in res.finals.values() if r['status'] == 'done')}")
    print(f"steps_per_second={res.steps_per_second():.2f}")
    print(f"msgs_per_agent_step={res.msgs_per_agent_step():.2f}")
    print(f"neighbours_per_agent={res.neighbours_per_agent():.2f}")
    print(f"startup_seconds={res.startup_seconds:.2f}")
    return 0


def _verify(args) -> int:
    from agent.launcher import Launcher, run_swarm
    from agent.sph.particle import X, Y
    from agent.sph.reference import PerParticleDriver
    from agent.sph.setups import spread_block

    _check_counts(args.agents, args.steps)
    setup = spread_block(args.agents)
    ids = parse_ids(args.ids, args.agents) if args.ids else list(setup.ids)
    if args.ids and not args.run:
        raise UserError("--ids needs --run: every host of a split run must use the same run name")
    try:
        launcher = Launcher(run=args.run, connect=args.connect, agent_timeout=args.timeout,
                            user=args.user, password=args.password)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    with launcher:
        res = run_swarm(setup, args.steps, launcher=launcher, ids=ids, swarm_ids=list(setup.ids))
    reference = PerParticleDriver(setup.ids, setup.states, setup.controls, setup.params).run(args.steps)
    missing = [i for i in ids if i not in res.finals or res.finals[i]["status"] != "done"]
    if missing:
        print(f"fluidswarm verify: {len(missing)} agents did not finish (first: {missing[:5]})", file=sys.stderr)
        error = float("inf")
    else:
        got = np.array([res.finals[i]["state"] for i in ids])
        error = float(np.abs(got[:, [X, Y]] - reference[ids][:, [X, Y]]).max())
    print(f"max_position_error={error:.3e}")
    print(f"msgs_per_agent_step={res.msgs_per_agent_step():.3f}")
    print(f"neighbours_per_agent={res.neighbours_per_agent():.3f}")
    print(f"steps_per_second={res.steps_per_second():.2f}")
    return 0 if error <= 1e-9 else 1
