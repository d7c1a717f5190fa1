"""What the coordinator observes: one target silhouette per frame, its parts and the recognised gesture.

A hand photograph (or a folder of them, a gesture sequence) -> `perception.segmentation.hand_mask`.
A clip with a static camera (video file or Weizmann strip) -> `perception.segmentation.person_regions`:
the whole person's silhouette with its torso (head and legs included), left and right arm.

`label` is what was recognised (the body pose from the arm ellipses, or the hand's silhouette shape from
the skeleton features): the coordinator publishes a new command when it changes between frames.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from perception.ellipses import fit_ellipse
from perception.io import is_clip
from perception.segmentation import PersonRegions, hand_mask, person_regions
from perception.skeleton import NAMES, feature_vector


@dataclass
class Observation:
    kind: str  # "hand" | "body"
    mask: np.ndarray  # bool (rows, cols): the target silhouette
    label: str  # the recognised gesture / pose
    frame: np.ndarray | None = None  # the BGR picture (for the eigen classifier and the recording)
    parts: dict = field(default_factory=dict)  # body: {"torso", "left_arm", "right_arm"} bool masks (or absent)
    index: int = 0


SIDE_MAX_DEG = 35.0  # an arm ellipse within this of horizontal is held sideways (labelled wave2: <= 31)


def arm_pose(arm: np.ndarray | None, head_row: float) -> str:
    """'side' | 'up' | 'down' for an arm mask: sideways if its ellipse lies within SIDE_MAX_DEG of horizontal,
    else up if the arm reaches above head_row (the head's centre row), else down. No arm: down (an arm that
    does not leave the torso's outline hangs along it)."""
    if arm is None or not arm.any():
        return "down"

    e = fit_ellipse(arm)
    if e is not None and min(e.orientation_deg, 180 - e.orientation_deg) <= SIDE_MAX_DEG:
        return "side"
    return "up" if np.flatnonzero(arm.any(axis=1))[0] < head_row else "down"


def body_label(parts: dict, head_row: float | None = None) -> str:
    """The pose from both arms (arm_pose); head_row defaults to a sixth of the torso's height (head and
    legs included) below its top."""
    torso = parts.get("torso")
    if torso is None or not torso.any():
        return "body"
    if head_row is None:
        rows = np.flatnonzero(torso.any(axis=1))
        head_row = rows[0] + (rows[-1] - rows[0]) / 6
    return f"left_{arm_pose(parts.get('left_arm'), head_row)}-right_{arm_pose(parts.get('right_arm'), head_row)}"


def hand_label(mask: np.ndarray) -> str:
    try:
        fv = feature_vector(mask)
    except Exception:  # noqa: BLE001  # a silhouette the skeleton cannot read is still a gesture
        return "hand"
    on = [n for n, v in zip(NAMES[:5], fv[:5]) if v]
    return "+".join(on) or "blob"


def body_observation(frame: np.ndarray, r: PersonRegions, index: int = 0) -> Observation:
    """A person's Observation from one frame's regions (a clip's `person_regions` or one frame's
    `perception.selfie.person_in_frame`): the head counts with the torso, the pose from the arms."""
    head_row = float(np.nonzero(r.head)[0].mean()) if r.head is not None else None
    torso = None
    if r.torso is not None or r.head is not None:
        torso = np.zeros(r.silhouette.shape, bool)
        for m in (r.torso, r.head):
            if m is not None:
                torso |= m
    parts = {
        k: v
        for k, v in (("torso", torso), ("left_arm", r.left_arm), ("right_arm", r.right_arm))
        if v is not None and v.any()
    }
    return Observation("body", r.silhouette.astype(bool), body_label(parts, head_row), frame, parts, index)


def observe(path: str | Path, frames: list[np.ndarray]) -> list[Observation]:
    """One Observation per frame. Raises perception's InputError / SegmentationError."""
    if is_clip(path, frames):
        return [body_observation(f, r, i) for i, (f, r) in enumerate(zip(frames, person_regions(frames)))]

    out = []
    for i, f in enumerate(frames):
        m = hand_mask(f)
        out.append(Observation("hand", m, hand_label(m), f, {}, i))
    return out
