"""`fluidswarm agent`, `fluidswarm launch` and `fluidswarm verify`."""

from __future__ import annotations

import sys
from pathlib import Path

from agent.protocol.errors import UserError
from agent.protocol.spec import MODES, NEIGHBOUR_TIMEOUT
from fluidswarm.options import (
    add_json_argument,
    add_obstacles_argument,
    add_radio_arguments,
    add_robot_argument,
    add_swarm_arguments,
    check_lockstep,
    print_json,
    radio_model,
    radio_options,
    robot_model,
)
from fluidswarm.orchestration.run_config import (
    LAUNCH_AGENTS,
    SYNC_OPTION,
    VERIFY_AGENTS,
    Access,
    Recording,
    Sync,
    check,
    check_agents,
    positive_problem,
)
from fluidswarm.recording.live import live_from_args
from fluidswarm.ros2_options import ros2_bag_from_args, ros2_from_args, write_run_bag
from fluidswarm.scenario import obstacles_file


def register(sub) -> None:
    p = sub.add_parser("agent", help="run one particle agent process (normally started by the launcher)")
    p.add_argument("--spec", required=True, help="start-up parameters as JSON (agent/protocol/spec.py)")
    p.set_defaults(func=_agent)

    p = sub.add_parser("launch", help="start N agent processes on this host and run them in lockstep")
    p.add_argument("-n", "--agents", type=int, default=LAUNCH_AGENTS)
    p.add_argument("--steps", type=int, default=100)
    p.add_argument("--connect", help="use the Zenoh router at tcp/HOST:PORT instead of an embedded one")
    _add_slice_arguments(p, "start only this slice of the swarm on this host, e.g. 0-19 (multi-host)")
    p.add_argument("--run", help="run name (must match on every host of a split run)")
    p.add_argument(
        "--timeout", type=float, default=NEIGHBOUR_TIMEOUT.default, help="s before a silent neighbour is dropped"
    )
    p.add_argument("--record", help="write the run to this MCAP file (passive recorder process)")
    _add_auth_file_argument(p)
    p.add_argument(
        SYNC_OPTION,
        "--mode",  # its first name, kept working (tests/test_radio.py, docs)
        dest="sync",
        choices=MODES,
        default=Sync.mode,
        help="lockstep (reproducible) or async (each agent on its own clock, docs/protocol.md)",
    )
    p.add_argument("--rate", type=float, default=Sync.rate, help="async: steps/s each agent aims for")
    p.add_argument(
        "--max-age", type=float, default=Sync.max_age, help="async: s after which a neighbour state is not used"
    )
    p.add_argument(
        "--progress",
        action="store_true",
        help="the progress line on stderr (step, steps/s, alive, failures; a new line every 5 s into a file or "
        "pipe: what scripts/soak.py reads)",
    )
    add_swarm_arguments(p)
    add_obstacles_argument(p)
    add_json_argument(p)
    p.set_defaults(func=_launch)

    p = sub.add_parser("verify", help="N agent processes against the per-particle reference driver")
    p.add_argument("--agents", type=int, default=VERIFY_AGENTS)
    p.add_argument("--steps", type=int, default=300)
    p.add_argument("--connect", help="use the Zenoh router at tcp/HOST:PORT instead of an embedded one")
    p.add_argument(
        "--timeout", type=float, default=NEIGHBOUR_TIMEOUT.exact, help="s before a silent neighbour is dropped"
    )
    _add_slice_arguments(p, "run only this slice of the swarm here (the other hosts run the rest), e.g. 0-19")
    p.add_argument("--run", help="run name shared by every host of a split run")
    _add_auth_file_argument(p)
    add_robot_argument(p)
    add_radio_arguments(p)
    add_obstacles_argument(p)
    add_json_argument(p)
    p.set_defaults(func=_verify)


def _add_slice_arguments(p, ids_help: str) -> None:
    slice_ = p.add_mutually_exclusive_group()
    slice_.add_argument("--ids", help=ids_help)
    slice_.add_argument(
        "--share",
        metavar="K/M",
        help="start region K (1..M) of M compact regions of the start layout here (recursive bisection, "
        "agent/sph/regions.py; every host of the run names its own K of the same M)",
    )


def _add_auth_file_argument(p) -> None:
    # No --user/--password: a secret on the command line is readable by every local user (ps); the users
    # file (mode 0600) gives each process of this launcher its own role's line (docs/security.md).
    p.add_argument(
        "--auth-file",
        metavar="FILE",
        help="with --connect: the run's users file (user:password lines, the routers hold the same; "
        "default $FLUIDSWARM_AUTH_FILE); this launcher authenticates as 'launcher' and hands each "
        "process its own line",
    )


def _agent(args) -> int:
    import os

    from swarmhost.executable import agent_executable

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


def parse_share(text: str) -> tuple[int, int]:
    """'2/3' -> (2, 3): region K of M, 1 <= K <= M."""
    k, sep, m = text.partition("/")
    try:
        share = int(k), int(m)
    except ValueError:
        share = None
    if not sep or share is None:
        raise UserError(f"--share {text!r}: expected K/M, region K of M, e.g. 1/2")
    if not 1 <= share[0] <= share[1]:
        raise UserError(f"--share {text!r}: K must be 1..M")
    return share


def share_ids(text: str, setup) -> list[int]:
    """The ids of region K of M (`--share K/M`) of `setup`'s start layout, sorted (agent/sph/regions.py)."""
    from agent.sph.particle import X, Y
    from agent.sph.regions import share

    k, m = parse_share(text)
    if m > len(setup.ids):
        raise UserError(f"--share {text!r}: {m} regions of {len(setup.ids)} agents, at most one region per agent")
    return sorted(int(i) for i in setup.ids[share(setup.states[:, [X, Y]], k, m)])


def _slice(args, kind) -> list[int] | None:
    """The ids of `--ids` or `--share` (after the block was checked: its layout is the one shared out)."""
    if args.share:
        return share_ids(args.share, kind.make_setup())
    return parse_ids(args.ids, args.agents) if args.ids else None


def _check_counts(args) -> None:
    check_agents(args.agents, embedded=not args.connect)
    steps = args.steps
    if steps < 0:
        raise UserError(f"--steps: must be >= 0, got {steps}")


def _check_before_start(args) -> None:
    """What would fail once the router runs, found before it starts: a recording that cannot be written (one
    line, nothing started; a swarm beyond an embedded router's ids is _check_counts')."""
    from swarmhost.recorder_process import check_writable

    if getattr(args, "record", None):
        check_writable(Path(args.record))


def _auth_file(args) -> str:
    """--auth-file, checked before anything starts: one line naming the file and the problem."""
    from agent.protocol.access import AuthFileError, read_users_file

    if not args.auth_file:
        return ""
    if not args.connect:
        raise UserError(
            f"--auth-file {args.auth_file}: needs --connect (an embedded router makes its own credentials for each run)"
        )
    try:
        users = read_users_file(args.auth_file)
    except AuthFileError as exc:
        raise UserError(f"--auth-file {exc}") from None
    if not any(c.user == "launcher" for c in users):
        raise UserError(f"--auth-file {args.auth_file}: no 'launcher' line (this launcher's own credentials)")
    return args.auth_file


def _options(args, name: str, timeout: float, live: str = "", ros2: str = ""):
    from fluidswarm.orchestration.run import RunOptions

    realtime = getattr(args, "realtime", False)  # launch has --realtime; verify runs as fast as it can
    access = Access(connect=args.connect, run=args.run, auth_file=_auth_file(args))
    return RunOptions(Recording(None, name, live, ros2), timeout, access=access, realtime=realtime)


def _check_block(kind) -> None:
    """The robots must fit the block before anything starts (one line naming the robot's key)."""
    try:
        kind.make_setup()
    except ValueError as exc:
        key, _, problem = str(exc).partition(": ")
        if key.startswith("obstacle["):  # agent/sph/setups.py with_obstacles: an obstacle on a start body
            raise UserError(f"--obstacles: key '{key}': {problem}") from None
        raise UserError(f"--robot: {exc}") from None


def _launch(args) -> int:
    from fluidswarm.block import Block
    from fluidswarm.orchestration.run import Run

    _check_counts(args)
    _check_before_start(args)
    check("--rate", positive_problem(args.rate))
    check("--max-age", positive_problem(args.max_age))
    if args.live is not None and not args.record:
        raise UserError("--live needs --record FILE.mcap (the recorder process serves the live view)")
    options = _options(args, "launch", args.timeout, live_from_args(args), ros2_from_args(args))
    if options.recording.ros2 and not args.record:
        raise UserError("--ros2 needs --record FILE.mcap (the recorder process publishes the run)")
    if args.ros2_bag and not args.record:
        raise UserError("--ros2-bag needs --record FILE.mcap (the bag is made from it)")
    bag = ros2_bag_from_args(args)
    options.progress = args.progress
    if args.share and not args.run:
        raise UserError("--share needs --run: every host of a split run must use the same run name")
    if args.share:
        parse_share(args.share)  # its form, before the block is made
    kind = Block(
        args.agents,
        args.steps,
        Sync(args.sync, args.rate, args.max_age),
        None,
        args.record,
        robot=robot_model(args.robot),
        radio=radio_model(radio_options(args)),
        obstacles=obstacles_file(args.obstacles),
    )
    check_lockstep(kind.radio, args.sync, "--radio-*")
    _check_block(kind)
    kind.ids = _slice(args, kind)
    with Run(kind, options) as run:
        # the run's name and router come first, as they happen: the other hosts of a split run need them
        print(
            f"run={run.launcher.run} router={run.launcher.endpoint}",
            flush=True,
            file=sys.stderr if args.json else sys.stdout,
        )
        kind.drive(run)
    r = run.record
    write_run_bag(r.mcap, bag)
    if args.json:
        print_json(r)
        return 0
    print(f"mode={r.sync}")
    print(f"agents={r.agents}")
    print(f"finished={r.finished}")
    print(f"steps_per_second={r.steps_per_second:.2f}")
    print(f"msgs_per_agent_step={r.msgs_per_agent_step:.2f}")
    print(f"neighbours_per_agent={r.neighbours_per_agent:.2f}")
    print(f"startup_seconds={r.startup_seconds:.2f}")
    return 0


def _verify(args) -> int:
    from fluidswarm.block import Block
    from fluidswarm.orchestration.run import Run

    _check_counts(args)
    _check_before_start(args)
    for flag in ("ids", "share"):
        if getattr(args, flag) and not args.run:
            raise UserError(f"--{flag} needs --run: every host of a split run must use the same run name")
    if args.share:
        parse_share(args.share)
    kind = Block(
        args.agents,
        args.steps,
        reference=True,
        kind="verify",
        robot=robot_model(args.robot),
        radio=radio_model(radio_options(args)),
        obstacles=obstacles_file(args.obstacles),
    )
    _check_block(kind)
    kind.ids = _slice(args, kind)
    with Run(kind, _options(args, "verify", args.timeout)) as run:
        kind.drive(run)
    r = run.record
    error = r.figures["max_position_error"]
    if args.json:
        print_json(r)
    else:
        print(f"max_position_error={error:.3e}")
        print(f"msgs_per_agent_step={r.msgs_per_agent_step:.3f}")
        print(f"neighbours_per_agent={r.neighbours_per_agent:.3f}")
        print(f"steps_per_second={r.steps_per_second:.2f}")
    return 0 if r.passed else 1
