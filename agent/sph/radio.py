"""The imperfect radio and localisation of robots (issue 33, docs/robots.md "The imperfect radio").

Zenoh delivers every state as it always does (the network stays real); the *receiving* agent then makes of
it what a robot's radio and localisation would have given it:

loss      receiver i does not use sender j's state of step s in its SPH sums when
          u(seed, LOSS, i, j, s) < loss. Lockstep still counts the state as received: it completes the
          step's expected set, so a lost state never makes anyone wait (docs/protocol.md).
latency   at step t the receiver uses j's state of step t - latency (at the start, and whenever it lacks
          it, the oldest it holds of steps t - latency .. t). Which neighbours take part is decided on
          their step-t states, as lockstep guarantees them; their contributions come from the older state
          (and vanish, through the kernel's support, when that state is beyond it).
noise     j's localisation reports its position of step s off by sigma (g_x, g_y), a standard normal pair
          from Box-Muller on u(seed, NOISE_R, j, 0, s) and u(seed, NOISE_A, j, 0, s). The error is j's
          (every receiver sees the same one), applied where it is received: what j publishes, and what the
          recorder measures, is its true state; an agent's own position in its step is its true one.

u is counter-based: splitmix64's finaliser chained over (seed, stream, a, b, step) (Steele, Lea & Flood,
"Fast splittable pseudorandom number generators", OOPSLA 2014), so every draw is a function of the run's
seed, ids and a step, never of the order messages arrived in. agent/native/src/radio.rs is the port
(tests/vectors/radio.json holds draws of this module that cargo test checks); the per-particle reference
driver (agent/sph/reference.py) applies the same draws, so `verify --radio-*` stays exact.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace

MASK = (1 << 64) - 1
LOSS, NOISE_R, NOISE_A = 1, 2, 3
# R_sub = 2h + 10 v_max dt covers where a neighbour k steps back can have published (2k v_max dt of relative
# motion, one step of it before the cells are updated): k <= 4 (docs/protocol.md).
MAX_LATENCY = 4


def _mix(z: int) -> int:
    """splitmix64's step and finaliser on a 64-bit integer."""
    z = (z + 0x9E3779B97F4A7C15) & MASK
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
    return z ^ (z >> 31)


def uniform(seed: int, stream: int, a: int, b: int, step: int) -> float:
    """A uniform number in [0, 1) for (seed, stream, a, b, step)."""
    z = _mix(seed & MASK)
    for v in (stream, a, b, step):
        z = _mix(z ^ v)
    return (z >> 11) * 2.0**-53


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


@dataclass(frozen=True)
class RadioModel:
    """loss: probability in [0, 1) that a state is lost to a receiver; latency: steps (0..MAX_LATENCY) a state
    takes to be used; noise: sigma [m] of each coordinate of a neighbour's reported position; seed: the run's
    (module docstring). The default is the perfect radio of the thesis."""

    loss: float = 0.0
    latency: int = 0
    noise: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        loss, latency, noise, seed = self.loss, self.latency, self.noise, self.seed
        if not _number(loss) or not 0.0 <= loss < 1.0:
            raise ValueError(f"radio.loss: must be a probability in [0, 1), got {loss!r}")
        if not isinstance(latency, int) or isinstance(latency, bool) or not 0 <= latency <= MAX_LATENCY:
            raise ValueError(
                f"radio.latency: must be an integer number of steps in [0, {MAX_LATENCY}], got {latency!r}"
            )
        if not _number(noise) or noise < 0:
            raise ValueError(f"radio.noise: must be a finite number of metres >= 0, got {noise!r}")
        if not isinstance(seed, int) or isinstance(seed, bool):
            raise ValueError(f"radio.seed: must be an integer, got {seed!r}")  # noqa: TRY004  # one kind of error for every bad setting
        object.__setattr__(self, "loss", float(loss))
        object.__setattr__(self, "noise", float(noise))
        object.__setattr__(self, "seed", seed & MASK)  # the agent reads it as an unsigned 64-bit integer

    @property
    def is_perfect(self) -> bool:
        return self.loss == 0.0 and self.latency == 0 and self.noise == 0.0

    def lost(self, receiver: int, sender: int, step: int) -> bool:
        """Whether `receiver` does not use `sender`'s state of `step`."""
        return self.loss > 0.0 and uniform(self.seed, LOSS, receiver, sender, step) < self.loss

    def position_error(self, sender: int, step: int) -> tuple[float, float]:
        """(dx, dy) [m]: how far off `sender`'s reported position of `step` is."""
        if self.noise == 0.0:
            return 0.0, 0.0
        u1 = 1.0 - uniform(self.seed, NOISE_R, sender, 0, step)  # (0, 1]: the log is finite
        u2 = uniform(self.seed, NOISE_A, sender, 0, step)
        r = self.noise * math.sqrt(-2.0 * math.log(u1))
        a = 2.0 * math.pi * u2
        return r * math.cos(a), r * math.sin(a)

    def with_seed(self, seed: int) -> RadioModel:
        return replace(self, seed=seed)

    def as_dict(self) -> dict:
        return asdict(self)


PERFECT = RadioModel()


def radio_from(table: dict | None = None, seed: int = 0) -> RadioModel:
    """A RadioModel from a table of its fields (a scenario's [radio], the --radio-* options), validated; `seed`
    the run's."""
    values = dict(table or {})
    known = [f.name for f in fields(RadioModel) if f.name != "seed"]
    unknown = sorted(set(values) - set(known))
    if unknown:
        raise ValueError(f"radio.{unknown[0]}: unknown key (known: {', '.join(known)})")
    return RadioModel(**values, seed=seed)
