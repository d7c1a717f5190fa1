"""From what was observed to an imitation: silhouette, transform, SPH parameters, initial swarm, commands.

`imitation_for` is the one function from observations to (set-up, commands); the process that runs the swarm
calls it for a file (`imitation_of_input`, fluidswarm/orchestration/imitate.py) and for a camera's first
observation, which its coordinator puts on the bus (fluidswarm/orchestration/imitate_camera.py); `reproduce`
and the tests call the same function."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from enum import StrEnum

import numpy as np

from agent.protocol.command import GestureCommand
from agent.sph.params import Border, SPHParams
from agent.sph.particle import Control, initial_state
from agent.sph.setups import Setup, lattice
from coordinator.control.fill import AREA_PER_PARTICLE as FILL_AREA
from coordinator.control.fill import INITIAL_SPACING as FILL_SPACING
from coordinator.control.fill import fill_command, material_zones, rest_density
from coordinator.control.geometry import ImageToDomain
from coordinator.control.material import ARM_BETA, ARM_MU, BETA, FINGER_BETA, FINGER_MU, MU
from coordinator.control.observe import Observation, hand_label, is_clip, observe
from coordinator.control.region import (
    AREA_PER_PARTICLE,
    body_region_command,
    centre_px,
    domain_for,
    fit_transform,
    region_command,
)
from coordinator.control.route import class_of
from perception.ellipses import fit_ellipse, hand_regions
from perception.io import InputError, load_frames
from perception.segmentation import hand_mask

DEFAULT_STEPS = 700


class Controller(StrEnum):
    """How a silhouette becomes a command: fill (the shape itself, docs/fill.md), region (k-means regions
    as waypoints), pca (the eigen classifier's gesture template), ann (the thesis' network's force)."""

    FILL = "fill"
    REGION = "region"
    PCA = "pca"
    ANN = "ann"


CONTROLLERS = tuple(c.value for c in Controller)
DEFAULT_CONTROLLER = Controller.FILL


def controller_of(name: str) -> Controller:
    """The Controller named `name` (a Controller is its own name); ValueError naming the known ones."""
    try:
        return Controller(name)
    except ValueError:
        raise ValueError(f"unknown controller {name!r} (one of {', '.join(CONTROLLERS)})") from None


def imitation_params(domain, controller: Controller | None = None) -> SPHParams:
    """SPH settings of the imitation runs: the thesis' model plus a little drag so the swarm settles.

    dt = 0.02 s with v_max = 3 m/s (0.06 m per step); mu = 0.2 kg/s; drag 1.5 1/s. The fill controller
    sets the rest density from the area each particle is given (coordinator/control/fill.py: rest_density).
    """
    params = SPHParams(dt=0.02, v_max=3.0, drag=1.5, mu=MU, beta=BETA, domain=tuple(domain), border=Border.REFLECT)
    if controller is Controller.FILL:
        params = replace(params, rho0=rest_density(params))
    return params


@dataclass
class Imitation:
    """What an imitation starts from and is scored against: the target silhouette `mask` (of the last
    observation shown) in the domain of `transform`, the `commands` along the observations [(index of the
    first it holds for, command)], the swarm's initial `setup` and the target's `observation`."""

    mask: np.ndarray
    transform: ImageToDomain
    commands: list[tuple[int, GestureCommand]]
    setup: Setup
    observation: Observation

    @property
    def command(self) -> GestureCommand:
        """The first command: the one the swarm is placed for."""
        return self.commands[0][1]


def transform_for(mask: np.ndarray, n_agents: int, controller: Controller) -> ImageToDomain:
    """The image -> domain map, fixed by the first frame: the fill controller gives each particle more area,
    and its scale is a multiple of 2^-16 m/pixel so the fill shape's vertices (pixel corners) are exact
    binary fractions: a contour that touches itself stays touching, never crosses by a rounding error."""
    if controller is not Controller.FILL:
        return fit_transform(mask, n_agents, AREA_PER_PARTICLE)
    t = fit_transform(mask, n_agents, FILL_AREA)
    scale = round(t.scale * 2**16) / 2**16
    return ImageToDomain(scale=scale, x0=0.0, y0=mask.shape[0] * scale)


def fill_zones(obs, transform: ImageToDomain):
    """Where the thesis' region controller switches the material: the arms of a body (thesis §6.3,
    beta 2 -> 20 past the shoulders), the fingers of a hand (beta 2 -> 50 past the palm, §6.2.2)."""
    if obs.kind == "body":
        arms = [fit_ellipse(obs.parts[k]) for k in ("left_arm", "right_arm") if k in obs.parts]
        return material_zones([e for e in arms if e is not None], transform, ARM_BETA, ARM_MU)
    try:
        fingers = hand_regions(obs.mask)["fingers"]
    except ValueError:  # an empty silhouette: shape_rings says why
        return ()
    return material_zones(fingers, transform, FINGER_BETA, FINGER_MU)


def build_command(
    obs, transform: ImageToDomain, n_agents: int, controller: str = DEFAULT_CONTROLLER, seq: int = 1
) -> GestureCommand:
    """The chosen controller's command for one observation (coordinator.control.observe.Observation)."""
    kind = controller_of(controller)
    if kind is Controller.FILL:
        return fill_command(
            obs.mask, transform, n_agents, seq=seq, gesture=obs.label[:64], zones=fill_zones(obs, transform)
        )
    if kind is Controller.REGION:
        if obs.kind == "body":
            return body_region_command(obs.mask, obs.parts, transform, n_agents, seq=seq, gesture=obs.label)
        return region_command(obs.mask, transform, n_agents, seq=seq, gesture=obs.label[:64])
    # pca and ann are imported when chosen: their classifiers pull in scipy.optimize and the thesis' network
    # (~0.4 s), which every command line that plans an imitation paid before it started its router
    if kind is Controller.PCA:
        from coordinator.control.pca import pca_command

        return pca_command(obs, transform, n_agents, seq=seq)
    from coordinator.control.ann import ann_command

    return ann_command(obs, transform, n_agents, seq=seq)


def commands_along(
    shown: Sequence[Observation], transform: ImageToDomain, n_agents: int, controller: str = DEFAULT_CONTROLLER
) -> list[tuple[int, GestureCommand]]:
    """[(index of the first observation it holds for, command)]: a new command (next sequence number)
    whenever the recognised gesture (the command's `gesture`) changes between consecutive observations
    `shown`, all in one image -> domain `transform` (thesis ch. 5, gesture sequences)."""
    out: list[tuple[int, GestureCommand]] = []
    last = None
    for i, o in enumerate(shown):
        cmd = build_command(o, transform, n_agents, controller, seq=len(out) + 1)
        if cmd.gesture != last:
            out.append((i, cmd))
            last = cmd.gesture
    return out


def initial_setup(
    mask: np.ndarray, transform: ImageToDomain, command: GestureCommand, n_agents: int, controller: Controller
) -> Setup:
    """SPH parameters and the initial swarm: a compact lattice at the silhouette's most interior point (fill)
    or at the command's common first waypoint (palm / torso centre), each particle in its class."""
    fill = controller is Controller.FILL
    params = imitation_params(domain_for(mask, transform), controller)
    if fill:
        centre = np.array(transform.to_domain(np.array(centre_px(mask)) + 0.5))
    else:
        first = command.classes[0].route[0]
        centre = np.array([first.x, first.y])
    columns = max(1, int(round(np.sqrt(n_agents))))
    pos = lattice(n_agents, columns, FILL_SPACING if fill else 1.0)
    pos += centre - pos.mean(axis=0)
    states = np.array([initial_state(x, y, 0.0, 0.0, params) for x, y in pos])
    controls = [Control(beta=command.beta, mu=command.mu) for _ in range(n_agents)]
    shares = [c.share for c in command.classes]
    classes = np.array([class_of(i, n_agents, shares) for i in range(n_agents)])
    return Setup(np.arange(n_agents), states, controls, classes, tuple(c.name for c in command.classes), params)


def imitation_for(
    shown: Sequence[Observation],
    n_agents: int,
    controller: str = DEFAULT_CONTROLLER,
    transform: ImageToDomain | None = None,
) -> Imitation:
    """The imitation of the observations `shown` (one frame, or a gesture sequence): the one function from
    what was observed to (set-up, commands), used by the coordinator process for a file and a camera, by
    `reproduce` and by the tests. Pure: observations in, an Imitation out.

    The first observation fixes the image -> domain map (default: silhouette area = what n_agents particles
    cover, transform_for) and the swarm's start; the commands follow the observations (commands_along); the
    target is the last observation's silhouette, in the first one's map."""
    if not shown:
        raise ValueError("no observation to imitate")
    kind = controller_of(controller)
    first, last = shown[0], shown[-1]
    transform = transform or transform_for(first.mask, n_agents, kind)
    commands = commands_along(shown, transform, n_agents, kind)
    setup = initial_setup(first.mask, transform, commands[0][1], n_agents, kind)
    return Imitation(last.mask, transform, commands, setup, last)


def prepare(frame_bgr: np.ndarray, n_agents: int, controller: str = DEFAULT_CONTROLLER) -> Imitation:
    """A hand photograph -> its imitation."""
    mask = hand_mask(frame_bgr)
    return imitation_for([Observation("hand", mask, hand_label(mask), frame_bgr)], n_agents, controller)


def observations_for(path, frame: int | None = None):
    """(all frames, their observations, the index of the frame to imitate)."""
    frames = load_frames(path)
    if frame is not None and not 0 <= frame < len(frames):
        raise InputError(f"{path}: --frame {frame} out of range (the input has {len(frames)} frames)")
    if frame is not None and len(frames) > 1 and not is_clip(path, frames):
        frames = [frames[frame]]  # a folder of hand photographs: just the one
        frame = 0
    return frames, observe(path, frames), (frame or 0)


def imitation_of_input(path, n_agents: int, controller: str = DEFAULT_CONTROLLER, frame: int | None = 0) -> Imitation:
    """An image, folder or clip -> the imitation of its frame `frame` (default the first), or with frame None
    of all its frames as a gesture sequence (thesis ch. 5): imitation_for on what perception observed."""
    _frames, obs, k = observations_for(path, frame)
    return imitation_for(obs if frame is None else [obs[k]], n_agents, controller)
