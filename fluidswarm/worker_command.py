"""`fluidswarm worker` and the main host's `--workers M` (`imitate`, `run`): one run over several hosts, each on
its own router (docs/multi-host.md "Workers"). The main host perceives, plans, runs the coordinator, the
recorder and region 1; each worker fetches its region of the run's plan over Zenoh, checks its signature, and
starts and supervises its agents until they have reported (their reports reach the main host's record).
"""

from __future__ import annotations

import os
import sys

from agent.protocol.access import AUTH_FILE_ENV
from agent.protocol.errors import UserError
from fluidswarm.orchestration.split_options import SHARE_KINDS, WORKERS_TIMEOUT


def add_workers_arguments(p) -> None:
    p.add_argument("--connect", help="with --workers: this host's router (tcp/HOST:PORT, `fluidswarm router`)")
    p.add_argument("--run", help="with --workers: the run's name, which every worker names too")
    p.add_argument(
        "--workers",
        type=int,
        default=0,
        metavar="M",
        help="the run's other hosts: wait for M `fluidswarm worker --run NAME` and give each a region of the "
        "start layout (this host runs region 1; needs --connect, --run and the users file)",
    )
    p.add_argument(
        "--workers-timeout",
        type=float,
        default=WORKERS_TIMEOUT,
        metavar="S",
        help=f"s to wait for the workers before anything starts (default {WORKERS_TIMEOUT:.0f})",
    )
    p.add_argument(
        "--shares",
        choices=SHARE_KINDS,
        default=None,
        help="with --workers: how the swarm is cut between the hosts: compact regions of the formation it is going "
        "to (default: the numpy oracle run ahead; a host's agents stay each other's neighbours), regions of its "
        "start layout, or ranges of ids (the last two to compare what crosses between hosts)",
    )
    _add_auth_file(p)


def _add_auth_file(p) -> None:
    p.add_argument(
        "--auth-file",
        metavar="FILE",
        help="the run's users file (`fluidswarm auth-file`; default $FLUIDSWARM_AUTH_FILE), the one the routers hold",
    )


def _users_file(args) -> str:
    """--auth-file or $FLUIDSWARM_AUTH_FILE, checked (one line naming the file and the problem)."""
    from agent.protocol.access import AuthFileError, read_users_file

    path = args.auth_file or os.environ.get(AUTH_FILE_ENV, "")
    source = "--auth-file" if args.auth_file else AUTH_FILE_ENV
    if not path:
        raise UserError(f"a run over hosts needs the run's users file: --auth-file FILE or ${AUTH_FILE_ENV}")
    try:
        users = read_users_file(path)
    except AuthFileError as exc:
        raise UserError(f"{source} {exc}") from None
    if not any(c.user == "launcher" for c in users):
        raise UserError(f"{source} {path}: no 'launcher' line (this launcher's own credentials)")
    return path


def workers_options(args) -> dict:
    """The imitation's multi-host options, checked before anything starts ({} for a run on this host)."""
    if not args.workers:
        for flag in ("connect", "run", "auth_file", "shares"):
            if getattr(args, flag):
                raise UserError(f"--{flag.replace('_', '-')} goes with --workers M (a run over several hosts)")
        return {}
    if args.workers < 1 or args.workers > 255:
        raise UserError(f"--workers: must be 1..255, got {args.workers}")
    if not args.connect or not args.run:
        raise UserError("--workers needs --connect ROUTER and --run NAME (the workers name the same run)")
    if not 0 < args.workers_timeout <= 3600:
        raise UserError(f"--workers-timeout: must be in (0, 3600] s, got {args.workers_timeout}")
    return {
        "connect": args.connect,
        "run": args.run,
        "workers": args.workers,
        "auth_file": _users_file(args),
        "workers_timeout": args.workers_timeout,
        "shares": args.shares or SHARE_KINDS[0],
    }


def register(sub) -> None:
    p = sub.add_parser("worker", help="run this host's share of a run whose main host has --workers M")
    p.add_argument("--connect", required=True, help="this host's router (tcp/HOST:PORT, `fluidswarm router`)")
    p.add_argument("--run", required=True, help="the run's name (the main host's --run)")
    _add_auth_file(p)
    p.add_argument(
        "--wait",
        type=float,
        default=60.0,
        metavar="S",
        help="s to wait for the main host to serve the run's plan (it perceives first; default 60)",
    )
    p.add_argument("--quiet", action="store_true", help="no summary lines")
    p.set_defaults(func=_worker)


def _worker(args) -> int:
    from agent.protocol import keys
    from agent.protocol.plan import command_key
    from swarmhost.launcher import Launcher
    from swarmhost.workers import fetch_share, launcher_password, run_share

    if not keys.valid_run_name(args.run):
        raise UserError(f"--run {args.run!r}: use 1-64 letters, digits, '-' or '_'")
    users = _users_file(args)
    if not 0 < args.wait <= 3600:
        raise UserError(f"--wait: must be in (0, 3600] s, got {args.wait}")
    with Launcher(run=args.run, connect=args.connect, auth_file=users, commands=True) as la:
        plan = fetch_share(la, args.wait)
        la.use_secret(command_key(launcher_password(la), la.run, plan.salt))
        k, m = plan.share
        print(f"run={la.run} share={k}/{m} agents={len(plan.specs)} router={la.endpoint}", flush=True)
        start = max(s.start_timeout for s in plan.specs)
        steps = max(s.steps for s in plan.specs)
        finals = run_share(la, plan, start, 60.0 + steps * (0.05 + 0.004 * len(plan.specs)))
    done = sum(1 for r in finals.values() if r.done)
    if not args.quiet:
        print(f"agents={len(plan.specs)}")
        print(f"finished={done}")
    if done < len(plan.specs):
        print(
            f"fluidswarm worker: {len(plan.specs) - done} of {len(plan.specs)} agents of share {k}/{m} did not finish",
            file=sys.stderr,
        )
        return 1
    return 0
