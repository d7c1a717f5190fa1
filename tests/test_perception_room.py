"""Hands and persons in an ordinary room (issue 50): the shipped MediaPipe models (perception/models.py),
the GrabCut silhouette from the landmarks, `find_hand`'s learned reading behind its plain one, the person
from one frame; real shared photographs and Weizmann frames pasted into 640 x 480 backgrounds; bad input
(a missing or corrupt model file, a frame of the wrong kind) is one line."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from perception import composites as cm
from perception.dataset import is_test_file
from perception.eigen import default_model
from perception.features import to_work_size
from perception.hand import NoHandError, find_hand
from perception.hand_pose import load_poses, pose_classifier
from perception.io import load_frames, load_image
from perception.landmarks import FINGERS, find_landmarks
from perception.segmentation import NoPersonError, hand_mask, person_regions
from perception.selfie import person_in_frame, person_silhouette


@pytest.fixture(scope="module")
def clf():
    return default_model()


def held_out(shared_hands, cls: int, k: int = 0) -> np.ndarray:
    """The k-th photograph of class `cls` in the documented split's test part, at the set's 100 px."""
    files = sorted(p for p in (shared_hands / str(cls)).iterdir() if is_test_file(p.name))
    return to_work_size(load_image(files[k]))


def iou(a: np.ndarray, b: np.ndarray) -> float:
    """Mask IoU; `b` a pasted hand's true mask: both above its lowest row (a hand on a drawn forearm is scored
    above its wrist line, as bench-perception does; a hand whose wrist is on the bottom edge, all of it)."""
    rows = cm.scored_rows(b)
    a, b = a[rows], b[rows]
    return float((a & b).sum() / max((a | b).sum(), 1))


def composite(photo: np.ndarray, family: str, seed: int, forearm: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """A held-out photograph's hand in a room (`forearm` False: a palm the photograph cut set on the bottom edge,
    as a hand whose wrist is below the frame: the composites before issue 50 session 11)."""
    rng = np.random.default_rng(seed)
    frame, truth = cm.paste_hand(cm.background_maker(family)(rng), photo, hand_mask(photo), rng, forearm)
    return cm.degrade(frame, rng, 0.5), truth


def test_the_landmarks_of_a_raised_five_lie_on_its_fingers(shared_hands):
    photo = held_out(shared_hands, 5)
    frame, truth = composite(photo, "plain", 3)
    hands = find_landmarks(frame)
    assert len(hands) == 1 and hands[0].presence > 0.9
    pts = hands[0].points
    inside = truth[np.clip(pts[:, 1].astype(int), 0, 479), np.clip(pts[:, 0].astype(int), 0, 639)]
    assert inside.mean() >= 0.9, inside  # MediaPipe's landmarks lie on the hand
    wrist_y = pts[0, 1]
    assert all(pts[f[-1], 1] < wrist_y - 0.5 * hands[0].palm_length() for f in FINGERS[1:])  # tips above the wrist


def test_a_small_hand_on_wood_is_found_in_the_bottom_corners_squares(shared_hands, monkeypatch):
    """A held-out 0 on wood: neither the whole frame nor the squares at its ends give a palm the landmark
    model confirms; the squares at the bottom corners (a hand raised into a camera's picture comes in from
    its bottom edge: a larger palm there) do, and its landmarks lie on the hand."""
    import perception.landmarks as lmk

    frame, truth = composite(held_out(shared_hands, 0), "wood", 30)
    views = lmk.palm_views(frame)
    assert [(x0, y0, v.shape[:2]) for x0, y0, v in views[3:]] == [(0, 120, (360, 360)), (280, 120, (360, 360))]
    hands = find_landmarks(frame)
    assert len(hands) == 1 and hands[0].presence >= 0.5
    pts = hands[0].points
    inside = truth[np.clip(pts[:, 1].astype(int), 0, 479), np.clip(pts[:, 0].astype(int), 0, 639)]
    assert inside.mean() >= 0.8, inside
    monkeypatch.setattr(lmk, "palm_views", lambda image: views[:3])  # the views before issue 50's session 3
    monkeypatch.setattr(lmk, "bottom_boxes", lambda h, w: [])  # and without the landmark model's own squares
    assert find_landmarks(frame) == []


def test_a_hand_no_palm_view_finds_is_read_in_the_bottom_boxes(shared_hands, clf, monkeypatch):
    """A held-out 7 on stripes: no palm view holds a palm the landmark model confirms; the landmark model run
    on the upright squares along the bottom edge (`bottom_boxes`) finds it, its landmarks on the hand. Found
    without a palm, its class must be steady in the rereadings even where the two classifiers agree: it is
    in the mirrored and the smaller crop (hand_detector.STEADY_SCALES), so it is read as a 7; the larger
    crop, which reaches further past the bottom edge, would have refused it. A hand-free stripes frame gives
    no hand there."""
    import perception.hand_detector as hd
    import perception.landmarks as lmk

    frame, truth = composite(held_out(shared_hands, 7), "stripes", 52, forearm=False)  # its wrist below the frame
    boxes = lmk.bottom_boxes(480, 640)
    assert len(boxes) == 18 and all(b[1] + b[2] / 2 > 480 for b in boxes)  # each reaches below the edge
    hands = find_landmarks(frame)
    assert len(hands) == 1 and hands[0].palm_score == 0.0  # no palm: found by a bottom box
    pts = hands[0].points
    inside = truth[np.clip(pts[:, 1].astype(int), 0, 479), np.clip(pts[:, 0].astype(int), 0, 639)]
    assert inside.mean() >= 0.9, inside
    hand = find_hand(frame, clf)
    assert hand.label == "7" and np.logical_and(hand.mask, truth).sum() / np.logical_or(hand.mask, truth).sum() > 0.7
    monkeypatch.setattr(hd, "STEADY_SCALES", lmk.REREAD_SCALES)
    with pytest.raises(NoHandError, match="no palm found\\) are not steady \\(class 7\\)"):
        find_hand(frame, clf)
    monkeypatch.setattr(lmk, "bottom_boxes", lambda h, w: [])
    assert find_landmarks(frame) == []
    with pytest.raises(NoHandError, match="the hand detector sees no hand"):
        find_hand(frame, clf)
    monkeypatch.undo()
    empty = cm.degrade(cm.background_maker("stripes")(np.random.default_rng(52)), np.random.default_rng(53), 0.5)
    assert find_landmarks(empty) == []


def test_hands_in_front_of_clutter_are_found_with_their_silhouettes_and_classes(shared_hands, clf):
    """12 composites (three cluttered families, four held-out photographs): the plain reading refuses every
    one, as before; the learned one finds some, cuts them out and names them right (bench-perception: the
    figures over 140)."""
    found, ious, right = 0, [], 0
    for family in ("skin", "stripes", "noise"):
        for cls in (0, 1, 2, 5):
            frame, truth = composite(held_out(shared_hands, cls), family, cls)
            with pytest.raises(NoHandError, match="^no hand found: "):
                find_hand(frame, clf, learned=False)
            try:
                hand = find_hand(frame, clf)
            except NoHandError:
                continue
            assert hand.mask.shape == frame.shape[:2]
            found += 1
            ious.append(iou(hand.mask, truth))
            right += hand.label == str(cls)
    print(f"found {found} of 12, named right {right}, mask IoU {np.mean(ious):.3f}")
    # measured: 6 found (a 5 on stripes by its steady landmarks; the others refused: no hand seen, or the
    # landmarks and the silhouette name different classes), 6 right, IoU 0.84; issue 50 wants 90 % found.
    # Session 11 (palm-cut photographs on a drawn forearm, scored above its wrist line): 9 found, 9 right, 0.814
    assert found >= 4, found
    assert np.mean(ious) >= 0.8, ious  # issue 50: mask IoU >= 0.80
    assert right >= found - 1, (right, found)


def test_a_disagreement_is_the_landmarks_class_only_when_it_is_steady(shared_hands, clf, monkeypatch):
    """Where the silhouette's classifier and the landmarks' name different classes, the landmarks' class is
    the hand's when every rereading in another crop (mirrored, smaller, larger box) gives it with all votes
    and its landmarks barely move: a held-out 4 and a 5 on noise are found and named right, and refused
    without the rereadings. A held-out 1 on a skin wall whose landmarks say 2 is still refused (its
    rereadings say otherwise), and so would be a held-out 2 on noise whose rereadings all say 2 but whose
    landmarks move (fitted to a smaller hand than the one shown: its silhouette's IoU is 0.40): the full landmark
    model names it a 2 since session 12."""
    import perception.hand_detector as hd

    steady = hd.steady_pose
    for cls, family, seed in ((4, "noise", 41), (5, "noise", 40)):
        frame, truth = composite(held_out(shared_hands, cls), family, seed)
        hand = find_hand(frame, clf)
        assert hand.label == str(cls)
        assert iou(hand.mask, truth) >= 0.7  # measured 0.74 and 0.79: the silhouette GrabCut cut, as before
        monkeypatch.setattr(hd, "steady_pose", lambda *a, **k: False)
        monkeypatch.setattr(hd, "full_pose", lambda *a: None)  # session 12's reading, below
        with pytest.raises(NoHandError, match=f"two readings differ \\(silhouette: [^{cls}], landmarks: {cls}\\)"):
            find_hand(frame, clf)
        monkeypatch.undo()
    poses = hd.poses_for(clf)
    # these two photographs are cut through the palm: set on the bottom edge, their wrists below the frame
    frame, _ = composite(held_out(shared_hands, 1), "skin", 1, forearm=False)
    with pytest.raises(NoHandError, match="two readings differ \\(silhouette: 1, landmarks: 2\\)"):
        find_hand(frame, clf)
    frame, _ = composite(held_out(shared_hands, 2), "noise", 2, forearm=False)
    lm = find_landmarks(frame)[0]
    again = hd.rereadings(frame, lm.points)
    assert [poses.predict(a.points) for a in again] == [("2", 1.0)] * 3
    moved = np.mean([np.linalg.norm(a.points - lm.points, axis=1).mean() for a in again]) / lm.palm_length()
    assert moved > hd.STEADY_MOVE, moved
    assert not steady(frame, lm, poses, "2")
    # not steady, so refused by the lite landmarks' rules; the full landmark model reads it a 2 (full_pose, below)
    assert find_hand(frame, clf).label == "2"
    monkeypatch.setattr(hd, "full_pose", lambda *a: None)
    with pytest.raises(NoHandError, match="two readings differ \\(silhouette: 6, landmarks: 2\\)"):
        find_hand(frame, clf)


def test_a_disagreement_the_full_landmark_model_reads_steadily_is_its_class(shared_hands, clf, monkeypatch):
    """Where the two classifiers disagree and the lite landmarks are not steady, MediaPipe's full landmark
    model reads the hand in the tracking box, mirrored and in the 0.85 crop: when all three find it and all
    their nearest training hands vote for one class, that is the hand's (issue 50 session 12). Held-out 6, 2
    and 4 on noise, refused before, are named right; a held-out 1 on noise whose full readings do not agree
    stays refused; hand-free rooms stay hand-free (test_rooms_without_a_hand_are_never_a_hand)."""
    import perception.hand_detector as hd
    from perception.landmarks import FULL_LANDMARK_MODEL, landmark_box, landmarks_in

    poses = hd.poses_for(clf)
    full_pose = hd.full_pose
    for cls, seed in ((6, 1), (2, 3), (4, 3)):
        frame, truth = composite(held_out(shared_hands, cls), "noise", seed)
        hand = find_hand(frame, clf)
        assert hand.label == str(cls) and iou(hand.mask, truth) >= 0.5
        lm = find_landmarks(frame)[0]
        assert full_pose(frame, lm, poses) == str(cls)
        # the full model's own reading in the tracking box: the hand, all votes for its class
        full = landmarks_in(frame, landmark_box(lm.points), model=FULL_LANDMARK_MODEL)
        assert full.presence >= hd.PRESENCE and poses.predict(full.points) == (str(cls), 1.0)
        monkeypatch.setattr(hd, "full_pose", lambda *a: None)
        with pytest.raises(NoHandError, match="two readings differ"):
            find_hand(frame, clf)
        monkeypatch.undo()
    frame, _ = composite(held_out(shared_hands, 1), "noise", 1)
    assert full_pose(frame, find_landmarks(frame)[0], poses) is None
    with pytest.raises(NoHandError, match="two readings differ \\(silhouette: 1, landmarks: 2\\)"):
        find_hand(frame, clf)


def test_an_agreement_that_does_not_hold_mirrored_is_refused(shared_hands, clf, monkeypatch):
    """Both classifiers can be wrong together: a held-out 8 on noise is read as a 9 by the silhouette's and
    by the landmarks' classifier (the thumb taken to touch the index finger, not the middle one). Read again
    in its mirrored crop, its landmarks name another class: no hand (the swarm keeps its command), where
    without that check it was a 9. A held-out 8 on wood read as a 9 likewise."""
    import perception.hand_detector as hd

    for family, k, seed in (("noise", 0, 22), ("wood", 0, 5)):
        frame, _ = composite(held_out(shared_hands, 8, k), family, seed)
        with pytest.raises(NoHandError, match="name another class when read mirrored \\(class 9\\)"):
            find_hand(frame, clf)
        monkeypatch.setattr(hd, "MIRROR_BELOW", 0.0)
        assert find_hand(frame, clf).label == "9"
        monkeypatch.undo()


DRIFTS = (  # gain, gamma, white balance (B, G, R gains)
    (1.0, 1.0, (1.0, 1.0, 1.0)),
    (0.6, 1.0, (1.0, 1.0, 1.0)),
    (1.3, 0.8, (1.0, 1.0, 1.0)),
    (1.0, 1.4, (1.1, 1.0, 0.9)),
    (0.8, 1.0, (0.9, 1.0, 1.12)),
    (0.7, 1.2, (1.0, 0.95, 1.05)),
)


def drifted(frame: np.ndarray, gain: float, gamma: float, balance: tuple[float, float, float]) -> np.ndarray:
    return np.clip(255 * ((frame / 255.0 * gain * np.array(balance)) ** gamma), 0, 255).astype(np.uint8)


def test_light_drift_never_changes_the_class(shared_hands, clf):
    """Brightness, gamma and white balance drifting over a held hand (8 hands, 6 lights each): a frame where it
    is not found commands nothing (the swarm keeps its command); where it is found, it is its usual class but in
    at most two frames. Before the landmarks' classifier had to agree with the silhouette's, a small hand whose
    landmarks the skin-coloured wall confused was named 7, 1 or 8 as the light changed (28 of 35 frames at the
    usual class)."""
    steady, seen = 0, 0  # frames
    for family in ("skin", "stripes"):
        for cls in (0, 1, 2, 5):
            frame, _ = composite(held_out(shared_hands, cls), family, 20 + cls)
            labels = []
            for drift in DRIFTS:
                try:
                    labels.append(find_hand(drifted(frame, *drift), clf).label)
                except NoHandError as exc:
                    assert "the hand detector" in str(exc)
            if labels:
                seen += len(labels)
                steady += max(labels.count(x) for x in labels)  # frames showing the hand's usual class
    print(f"frames found {seen} of 48, at their hand's usual class {steady}")
    # measured: 24 found, 22 at the usual class (a 2 on the skin wall named 1 in one light, on the stripes 6:
    # both readings agreed, fully confident); the landmarks by OpenCV's DNN module: 25 found, all usual
    assert seen >= 20 and steady >= seen - 2, (steady, seen)


def test_rooms_without_a_hand_are_never_a_hand(clf):
    rng = np.random.default_rng(11)
    for family in ("skin", "wood", "stripes", "noise", "plain"):
        for _ in range(2):
            frame = cm.degrade(cm.background_maker(family)(rng), rng)
            with pytest.raises(NoHandError, match="^no hand found: .*the hand detector sees no hand"):
                find_hand(frame, clf)


def test_a_person_is_found_from_one_frame_in_front_of_clutter(weizmann):
    frames = load_frames(weizmann / "wave2" / "person1.png")
    only = [5, 25, 45]
    regions = person_regions(frames, only=only)
    rng = np.random.default_rng(5)
    ious = []
    for k, r in zip(only, regions, strict=True):
        for family in ("stripes", "skin", "wood"):
            frame, truth = cm.paste_person(cm.background_maker(family)(rng), frames[k], r.silhouette, rng)
            ious.append(iou(person_silhouette(cm.degrade(frame, rng, 0.5)), truth))
    assert np.mean(ious) >= 0.8 and min(ious) >= 0.5, ious
    with pytest.raises(NoPersonError, match="^no person found: "):
        person_silhouette(cm.background_maker("noise")(rng))


def test_a_frame_of_the_wrong_kind_is_one_line(shared_hands, clf):
    frame, _ = composite(held_out(shared_hands, 5), "skin", 1)
    for bad, why in (
        (frame.astype(np.uint16) * 256, "uint16"),
        (frame[:20, :20], "too small"),
        (frame[..., :2], "no picture"),
        (np.zeros((0, 0, 3), np.uint8), "empty"),
    ):
        with pytest.raises(NoHandError) as exc:
            find_hand(bad, clf)
        assert why in str(exc.value) and "\n" not in str(exc.value)
    grey = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)  # one channel: a grey camera's frame is read as such
    assert find_hand(grey, clf).mask.shape == grey.shape


def test_the_landmarks_classifier_names_held_out_hands(shared_hands):
    """perception/hand_pose.py on the documented split: trained on the training photographs' landmarks,
    tested on the others' (measured 0.992 ten classes, 1.000 five); and on a fresh reading of one photo."""
    points, labels, files = load_poses()
    test = np.array([is_test_file(f) for f in files])
    train = pose_classifier(files=lambda name: not is_test_file(name))
    right = [train.predict(p)[0] == y for p, y in zip(points[test], labels[test], strict=True)]
    # measured 395 of 399 (0.990; the landmarks read by LiteRT; by OpenCV's DNN module 396)
    assert len(right) >= 395 and np.mean(right) >= 0.985, (len(right), np.mean(right))
    five = np.isin(labels[test], list("01245"))
    right5 = [
        train.only("01245").predict(p)[0] == y for p, y in zip(points[test][five], labels[test][five], strict=True)
    ]
    assert np.mean(right5) >= 0.995, np.mean(right5)
    frame, _ = composite(held_out(shared_hands, 4), "plain", 2)
    assert train.predict(find_landmarks(frame)[0].points)[0] == "4"


def test_a_persons_arm_pose_is_read_from_one_frame_in_front_of_clutter(weizmann):
    """The labelled wave2 frames (perception/data/weizmann_wave2_labels.json: both arms sideways, or both
    up), each person cut out by the clip's own reading and pasted into one of three rooms in turn;
    `person_in_frame` reads silhouette and arms from that one frame, coordinator's body_label names the pose
    (the clip's reading on the plain wall: 56 of 59)."""
    from coordinator.control.observe import body_label

    labels = json.loads((Path(cm.__file__).parent / "data" / "weizmann_wave2_labels.json").read_text())["frames"]
    want = {"sideways": "left_side-right_side", "up": "left_up-right_up"}
    rng = np.random.default_rng(3)
    right = total = 0
    rooms = ("stripes", "skin", "wood")
    for person, poses in labels.items():
        frames = load_frames(weizmann / "wave2" / f"{person}.png")
        wanted = sorted(i for indices in poses.values() for i in indices)
        regions = dict(zip(wanted, person_regions(frames, only=wanted), strict=True))
        for pose, indices in poses.items():
            for i in indices:
                family = rooms[total % len(rooms)]  # each frame in one room, the rooms in turn
                frame, _ = cm.paste_person(cm.background_maker(family)(rng), frames[i], regions[i].silhouette, rng)
                total += 1
                try:
                    r = person_in_frame(cm.degrade(frame, rng, 0.5))
                except NoPersonError:
                    continue
                torso = np.zeros(r.silhouette.shape, bool)
                for m in (r.torso, r.head):
                    if m is not None:
                        torso |= m
                parts = {"torso": torso, "left_arm": r.left_arm, "right_arm": r.right_arm}
                parts = {k: v for k, v in parts.items() if v is not None and v.any()}
                head_row = float(np.nonzero(r.head)[0].mean()) if r.head is not None else None
                right += body_label(parts, head_row) == want[pose]
    print(f"poses read right {right} of {total}")
    # measured 48 of 59 (each frame in all three rooms, 3 x the time: 151 of 177)
    assert total == 59 and right >= 0.8 * total, (right, total)


def test_perceive_reads_a_cluttered_photo_with_the_learned_reading(shared_hands, tmp_path):
    """`fluidswarm perceive` on a photograph of a hand in a room: the learned reading's silhouette and class
    (before issue 50's wiring: hand_mask's segmentation of the wall); a shared photograph: as before."""
    from perception.perceive import perceive_hand

    frame, truth = composite(held_out(shared_hands, 5), "skin", 1)
    path = tmp_path / "room.png"
    cv2.imwrite(str(path), frame)
    lines, picture = perceive_hand(path)
    assert "reading=learned" in lines[0] and lines[1].startswith("class=5 "), lines[:2]
    small = cv2.resize(truth.astype(np.uint8), (400, 300), interpolation=cv2.INTER_NEAREST).astype(bool)
    area = int(lines[0].split("silhouette_area=")[1].split()[0])
    assert abs(area - small.sum()) < 0.2 * small.sum(), (area, small.sum())  # perceive works at 400 px at most
    assert picture.shape[:2] == (300, 400)
    files = sorted(p for p in (shared_hands / "5").iterdir() if is_test_file(p.name))
    lines, _ = perceive_hand(files[0])
    assert "reading=plain" in lines[0] and lines[1].startswith("class=5 "), lines[:2]
