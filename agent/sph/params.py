"""SPH parameters: one typed dataclass, validated once at the edge.

Units are SI in two dimensions: lengths in metres, masses in kilograms, densities in kg/m^2 (an areal
density, since the fluid is 2-D), pressures in N/m, times in seconds.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace
from enum import StrEnum


class Border(StrEnum):
    """What happens to a particle that leaves the domain (SPHParams.border)."""

    FREEZE = "freeze"
    REFLECT = "reflect"


BORDER_POLICIES = tuple(b.value for b in Border)


@dataclass(frozen=True)
class SPHParams:
    """Parameters of the SPH model (thesis ch. 3, eq. 3.3-3.13) and of its integration.

    Thesis values: kappa = 2 (support radius kappa*h), gamma = 7 (Tait), beta in {2, 20, 50}.
    The rest is our choice, documented here:

    h        smoothing length [m]; 1.0 with a particle spacing of 1.0 gives ~12 neighbours within 2h.
    mass     particle mass [kg]; 1.0 so a square lattice of spacing 1 has density ~ rho0.
    rho0     reference density [kg/m^2] of the Tait equation of state (eq. 3.13): 0.85, below the
             density of a unit-spaced lattice (0.98), so a packed swarm is slightly compressed and spreads.
    gamma    Tait exponent (thesis: "around 7").
    beta     the fluid's stiffness [N/m] of eq. 3.13 (thesis: 2 normal, 20 arms, 50 fingers/cylindrical):
             every particle's unless its controller sets another (Control.beta; the branching
             experiment's edges, the drag experiment's fluid). A scenario's [sph] beta sets it.
    beta_pi  coefficient of the artificial viscosity (eq. 3.9) [dimensionless].
    mu       the fluid's dynamic viscosity [kg/s] of the viscous stress term (eq. 3.7-3.8, 3.11), likewise
             the default of Control.mu. In an imitation the gesture command sets both per class.
    kappa    support radius in units of h (W = 0 beyond kappa*h, eq. 3.3).
    dt       time step [s] of the symplectic Euler integrator.
    v_max    speed limit [m/s]: a robot's top speed; it also bounds a particle's displacement per step
             (v_max*dt), which the agents' neighbour protocol relies on (docs/protocol.md).
    drag     linear drag coefficient [1/s] (per unit mass, -drag*v). 0 in the thesis' pure model; the
             imitation scenarios use a little so a swarm settles at its waypoints instead of orbiting.
    domain   (xmin, xmax, ymin, ymax) [m] of the environment.
    border   Border.FREEZE (thesis §4.7: a particle leaving the domain gets its fluid parameters set to 0 and
             stops) or Border.REFLECT (mirrored back, normal velocity reversed); its name is accepted too.
    """

    h: float = 1.0
    mass: float = 1.0
    rho0: float = 0.85
    gamma: float = 7.0
    beta: float = 2.0
    beta_pi: float = 1.0
    mu: float = 0.0
    kappa: float = 2.0
    dt: float = 0.01
    v_max: float = 5.0
    drag: float = 0.0
    domain: tuple[float, float, float, float] = (0.0, 60.0, 0.0, 30.0)
    border: Border = Border.FREEZE

    def __post_init__(self) -> None:
        positive = ("h", "mass", "rho0", "gamma", "kappa", "dt", "v_max")
        non_negative = ("beta", "beta_pi", "mu", "drag")
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name in positive + non_negative:
                if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
                    raise ValueError(f"SPHParams.{f.name}: must be a finite number, got {value!r}")
                if f.name in positive and value <= 0:
                    raise ValueError(f"SPHParams.{f.name}: must be > 0, got {value!r}")
                if f.name in non_negative and value < 0:
                    raise ValueError(f"SPHParams.{f.name}: must be >= 0, got {value!r}")
        if len(self.domain) != 4 or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in self.domain):
            raise ValueError(
                f"SPHParams.domain: must be four finite numbers (xmin, xmax, ymin, ymax), got {self.domain!r}"
            )
        xmin, xmax, ymin, ymax = self.domain
        if not (xmin < xmax and ymin < ymax):
            raise ValueError(f"SPHParams.domain: need xmin < xmax and ymin < ymax, got {self.domain!r}")
        if self.border not in BORDER_POLICIES:
            raise ValueError(f"SPHParams.border: must be one of {BORDER_POLICIES}, got {self.border!r}")
        # a policy's name (a scenario's [sph] table, a spec's JSON) is the Border it names
        object.__setattr__(self, "border", Border(self.border))
        object.__setattr__(self, "domain", tuple(float(v) for v in self.domain))

    @property
    def support(self) -> float:
        """Support radius kappa*h [m]: particles farther apart do not interact."""
        return self.kappa * self.h

    @property
    def max_step_displacement(self) -> float:
        """Largest distance a particle can move in one step [m] (speed limit times dt)."""
        return self.v_max * self.dt

    def with_(self, **changes) -> SPHParams:
        return replace(self, **changes)

    def with_overrides(self, fields: dict, dt: float = 0.0) -> SPHParams:
        """These parameters with a scenario's [sph] table (and dt when > 0) applied, validated again."""
        changes = dict(fields)
        if "domain" in changes:
            changes["domain"] = tuple(changes["domain"])
        if dt:
            changes["dt"] = dt
        return replace(self, **changes)

    def as_dict(self) -> dict:
        return asdict(self)
