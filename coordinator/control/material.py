"""The imitation's materials, each written here once: the stiffness beta [N/m] and viscosity mu [kg/s] every
controller (fill, region, pca, ann) gives the fluid, and the harder parts fill gives fingers and arms.

beta is the fluid's own default (agent/sph/params.py SPHParams.beta, the thesis' normal stiffness; the agent's
crate decodes the same, tests/test_defaults.py); mu is the imitation's, above the fluid's default of 0 so a
swarm settles at its shape instead of sloshing (imitation_setup.imitation_params).
"""

from __future__ import annotations

from agent.sph.params import SPHParams

BETA = SPHParams.beta  # the fluid's stiffness in every imitation: the thesis' normal 2 N/m
MU = 0.2
# the fingers' material (thesis: beta 2 -> 50 past the palm; 50 measured worse, docs/fill.md)
FINGER_BETA, FINGER_MU = 5.0, 1.0
ARM_BETA, ARM_MU = 20.0, 1.0  # the arms' material (thesis: beta 2 -> 20 past the shoulders, §6.3)
