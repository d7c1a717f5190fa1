"""Pure SPH physics (thesis ch. 3 and 6): arrays in, arrays out; no I/O, no globals.

The agent process and the centralised reference solvers call these same functions.
"""

from agent.sph.equations import (
    artificial_viscosity,
    body_force,
    density,
    density_terms,
    momentum_terms,
    stress_rate_terms,
    tait_pressure,
)
from agent.sph.kernel import gaussian_kernel, kernel_gradient
from agent.sph.params import SPHParams
from agent.sph.particle import FIELD_NAMES, NFIELDS, Control, initial_state, step_particle

__all__ = [
    "FIELD_NAMES",
    "NFIELDS",
    "Control",
    "SPHParams",
    "artificial_viscosity",
    "body_force",
    "density",
    "density_terms",
    "gaussian_kernel",
    "initial_state",
    "kernel_gradient",
    "momentum_terms",
    "step_particle",
    "stress_rate_terms",
    "tait_pressure",
]
