"""The `fluidswarm` console command.

Each subcommand lives next to the code it drives and exposes `register(subparsers)`; this module imports each
one by name and collects them (a subcommand's module that cannot be imported is an error here, never a command
silently missing from `--help`). The project's errors
(agent/protocol/errors.py `FluidswarmError`: `UserError` for what the user can fix, `SwarmError` for a run's
processes) are printed as one line (exit 1); argparse usage errors exit 2. The research tools outside the wheel
(research/, `python -m research`) are a second console of the same machinery (`build_parser`'s `prog` and
`modules`, then `main`).
"""

from __future__ import annotations

import argparse
import signal
import sys
from typing import NoReturn

from agent.protocol.errors import FluidswarmError
from fluidswarm import (
    auth_file,
    bench,
    imitate_commands,
    replay_command,
    router,
    scenario_commands,
    simulate,
    swarm_commands,
    worker_command,
)
from perception import commands as perception_commands

# The modules that contribute subcommands, in the order they appear in `--help`.
COMMAND_MODULES = (
    simulate,
    swarm_commands,
    perception_commands,
    imitate_commands,
    replay_command,
    scenario_commands,
    bench,
    router,
    auth_file,
    worker_command,
)


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # one line, exit 2
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser(
    prog: str = "fluidswarm", description: str = __doc__.splitlines()[0], modules: tuple = COMMAND_MODULES
) -> argparse.ArgumentParser:
    parser = _Parser(prog=prog, description=description)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for module in modules:
        module.register(sub)
    return parser


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def main(argv: list[str] | None = None, parser: argparse.ArgumentParser | None = None) -> int:
    """Run one command of `parser` (the `fluidswarm` command's by default); its errors are one line each."""
    # SIGTERM unwinds like Ctrl-C, so every command's clean-up (stop agents, finish files) runs.
    signal.signal(signal.SIGTERM, _interrupt)
    parser = parser or build_parser()
    args = parser.parse_args(argv)
    prog = f"{parser.prog} {args.command}"
    try:
        return int(args.func(args) or 0)
    except FluidswarmError as exc:  # every kind: its one line (agent/protocol/errors.py)
        print(f"{prog}: error: {exc.what}{exc}", file=sys.stderr)
        return 1
    except (TimeoutError, RuntimeError) as exc:  # a library's, or a process not yet given a kind of its own
        print(f"{prog}: error: swarm: {exc}", file=sys.stderr)
        return 1
    except BrokenPipeError:  # output piped into `head` and closed early
        return 0
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
