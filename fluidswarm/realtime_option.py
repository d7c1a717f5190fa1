"""`--realtime` of the commands that run a swarm as fast as they can: simulated time held to the wall clock
instead (swarmhost/pacing.py pace_realtime; `imitate --camera` always is). The record's `realtime_factor` says
what was reached, and a swarm that cannot keep up says so once (fluidswarm/orchestration/run.py REALTIME_KEPT)."""

from __future__ import annotations

HELP = (
    "pace the swarm to the wall clock: simulated time never runs ahead of it (realtime_factor in the record "
    "and the MCAP; a swarm that cannot keep up says so once)"
)


def add_realtime_argument(parser) -> None:
    parser.add_argument("--realtime", action="store_true", help=HELP)
