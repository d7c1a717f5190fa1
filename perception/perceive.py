"""What `fluidswarm perceive` finds and draws, for a hand photograph and for a clip of a person.

Hand: silhouette, class and confidence (eigen classifier; a photograph the plain-background reading refuses
-- clutter, a room -- is read by the learned one, `find_hand`'s second: perception/hand_detector.py), palm and
finger ellipses, critical points
(first joints, finger tips, centre of mass), skeleton feature vector and the ANN's body-force command.
Clip: per-frame body ellipses (torso, head, arms) from `person_regions`, the Kalman-tracked bounding box,
a contact sheet of up to SHEET_FRAMES frames.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from perception.ann import GestureANN
from perception.eigen import EigenClassifier, default_model
from perception.ellipses import Ellipse, body_regions, hand_regions
from perception.features import to_work_size
from perception.hand import NoHandError, plain_hand
from perception.hand_detector import LearnedHand, learned_hand
from perception.io import load_frames, load_image
from perception.segmentation import hand_mask, person_regions
from perception.skeleton import feature_vector
from perception.tracking import track_boxes

SHEET_FRAMES = 12
COLOURS = {
    "torso": (0, 200, 0),
    "head": (0, 200, 200),
    "left_arm": (0, 0, 255),
    "right_arm": (255, 0, 0),
    "palm": (0, 200, 0),
    "finger": (255, 0, 255),
}


def _fmt(e: Ellipse | None) -> str:
    if e is None:
        return "none"
    return (
        f"l_major={e.l_major:.1f} l_minor={e.l_minor:.1f} orientation={e.orientation_deg:.1f} "
        f"x_c={e.x_c:.1f} y_c={e.y_c:.1f}"
    )


def _draw_ellipse(img: np.ndarray, e: Ellipse | None, colour, scale: float) -> None:
    if e is None:
        return
    (cx, cy), (a, b), ang = e.cv_box()
    cv2.ellipse(
        img,
        ((cx * scale + scale / 2, cy * scale + scale / 2), (max(a * scale, 1), max(b * scale, 1)), ang),
        colour,
        1,
        cv2.LINE_AA,
    )
    cv2.drawMarker(img, (int(cx * scale + scale / 2), int(cy * scale + scale / 2)), colour, cv2.MARKER_CROSS, 6, 1)


def _upscale(img: np.ndarray, target: int = 400) -> tuple[np.ndarray, float]:
    scale = max(1.0, target / max(img.shape[:2]))
    if scale == 1.0:
        return img.copy(), 1.0
    return cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST), scale


def _outline(img: np.ndarray, mask: np.ndarray, scale: float, colour=(0, 255, 255)) -> None:
    big = cv2.resize(mask.astype(np.uint8), (img.shape[1], img.shape[0]), interpolation=cv2.INTER_NEAREST)
    contours, _ = cv2.findContours(big, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    cv2.drawContours(img, contours, -1, colour, 1)


def perceive_hand(path: Path, model: str | None = None) -> tuple[list[str], np.ndarray]:
    img = load_image(path)
    if max(img.shape[:2]) > 400:  # work at a sane size; coordinates are reported in this picture's pixels
        f = 400 / max(img.shape[:2])
        img = cv2.resize(img, None, fx=f, fy=f, interpolation=cv2.INTER_AREA)
    clf = EigenClassifier.load(model) if model else default_model()
    found: LearnedHand | str | None = None
    try:
        plain_hand(img, clf)
    except NoHandError:  # not a plain, bright background (clutter, a room): the learned reading, if it finds one
        found = learned_hand(img, clf)
    if isinstance(found, LearnedHand):
        reading, mask, label, conf = "learned", found.mask, [found.label], [found.confidence]
    else:  # the shared photographs' kind, or nothing the learned reading takes for a hand: as it always was
        reading, mask = "plain", hand_mask(img)
        label, conf = clf.predict_features(clf.features([to_work_size(img)]))
    regions = hand_regions(mask)
    fv = feature_vector(mask)
    force = GestureANN.load()(fv)
    pts = regions["critical_points"]
    lines = [
        f"image={path} size={img.shape[1]}x{img.shape[0]} silhouette_area={int(mask.sum())} reading={reading}",
        f"class={label[0]} confidence={conf[0]:.2f}",
        f"palm {_fmt(regions['palm'])}",
    ]
    lines += [f"finger{i} {_fmt(e)}" for i, e in enumerate(regions["fingers"])]
    lines += [
        f"first_joints={[(round(x, 1), round(y, 1)) for x, y in pts['first_joints']]}",
        f"finger_tips={[(round(x, 1), round(y, 1)) for x, y in pts['finger_tips']]}",
        f"centre_of_mass=({pts['centre_of_mass'][0]:.1f}, {pts['centre_of_mass'][1]:.1f})",
        "feature_vector=[" + ", ".join(f"{v:.2f}" for v in fv) + "]",
        f"body_force F_along={force[0]:.2f} F_split={force[1]:.2f}",
    ]
    pic, s = _upscale(img)
    _outline(pic, mask, s)
    _draw_ellipse(pic, regions["palm"], COLOURS["palm"], s)
    for e in regions["fingers"]:
        _draw_ellipse(pic, e, COLOURS["finger"], s)
    for x, y in pts["first_joints"]:
        cv2.drawMarker(pic, (int(x * s), int(y * s)), (255, 0, 0), cv2.MARKER_STAR, 10, 2)
    for x, y in pts["finger_tips"]:
        cv2.drawMarker(pic, (int(x * s), int(y * s)), (0, 160, 0), cv2.MARKER_STAR, 10, 2)
    cx, cy = pts["centre_of_mass"]
    cv2.drawMarker(pic, (int(cx * s), int(cy * s)), (0, 0, 255), cv2.MARKER_STAR, 12, 2)
    cv2.putText(pic, f"class {label[0]} ({conf[0]:.2f})", (6, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (0, 0, 0), 3)
    cv2.putText(pic, f"class {label[0]} ({conf[0]:.2f})", (6, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (255, 255, 255), 1)
    return lines, pic


def perceive_clip(path: Path) -> tuple[list[str], np.ndarray]:
    frames = load_frames(path)
    if len(frames) < 3:
        raise ValueError(f"a clip needs at least 3 frames, got {len(frames)}")
    regions = person_regions(frames)
    tracked = track_boxes([r.bbox for r in regions])
    picks = np.unique(np.linspace(0, len(frames) - 1, min(SHEET_FRAMES, len(frames))).round().astype(int))
    lines = [f"clip={path} frames={len(frames)} size={frames[0].shape[1]}x{frames[0].shape[0]}"]
    tiles = []
    for i in picks:
        ells = body_regions(regions[i])
        box = tracked[i]
        lines.append(
            f"frame {i}: "
            + " | ".join(f"{k} {_fmt(e)}" for k, e in ells.items())
            + (f" | box x={box[0]:.1f} y={box[1]:.1f} w={box[2]:.1f} h={box[3]:.1f}" if box else " | box none")
        )
        tile, s = _upscale(frames[i], 256)
        if regions[i].silhouette.any():
            _outline(tile, regions[i].silhouette, s)
        for k, e in ells.items():
            _draw_ellipse(tile, e, COLOURS[k], s)
        if box:
            x, y, w, h = box
            cv2.rectangle(tile, (int(x * s), int(y * s)), (int((x + w) * s), int((y + h) * s)), (255, 255, 255), 1)
        cv2.putText(tile, f"{i}", (4, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1)
        tiles.append(tile)
    cols = min(4, len(tiles))
    while len(tiles) % cols:
        tiles.append(np.zeros_like(tiles[0]))
    sheet = np.vstack([np.hstack(tiles[r : r + cols]) for r in range(0, len(tiles), cols)])
    return lines, sheet
