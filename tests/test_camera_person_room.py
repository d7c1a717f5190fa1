"""`imitate --camera --subject person` in a room that does not stand still (issue 50): when the last frames
cannot be read as a static camera's clip (the camera pans, the room changes), the newest frame is read
alone (perception/selfie.py `person_in_frame`); a static camera's clip is read by background subtraction
as before. Real frames: the shared wave2 person pasted into rooms the camera pans across."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from coordinator.camera import LiveObserver
from perception import composites as cm
from perception.io import load_frames
from perception.segmentation import person_regions

REPO = Path(__file__).resolve().parents[1]
WAVE2 = REPO / "scenarios" / "inputs" / "weizmann_wave2_person0.png"  # = shared weizmann-actions-64/wave2/person0.png
SIDEWAYS = (14, 15, 16, 17, 18, 19)  # wave2 person 0: both arms held sideways in these frames


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


def panning_clip(family: str, seed: int, indices) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The person of each wave2 frame pasted at one place (the camera follows them) into a room that slides
    past by 24 px a frame (a panning camera), each frame through a webcam's degradations."""
    frames = load_frames(WAVE2)
    regions = person_regions(frames, only=list(indices))
    rng = np.random.default_rng(seed)
    room = cm.background_maker(family)(rng)
    wide = np.concatenate([room, room[:, ::-1]], axis=1)
    clip, truths = [], []
    for k, (i, r) in enumerate(zip(indices, regions, strict=True)):
        bg = np.ascontiguousarray(wide[:, 24 * k : 24 * k + cm.W])
        frame, truth = cm.paste_person(bg, frames[i], r.silhouette, np.random.default_rng(seed))
        clip.append(cm.degrade(frame, rng, 0.5))
        truths.append(truth)
    return clip, truths


def test_a_person_in_front_of_a_panning_room_is_read_from_each_frame():
    for family, seed in (("stripes", 1), ("wood", 2)):
        clip, truths = panning_clip(family, seed, SIDEWAYS)
        observer = LiveObserver(window=6)
        seen = []
        for frame, truth in zip(clip, truths, strict=True):
            obs = observer.observe(frame)
            if obs is None:
                continue
            assert obs.kind == "body"
            seen.append((observer.reading, iou(obs.mask, truth), obs.label))
        print(family, seen)
        # the first two frames make no clip yet; of the other four, background subtraction alone took the
        # room's motion for the person in 2 (stripes) and 3 (wood), at IoU 0.00-0.23 (before the fallback);
        # measured now: 7 of 8 read from the frame alone (the eighth, by the clip, right: IoU 0.95), IoU
        # 0.85-0.95, 7 of 8 both arms sideways
        assert len(seen) == len(clip) - 2, seen
        assert sum(reading == "frame" for reading, _, _ in seen) >= 3, seen
        assert min(s[1] for s in seen) >= 0.7, seen
        assert sum(label == "left_side-right_side" for _, _, label in seen) >= len(seen) - 1, seen


def test_an_empty_panning_room_is_nobody_with_both_reasons():
    rng = np.random.default_rng(7)
    room = cm.background_maker("noise")(rng)
    wide = np.concatenate([room, room[:, ::-1]], axis=1)
    observer = LiveObserver(window=6)
    for k in range(4):
        assert observer.observe(cm.degrade(np.ascontiguousarray(wide[:, 24 * k : 24 * k + cm.W]), rng, 0.5)) is None
    assert observer.missing is not None
    assert observer.missing.startswith("no person found: ")
    assert "the person segmentation sees nobody in the frame" in observer.missing, observer.missing


def test_a_static_cameras_clip_is_still_read_by_background_subtraction():
    frames = load_frames(WAVE2)[10:20]
    observer = LiveObserver(window=6)
    out = [observer.observe(f) for f in frames]
    assert all(o is not None for o in out[2:]) and observer.reading == "clip"
