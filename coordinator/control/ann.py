"""ANN controller (thesis ch. 3): the skeleton feature vector -> body-force command -> routes.

perception's network (`perception.ann.GestureANN`, 6 -> 5 tanh -> 2) maps the hand's 6-entry feature
vector (`perception.skeleton.feature_vector`) to [F_along, F_split]: the body force along the pointing
direction and the lateral force that divides the swarm into two branches. The command:

- a palm class (share 0.4) that gathers at the palm centre;
- F_split < SPLIT_MIN: one finger class pushed along the pointing direction (thesis §3.4.1);
  else two finger classes (share 0.3 each) whose routes leave the palm at ± atan(F_split / F_along)
  (thesis §3.4.3, separation of fingers);
- the gain alpha of the finger routes is ALPHA_PER_FORCE · F_along; at the first finger waypoint (the
  critical point) the finger classes switch to beta 50 (thesis branching).

The branch length is the observed finger length (farthest finger tip), else 3 palm radii. A person clip
has no hand skeleton: its arms are read the same way (torso centre, the two arms' directions).
"""

from __future__ import annotations

import math

import numpy as np

from agent.protocol.command import GestureCommand, ParticleClass, Waypoint
from coordinator.control.geometry import ImageToDomain
from coordinator.control.material import BETA, MU
from coordinator.control.pca import _hand_frame, pca_command
from perception.ann import GestureANN
from perception.ellipses import hand_regions
from perception.skeleton import feature_vector

SPLIT_MIN = 0.25
ALPHA_PER_FORCE = 2.0
BETA_FINGER = 50.0


def ann_force(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(feature vector (6,), [F_along, F_split])."""
    fv = feature_vector(mask)
    return fv, np.asarray(GestureANN.load()(fv), float)


def ann_command(obs, transform: ImageToDomain, n_agents: int, seq: int = 1) -> GestureCommand:
    if obs.kind == "body":  # no finger skeleton: fall back to the PCA template of the pose
        cmd = pca_command(obs, transform, n_agents, seq)
        return GestureCommand(
            seq=cmd.seq,
            gesture=cmd.gesture,
            n_agents=cmd.n_agents,
            classes=cmd.classes,
            beta=cmd.beta,
            mu=cmd.mu,
            extra={**cmd.extra, "controller": "ann(pose template)"},
        )
    fv, (f_along, f_split) = ann_force(obs.mask)
    (pu, pv), radius, up = _hand_frame(obs.mask)

    tips = hand_regions(obs.mask)["critical_points"]["finger_tips"]
    length = max([math.hypot(t[0] - pu, t[1] - pv) for t in tips] + [3.0 * radius])
    f_along = max(float(f_along), 0.2)
    alpha = float(np.clip(ALPHA_PER_FORCE * f_along, 0.5, 10.0))
    centre = transform.to_domain(np.array([pu, pv]))
    start_r = max(1.5, math.sqrt(n_agents / math.pi) + 0.5)
    palm = ParticleClass(
        "palm",
        0.4,
        (Waypoint(float(centre[0]), float(centre[1]), r=max(1.0, radius * transform.scale), s=2.0, alpha=alpha),),
    )
    angles = [0.0] if f_split < SPLIT_MIN else [-math.atan2(f_split, f_along), math.atan2(f_split, f_along)]
    names = ["finger"] if len(angles) == 1 else ["finger_left", "finger_right"]
    classes = [palm]
    for name, a in zip(names, angles):
        # rotate 'up' by a (on screen, positive = towards the picture's right when up is picture-up)
        d = np.array([up[0] * math.cos(a) - up[1] * math.sin(a), up[0] * math.sin(a) + up[1] * math.cos(a)])
        route = [Waypoint(float(centre[0]), float(centre[1]), r=start_r, s=2.0, alpha=alpha)]
        for frac, beta in ((0.55, BETA_FINGER), (0.85, None)):
            x, y = transform.to_domain(np.array([pu, pv]) + frac * length * d)
            last = frac == 0.85
            route.append(
                Waypoint(
                    float(x),
                    float(y),
                    r=(0.6 * radius * transform.scale if last else 1.2),
                    s=2.0,
                    alpha=alpha,
                    beta=beta,
                )
            )
        classes.append(ParticleClass(name, 0.6 / len(angles), tuple(route)))
    extra = {
        "controller": "ann",
        "features": [round(float(v), 4) for v in fv],
        "force": [round(float(f_along), 4), round(float(f_split), 4)],
    }
    return GestureCommand(
        seq=seq,
        gesture="two_branches" if len(angles) == 2 else "one_branch",
        n_agents=int(n_agents),
        classes=tuple(classes),
        beta=BETA,
        mu=MU,
        extra=extra,
    )
