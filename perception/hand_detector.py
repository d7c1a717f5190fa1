"""A hand in front of any background (a room, clutter, a skin-coloured wall): the learned reading of
`find_hand` (perception/hand.py), for the pictures its plain-background reading refuses.

MediaPipe's landmarks (perception/landmarks.py) say where the hand is and whether there is one (the palm
detector's score, and the landmark model's hand-presence score at MediaPipe's default); GrabCut seeded
by them cuts its silhouette (perception/hand_silhouette.py); the classifier, trained on the shared
photographs (a hand in front of a plain background), is given the silhouette in front of such a background
(`clean_crop`), and must place it within the hand space as before; the landmarks' own classifier
(perception/hand_pose.py) must name the same class. The two fail differently (a silhouette that lost a
finger; landmarks fitted to the wall): on 119 cluttered composites each alone named 103-104 right, the
two agreed on 100 and 97 of those were right. A disagreement is no hand (the swarm keeps its command), unless
the landmarks are sure and steady (`steady_pose`): all 5 nearest training hands vote for their class, and so
they do, with the landmarks barely moved, when the hand is read again in other crops (mirrored and 0.85 times
the box; until session 7 also 1.2 times). The silhouette's errors there are GrabCut's (given the pasted
silhouette, its classifier named 12 of 15 right); landmarks fitted to a wall or to a half-seen hand move from
crop to crop. On 315 composites of bench-perception's generator (seeds 7, 13 and held-out 11, not the
benchmark's): 45 disagreements, 17 steady, 16 of those the right class; detection 0.733 -> 0.787, accuracy
(ten classes) 0.952 -> 0.952, no hand in any of the 315 hand-free frames; on 210 more (seeds 17, held-out 19)
0.738 -> 0.776, 0.961 -> 0.957. The rereadings cost a landmark pass each (~4 ms), on disagreements only.
An agreement can be wrong too (both read an 8 as a 9 on noise): a palm hand's agreement read with a
hand-presence score below MIRROR_BELOW must hold when the hand is read mirrored (`holds_mirrored`), which
let the disagreements be read in two crops instead of three (STEADY_SCALES): on the tuning composites
detection 0.816 -> 0.832 and ten-class accuracy 0.961 -> 0.973 (issue 50 session 7).
A hand no palm view holds, found by the landmark model alone (landmarks.bottom_boxes), has no palm score to
vouch for it: its class counts only when steady, even where the two classifiers agree.
Session 8: the rereadings also vouch for the silhouette (`confirms`): a disagreement whose mirrored and 0.85
rereadings both name the silhouette's class with all votes is that class (the landmarks' first reading of a 6-9,
its thumb on a fingertip, is often a 4; read mirrored it is often right). On the tuning composites (the
benchmark's generator, seeds 0, 7, 13, 17; 560 hands) 5 more hands found, none wrong; the mirrored rereading
alone would have found 12, one wrong. And a palm hand's agreement read below MIRROR_BELOW must also be found in
the 0.85 crop (`found_again`, one landmark pass): the two wrong agreements it refused there (a 1 read 0 on noise,
its silhouette off the hand, IoU 0.08; a 6 read 4 on wood, IoU 0.40) lost the hand there (presence 0.12, 0.21),
the right ones kept it (0.75 and more).
Session 12: a palm hand's disagreement that neither settles is read by MediaPipe's full landmark model
(`full_pose`: the tracking box, mirrored, the 0.85 crop; all three find the hand and all votes name one class):
on the benchmark's tuning composites 461 -> 483 hands found, 19 -> 20 misnamed; held-out seeds 1, 11, 19 341 ->
357, 8 -> 9; no hand-free frame more (docs/perception.md).
What the rest of the pipeline consumes is unchanged: `Hand.mask` is the silhouette in the frame's pixels.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from perception.eigen import EigenClassifier
from perception.features import hand_hog
from perception.hand_pose import PoseClassifier, pose_classifier
from perception.hand_silhouette import clean_crop, silhouette
from perception.landmarks import FULL_LANDMARK_MODEL, PRESENCE, HandLandmarks, find_landmarks, reread, rereadings

# Of the hand's box (the landmarks' bounding box): a silhouette covering less of it is GrabCut losing the
# hand (a hand's silhouette covers 35-70 % of its landmarks' box; fingers spread: the least).
MIN_BOX_FILL = 0.15
# The hand space's limit for a silhouette the landmarks vouch for: HAND_SPACE_LIMIT (0.30) was set to
# refuse colour segmentations that are no hand; here the landmark model already said "hand", and on
# cluttered composites (200, 5 families) the hands at 0.30-0.45 were named as often as those below 0.30.
# 0.55 since issue 50 session 9: replayed on the benchmark's composites (tuning seeds 0, 7, 13, 17, held-out 1, 11,
# 19), the hands the other checks take at 0.45-0.55 were 5, all named right (a 1 on stripes at 0.53, 2s at 0.47),
# none above 0.54; of the 980 hand-free frames one gave a silhouette at all (0.33, refused by the other checks).
LEARNED_SPACE_LIMIT = 0.55
MIN_CROP_SHARE = 0.05  # of the classifier's crop: less is GrabCut keeping a sliver (find_hand's MIN_HAND_SHARE)
# Of the palm length: the landmarks' mean move from the first reading to its rereadings (steady_pose) at most.
# A hand's landmarks moved 0.036 L (median; 90 % below 0.075) on 36 steady disagreements of the composites
# named in the module docstring; the move grows as the silhouette's IoU falls (correlation -0.6 to -0.8):
# landmarks that moved more, e.g. 0.10 L fitted to a smaller hand than the one shown (a held-out 2 on noise,
# silhouette IoU 0.40), are not the hand's.
STEADY_MOVE = 0.08
# The rereadings' scales (steady_pose): the mirrored crop and the 0.85 one, not the 1.2 one. For a hand found
# without a palm whose two classifiers agree (issue 50 session 6): such a hand comes in from the bottom edge,
# and the larger crop reaches further past it (black): on the tuning composites of landmarks.bottom_boxes, of 12
# palm-less hands the two classifiers named right, 9 held in the mirrored and the smaller crop, and 6 of those 9
# lost the hand (presence < 0.5) or its class in the larger one, or moved there past STEADY_MOVE; of the two
# named wrong, one held in the first two. Tuning detection 0.806 -> 0.813 (with the 0.3 squares 0.827),
# accuracy 0.960 -> 0.958 (0.959). For a disagreement too since session 7, with the mirror check below (alone it
# cost seed 0's ten-class accuracy, session 6). One landmark pass fewer.
STEADY_SCALES: tuple[float, ...] = (0.85,)
# A palm hand whose two classifiers agree, read with a hand-presence score below MIRROR_BELOW, is read again in
# its mirrored crop, whose landmarks must find the hand and name the same class (`holds_mirrored`). On the
# tuning composites (seeds 7, 13, 17; 215 agreements of palm hands, 9 of them wrong: 8 read 9 by both on noise,
# a 6, a 9 on wood, three 2s) the mirrored reading lost the hand or named another class for 4 of the 9 wrong and 6 of
# the 206 right; all 4 wrong and 3 of the right ones had a presence below 0.98, where 46 of the 215 lie (a quarter of
# the agreements pay the pass, ~4 ms). With STEADY_SCALES for disagreements: detection 0.816 -> 0.832,
# ten-class accuracy 0.961 -> 0.973, five-class 0.980 -> 0.980, no hand in the 315 hand-free frames.
MIRROR_BELOW = 0.98
MIN_HAND_PX = 24  # the palm length [px] below which a hand is too small to classify (a 100-px photo's: 30-45)


class LearnedHand(NamedTuple):
    """What perception.hand.Hand holds (that module builds it: it imports this one)."""

    mask: np.ndarray
    label: str
    confidence: float
    distance: float


_poses: dict[tuple[str, ...], PoseClassifier] = {}


def classes_of(classifier: EigenClassifier) -> tuple[str, ...]:
    if classifier.svm is not None:
        return tuple(str(c) for c in classifier.svm["classes"])
    return tuple(str(c) for c in np.unique(np.asarray(classifier.train_labels)))


def poses_for(classifier: EigenClassifier) -> PoseClassifier:
    """The shipped landmark classifier kept to `classifier`'s classes (loaded once per class set)."""
    key = classes_of(classifier)
    if key not in _poses:
        _poses[key] = pose_classifier(key)
    return _poses[key]


def learned_hand(
    frame_bgr: np.ndarray, classifier: EigenClassifier, poses: PoseClassifier | None = None
) -> LearnedHand | str:
    """The hand seen by the learned detector, or why none (a reason to append to the plain reading's).
    Its class is named twice, by the silhouette's classifier and by the landmarks' (`poses`, default the
    shipped one for the classifier's classes): when they differ, no hand is reported (no command) unless
    the landmarks' class is steady (`steady_pose`); then it is the hand's."""
    hands = find_landmarks(frame_bgr)
    if not hands:
        return "the hand detector sees no hand"
    lm = hands[0]
    if lm.palm_length() < MIN_HAND_PX:
        length = lm.palm_length()
        return f"the hand detector's hand is too small ({length:.0f} px wrist to knuckles, at least {MIN_HAND_PX})"
    mask = silhouette(frame_bgr, lm)
    x0, y0 = lm.points.min(0)
    x1, y1 = lm.points.max(0)
    box = max(1.0, float((x1 - x0) * (y1 - y0)))
    if mask.sum() < MIN_BOX_FILL * box:
        return "the hand detector's hand has no silhouette"
    pic, sil = clean_crop(frame_bgr, mask)
    if sil.mean() < MIN_CROP_SHARE:
        return "the hand detector's silhouette is too small"
    x = hand_hog([pic], [sil])
    distance = float(classifier.hand_space_distance(x)[0])
    if distance > LEARNED_SPACE_LIMIT:
        return (
            f"the hand detector's silhouette is not a hand's "
            f"(distance from the hand space {distance:.2f} > {LEARNED_SPACE_LIMIT})"
        )
    label, conf = classifier.predict_features(x)
    poses = poses or poses_for(classifier)
    pose, votes = poses.predict(lm.points)
    palm = lm.palm_score > 0.0  # else found by the landmark model alone (landmarks.bottom_boxes)
    sil = str(label[0])
    if pose == sil and palm:
        if lm.presence < MIRROR_BELOW and not holds_mirrored(frame_bgr, lm, poses, pose):
            return f"the hand detector's landmarks name another class when read mirrored (class {pose})"
        if lm.presence < MIRROR_BELOW and not found_again(frame_bgr, lm):
            return f"the hand detector loses the hand when read again in a smaller crop (class {pose})"
        return LearnedHand(mask, sil, float(conf[0]), distance)
    if pose == sil:  # and no palm
        if votes >= 1.0 and steady_pose(frame_bgr, lm, poses, pose):
            return LearnedHand(mask, pose, votes, distance)
        return f"the hand detector's landmarks (no palm found) are not steady (class {pose})"
    again = rereadings(frame_bgr, lm.points, STEADY_SCALES)
    if votes >= 1.0 and steady_pose(frame_bgr, lm, poses, pose, readings=again):
        return LearnedHand(mask, pose, votes, distance)
    if confirms(again, poses, sil):
        return LearnedHand(mask, sil, float(conf[0]), distance)
    full = full_pose(frame_bgr, lm, poses) if palm else None
    if full is not None:
        return LearnedHand(mask, full, 1.0, distance)
    return f"the hand detector's two readings differ (silhouette: {sil}, landmarks: {pose})"


def steady_pose(
    frame_bgr: np.ndarray,
    lm: HandLandmarks,
    poses: PoseClassifier,
    pose: str,
    scales: tuple[float, ...] | None = None,
    readings: list[HandLandmarks] | None = None,
) -> bool:
    """Whether the landmarks' class `pose` holds when the hand is read again in other crops (`rereadings`):
    every rereading finds the hand, its NEIGHBOURS nearest training hands all vote for `pose`, and its
    landmarks lie where the first reading's did (on average over the rereadings, each landmark within
    STEADY_MOVE of the hand's palm length). `scales`: the rereadings' (default STEADY_SCALES); `readings`: those
    rereadings when already read."""
    scales = STEADY_SCALES if scales is None else scales
    moves = []
    for again in rereadings(frame_bgr, lm.points, scales) if readings is None else readings:
        if again.presence < PRESENCE:
            return False
        if poses.predict(again.points) != (pose, 1.0):
            return False
        moves.append(float(np.linalg.norm(again.points - lm.points, axis=1).mean()))
    return float(np.mean(moves)) <= STEADY_MOVE * lm.palm_length()


def holds_mirrored(frame_bgr: np.ndarray, lm: HandLandmarks, poses: PoseClassifier, pose: str) -> bool:
    """Whether the hand read again in its mirrored crop (`rereadings`' first) is found and its landmarks'
    nearest training hands name `pose` (by their majority: a right agreement's mirrored reading often has
    a vote or two elsewhere)."""
    again = rereadings(frame_bgr, lm.points, ())[0]
    return again.presence >= PRESENCE and poses.predict(again.points)[0] == pose


def found_again(frame_bgr: np.ndarray, lm: HandLandmarks) -> bool:
    """Whether the hand is found (hand presence >= PRESENCE) when read again in the smaller crops
    (STEADY_SCALES' rereadings without the mirrored one)."""
    return all(a.presence >= PRESENCE for a in rereadings(frame_bgr, lm.points, STEADY_SCALES, mirrored=False))


def full_pose(frame_bgr: np.ndarray, lm: HandLandmarks, poses: PoseClassifier) -> str | None:
    """The class MediaPipe's full landmark model (landmarks.FULL_LANDMARK_MODEL) names steadily for the hand
    `lm`, else None: read mirrored, in the tracking box, and in the 0.85 crop (STEADY_SCALES), each reading
    finds the hand and its NEIGHBOURS nearest training hands all vote for one class, the same in all three.
    Up to three passes of the full model (~2x a lite pass each), on disagreements only; stops at the first
    reading that does not hold."""
    named = None
    for again in reread(frame_bgr, lm.points, (1.0, *STEADY_SCALES), model=FULL_LANDMARK_MODEL):
        if again.presence < PRESENCE:
            return None
        pose, votes = poses.predict(again.points)
        if votes < 1.0 or named not in (None, pose):
            return None
        named = pose
    return named


def confirms(again: list[HandLandmarks], poses: PoseClassifier, label: str) -> bool:
    """Whether every rereading (`again`: the mirrored crop and STEADY_SCALES') finds the hand and its
    NEIGHBOURS nearest training hands all vote for the silhouette's class `label`."""
    return all(a.presence >= PRESENCE and poses.predict(a.points) == (label, 1.0) for a in again)
