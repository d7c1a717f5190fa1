"""`python -m research COMMAND`: the research tools' console (research/__init__.py), the same one-line errors and
exit codes as the `fluidswarm` command (fluidswarm/cli.py)."""

import sys

from fluidswarm.cli import build_parser, main
from research.reproduce import command as reproduce_command

# The modules that contribute subcommands, in the order they appear in `--help`.
COMMAND_MODULES = (reproduce_command,)

if __name__ == "__main__":
    parser = build_parser("python -m research", "fluidswarm's research tools, outside the wheel", COMMAND_MODULES)
    sys.exit(main(parser=parser))
