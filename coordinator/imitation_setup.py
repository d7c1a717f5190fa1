"""From a picture to an imitation set-up: silhouette, transform, SPH parameters, initial swarm, command."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from agent.sph.params import SPHParams
from agent.sph.particle import Control, initial_state
from agent.sph.setups import Setup, lattice
from coordinator.command import GestureCommand
from coordinator.region import centre_px, domain_for, fit_transform, region_command
from fluidswarm.geometry import ImageToDomain
from perception.segmentation import hand_mask

DEFAULT_STEPS = 700


def imitation_params(domain) -> SPHParams:
    """SPH settings of the imitation runs: the thesis' model plus a little drag so the swarm settles.

    dt = 0.02 s with v_max = 3 m/s (0.06 m per step); mu = 0.2 kg/s; drag 1.5 1/s.
    """
    return SPHParams(dt=0.02, v_max=3.0, drag=1.5, mu=0.2, beta=2.0, domain=tuple(domain), border="reflect")


@dataclass
class Imitation:
    mask: np.ndarray
    transform: ImageToDomain
    command: GestureCommand
    setup: Setup


def prepare(frame_bgr: np.ndarray, n_agents: int, seq: int = 1) -> Imitation:
    mask = hand_mask(frame_bgr)
    transform = fit_transform(mask, n_agents)
    params = imitation_params(domain_for(mask, transform))
    command = region_command(mask, transform, n_agents, seq=seq)
    cu, cv = centre_px(mask)
    centre = transform.to_domain(np.array([cu, cv]))
    columns = max(1, int(round(np.sqrt(n_agents))))
    pos = lattice(n_agents, columns, 1.0)
    pos += centre - pos.mean(axis=0)
    states = np.array([initial_state(x, y, 0.0, 0.0, params) for x, y in pos])
    controls = [Control(beta=command.beta, mu=command.mu) for _ in range(n_agents)]
    from agent.route import class_of

    shares = [c.share for c in command.classes]
    classes = np.array([class_of(i, n_agents, shares) for i in range(n_agents)])
    setup = Setup(np.arange(n_agents), states, controls, classes, tuple(c.name for c in command.classes), params)
    return Imitation(mask, transform, command, setup)
