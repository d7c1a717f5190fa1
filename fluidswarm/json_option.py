"""`--json` of the commands that run a swarm: the run's record as exactly one JSON object on stdout."""

from __future__ import annotations

HELP = (
    "print the run's record (fluidswarm/orchestration/run.py RunRecord) as one JSON object instead of key=value lines"
)


def add_json_argument(parser) -> None:
    parser.add_argument("--json", action="store_true", help=HELP)


def print_json(record) -> None:
    """`record`: a fluidswarm.orchestration.run.RunRecord."""
    print(record.to_json(), flush=True)
