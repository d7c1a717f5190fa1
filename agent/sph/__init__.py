"""Pure SPH physics (thesis ch. 3 and 6): arrays in, arrays out; no I/O, no globals.

The centralised reference solvers (`verify`'s and `reproduce`'s oracle) call these functions; the agent process
does not: it is compiled, and its step (agent/native/src/sph.rs) is tested against tests/vectors/sph_steps.json,
written by this package.
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
