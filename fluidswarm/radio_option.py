"""`--radio-loss/--radio-latency/--radio-noise` of the commands that run a swarm, and a scenario's [radio] table:
the imperfect radio and localisation of the robots (agent/sph/radio.py, docs/robots.md)."""

from __future__ import annotations

from agent.protocol.errors import UserError
from agent.sph.radio import MAX_LATENCY, PERFECT, RadioModel, radio_from

OPTIONS = {"loss": "--radio-loss", "latency": "--radio-latency", "noise": "--radio-noise"}


def add_radio_arguments(parser) -> None:
    g = parser.add_argument_group("imperfect radio (docs/robots.md; lockstep only; draws seeded from the run's seed)")
    g.add_argument(
        "--radio-loss",
        type=float,
        default=None,
        metavar="P",
        help="probability in [0, 1) that a receiver loses a neighbour's state (not used in its step)",
    )
    g.add_argument(
        "--radio-latency",
        type=int,
        default=None,
        metavar="K",
        help=f"steps (0..{MAX_LATENCY}) before a received state is used: a neighbour's state of K steps back",
    )
    g.add_argument(
        "--radio-noise",
        type=float,
        default=None,
        metavar="SIGMA",
        help="m: standard deviation of each coordinate of a neighbour's reported position",
    )


def radio_options(args) -> dict:
    """The --radio-* options given, as [radio] table fields."""
    return {
        k: getattr(args, o[2:].replace("-", "_"))
        for k, o in OPTIONS.items()
        if getattr(args, o[2:].replace("-", "_"), None) is not None
    }


def radio_model(table: dict | None, seed: int = 0, where: str = "") -> RadioModel:
    """The RadioModel of `table` (a scenario's [radio] with the options over it) for the run's `seed`; bad input
    is one line naming the key (`where`: the file, for a scenario; else the option)."""
    if not table:
        return PERFECT if seed == 0 else PERFECT.with_seed(seed)
    try:
        return radio_from(table, seed)
    except (ValueError, TypeError) as exc:
        key, _, problem = str(exc).partition(": ")
        if where:
            raise UserError(f"{where}: key '{key}': {problem}") from None
        option = OPTIONS.get(key.removeprefix("radio."), key)
        raise UserError(f"{option}: {problem}") from None


def check_lockstep(radio: RadioModel, mode: str, where: str) -> None:
    """The imperfect radio is modelled in lockstep only (its draws are per step; async steps are each agent's)."""
    if not radio.is_perfect and mode == "async":
        raise UserError(f"{where}: the imperfect radio is modelled in lockstep only, not with sync mode async")
