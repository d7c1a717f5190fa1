"""PCA controller (thesis ch. 4-5): the recognised class -> that class' parameter template.

The hand classifier (`perception.eigen.default_model`: the `best` method, HOG + PCA + RBF SVM; the thesis'
eigen-images are `--method eigen`) recognises the hand's class; a person clip's pose is recognised from the arm
regions (`coordinator.control.observe.body_label`). Each class maps to one of the thesis' preshapes or body
poses, a fixed template of particle classes and routes written in a normalised frame and placed on the observed
hand/body:

- hand frame: origin the palm centre, unit the palm's inscribed radius R, "up" pointing away from the
  wrist (towards the finger tips);
- body frame: origin the torso centre, unit half the torso's height, up = picture up.

A template class: (name, share, [(side, up) waypoints], radius of the last waypoint, beta at the first
finger/arm waypoint or None). Fingers switch to beta 50, arms to 20 (thesis §6.3.2 branching).
"""

from __future__ import annotations

import math

import numpy as np

from agent.protocol.command import GestureCommand, ParticleClass, Waypoint
from coordinator.control.geometry import ImageToDomain
from coordinator.control.material import BETA, MU
from perception.eigen import default_model
from perception.ellipses import hand_regions

F, A = 50.0, 20.0  # stiffness of fingers and arms after the critical point
PALM = ("palm", 0.4, [(0.0, 0.0)], 1.1, None)

HAND_TEMPLATES = {
    "horizontal_pointing": [PALM, ("finger", 0.6, [(0.0, 1.4), (0.0, 2.4), (0.0, 3.2)], 0.9, F)],
    "pointing_at_angle": [PALM, ("finger", 0.6, [(0.0, 1.4), (0.0, 2.4), (0.0, 3.2)], 0.9, F)],
    "v_separation": [
        PALM,
        ("finger_left", 0.3, [(-0.3, 1.4), (-0.9, 2.4), (-1.3, 3.2)], 0.8, F),
        ("finger_right", 0.3, [(0.3, 1.4), (0.9, 2.4), (1.3, 3.2)], 0.8, F),
    ],
    "pinching": [
        PALM,
        ("thumb", 0.2, [(-1.0, 1.0), (-1.2, 2.0)], 0.8, F),
        ("index", 0.2, [(-0.2, 1.4), (-0.8, 2.4)], 0.8, F),
        ("fingers", 0.2, [(0.6, 1.4), (1.0, 2.6)], 0.9, F),
    ],
    "cylindrical_hook": [
        PALM,
        ("hook_left", 0.2, [(-1.0, 1.0), (-1.1, 2.0)], 0.8, F),
        ("hook_top", 0.2, [(0.0, 1.4), (0.0, 2.4)], 0.8, F),
        ("hook_right", 0.2, [(1.0, 1.0), (1.1, 2.0)], 0.8, F),
    ],
    "open_hand": [PALM]
    + [
        (f"finger{i}", 0.12, [(0.5 * x, 1.4), (1.1 * x, 2.8)], 0.8, F)
        for i, x in enumerate((-1.4, -0.7, 0.0, 0.7, 1.4))
    ],
}

# sign-language digit -> preshape (0: fingers curled round an O; 1: one finger; 2: V; 3-5: spread fingers;
# 6-9: the thumb touching one finger).
DIGIT_TEMPLATE = {
    "0": "cylindrical_hook",
    "1": "pointing_at_angle",
    "2": "v_separation",
    "3": "open_hand",
    "4": "open_hand",
    "5": "open_hand",
    "6": "pinching",
    "7": "pinching",
    "8": "pinching",
    "9": "pinching",
}

TORSO = ("torso", 0.45, [(0.0, 0.0)], 1.0, None)
HEAD = ("head", 0.1, [(0.0, 1.0), (0.0, 1.5)], 0.5, None)


def _arm(side: str, pose: str, share: float = 0.225):
    s = -1.0 if side == "left" else 1.0
    pts = {
        "side": [(s * 0.9, 0.6), (s * 2.2, 0.6), (s * 3.2, 0.6)],
        "up": [(s * 0.9, 0.8), (s * 1.2, 2.0), (s * 1.4, 3.0)],
        "down": [(s * 0.9, 0.4), (s * 1.3, -0.6), (s * 1.5, -1.4)],
    }[pose]
    return (f"{side}_arm", share, pts, 0.8, A)


BODY_TEMPLATES = {
    "arms_sideways": [TORSO, HEAD, _arm("left", "side"), _arm("right", "side")],
    "both_arms_up": [TORSO, HEAD, _arm("left", "up"), _arm("right", "up")],
    "one_arm_up": [TORSO, HEAD, _arm("left", "up"), _arm("right", "down")],
    "one_arm_down": [TORSO, HEAD, _arm("left", "down"), _arm("right", "side")],
    "arms_down": [TORSO, HEAD, _arm("left", "down"), _arm("right", "down")],
    "bending": [
        ("torso", 0.5, [(0.0, 0.0), (0.8, -0.3)], 1.0, None),
        ("head", 0.1, [(1.5, -0.5)], 0.5, None),
        ("left_arm", 0.2, [(1.2, -0.8), (1.6, -1.8)], 0.7, A),
        ("right_arm", 0.2, [(1.4, -0.8), (1.9, -1.8)], 0.7, A),
    ],
}


def body_template(label: str) -> str:
    """The body pose template for a pose label of `coordinator.control.observe.body_label` ("bending" has a template
    but is not recognised yet: the Weizmann torso region is too round to tell it apart)."""
    if label == "bending":
        return "bending"
    poses = {p.split("_", 1)[1] for p in label.split("-") if "_" in p}
    if poses == {"side"}:
        return "arms_sideways"
    if poses == {"up"}:
        return "both_arms_up"
    if "up" in poses:
        return "one_arm_up"
    if poses == {"down"}:
        return "arms_down"
    if "down" in poses:
        return "one_arm_down"
    return "arms_sideways"


def _hand_frame(mask: np.ndarray):
    """(palm centre (u, v) px, R px, unit 'up' vector in pixel coordinates (v grows down), finger angle)."""
    r = hand_regions(mask)
    px, py = r["critical_points"]["palm_centre"]
    radius = max(float(r["palm_radius"]), 1.0)
    tips = r["critical_points"]["finger_tips"]
    if tips:
        d = np.mean(np.array(tips) - [px, py], axis=0)
    else:
        d = {"bottom": (0, -1), "top": (0, 1), "left": (1, 0), "right": (-1, 0)}.get(r["wrist_side"], (0, -1))
    d = np.asarray(d, float)
    d /= max(np.linalg.norm(d), 1e-9)
    return (px, py), radius, d


def _place(template, origin_px, unit_px: float, up_px: np.ndarray, transform: ImageToDomain, alpha: float):
    side_px = np.array([-up_px[1], up_px[0]])  # perpendicular; with v down this is the picture's right for up=(0,-1)
    classes = []
    for name, share, pts, r_last, beta in template:
        wps = []
        for i, (a, b) in enumerate(pts):
            uv = np.asarray(origin_px) + unit_px * (a * side_px + b * up_px)
            x, y = transform.to_domain(uv)
            last = i == len(pts) - 1
            r = r_last * unit_px * transform.scale if last else max(1.2, 0.5 * unit_px * transform.scale)
            wps.append(
                Waypoint(
                    float(x),
                    float(y),
                    r=float(r),
                    s=2.0,
                    alpha=alpha,
                    beta=beta if (beta is not None and i == 0 and len(pts) > 1) else None,
                )
            )
        classes.append(ParticleClass(name, float(share), tuple(wps)))
    return tuple(classes)


def classify_hand(frame_bgr) -> str:
    return str(default_model().predict([frame_bgr])[0])


def pca_command(obs, transform: ImageToDomain, n_agents: int, seq: int = 1, alpha: float = 4.0) -> GestureCommand:
    if obs.kind == "body":
        torso = obs.parts.get("torso", obs.mask)
        ys, xs = np.nonzero(torso)
        origin = (float(xs.mean()), float(ys.mean()))
        unit = max(1.0, (np.ptp(ys) + 1) / 2.0)
        name = body_template(obs.label)
        classes = _place(BODY_TEMPLATES[name], origin, unit, np.array([0.0, -1.0]), transform, alpha)
        recognised = obs.label
    else:
        digit = classify_hand(obs.frame) if obs.frame is not None else "1"
        name = DIGIT_TEMPLATE.get(digit, "open_hand")
        origin, radius, up = _hand_frame(obs.mask)
        if name == "pointing_at_angle" and abs(up[1]) < math.sin(math.radians(30)):
            name = "horizontal_pointing"
        classes = _place(HAND_TEMPLATES[name], origin, radius, up, transform, alpha)
        recognised = f"digit{digit}"
    extra = {"controller": "pca", "template": name, "recognised": recognised}
    return GestureCommand(seq=seq, gesture=name, n_agents=int(n_agents), classes=classes, beta=BETA, mu=MU, extra=extra)
