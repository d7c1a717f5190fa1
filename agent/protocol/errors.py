"""The project's exceptions have one base, `FluidswarmError`; each kind below it says in its message, in one
line, what was wrong and where (the file, the key, the process, the step).

    FluidswarmError
    ├── UserError       what a user can fix: a file, an argument, a scenario, a program not built
    │                   (InputError, SegmentationError, ShapeError, AuthFileError, BenchRecordError,
    │                   AgentNotBuilt, the coordinator's CoordinatorFailed, PerceptionFailed)
    ├── SwarmError      a run's processes did not do their part: did not start or finish in time
    │                   (SwarmTimeout), ended or failed when needed (SwarmFailed; HelperLost)
    └── CommandRejected a gesture command an agent or follower refused (untrusted bytes, not the user's)

The command line prints any of them as that one line with exit code 1 (fluidswarm/cli.py); a kind that was
a builtin error before keeps it as a second base (InputError is a ValueError, SwarmTimeout a TimeoutError,
SwarmFailed a RuntimeError).
"""


class FluidswarmError(Exception):
    """The base of the project's own errors. `what` is how the command line introduces the kind ('' or e.g.
    'swarm: '); the message is the rest of the line."""

    what = ""


class UserError(FluidswarmError):
    """Bad input from the user (a file, an argument, a scenario): printed as one line, exit code 1."""


class SwarmError(FluidswarmError):
    """The swarm's processes did not do their part (the message says which and when)."""

    what = "swarm: "


class SwarmTimeout(SwarmError, TimeoutError):
    """Agents, the recorder or the run did not reach a point in time (the message names the point and the wait)."""


class SwarmFailed(SwarmError, RuntimeError):
    """A process of the run ended or failed when the run needed it (the message names it and its exit)."""
