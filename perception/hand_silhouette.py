"""A hand's silhouette in front of any background, from its landmarks (perception/landmarks.py): GrabCut
(OpenCV `cv2.grabCut`: a colour mixture for the hand and one for the background, plus the contrast between
neighbours) seeded by the hand's skeleton.

Seeds, every length a share of the hand's own palm length L (wrist to the middle finger's knuckle):
- surely hand: the bones (wrist -> knuckles -> joints -> tips) drawn 0.08 L thick, and the palm polygon
  (wrist, the five knuckles) shrunk toward its centre to 60 %: both lie inside any hand the landmarks fit;
- probably hand: the bones drawn 0.18 L thick (a finger is about 0.2-0.25 L wide), the whole palm polygon,
  and the wrist continued 0.5 L away from the fingers (the shared photographs show the wrist);
- probably background: a margin of 0.45 L round those; surely background: the rest of the picture, and
  between two spread fingers (the triangle from their web to their tips) what lies farther than 0.18 L
  from every bone.
GrabCut runs on the hand's box only, scaled so its longer side is at most WORK_SIDE px, GRABCUT_ITERATIONS
times (its cost grows with both). The silhouette is GrabCut's hand part that holds the surely-hand seeds, holes filled,
cut 0.6 L beyond the wrist (a forearm in the picture is not the gesture; the classifier learnt hands
cut at the wrist).

`clean_crop` then paints everything but the silhouette with the shared photographs' plain background and
crops a square round it: what the classifier (trained on those photographs) is given.
"""

from __future__ import annotations

import itertools

import cv2
import numpy as np

from perception.landmarks import FINGERS, PALM, HandLandmarks

# GrabCut's picture's longer side at most [px], and its iterations: its cost grows with both. On 90 composites
# of six families (bench-perception's generator, seed 7, not the benchmark's seeds), 128 px and 3 iterations:
# detection 0.689, accuracy 0.935, mask IoU 0.894, 54 ms a frame; 96 px and 2: 0.689, 0.919, 0.882, 46 ms
# (96 and 3: 0.700, 0.921, 0.882, 49 ms; 128 and 2: 0.667, 0.933, 0.894, 51 ms; 80 and 3: 0.633).
WORK_SIDE = 96
GRABCUT_ITERATIONS = 2
BONE_SURE = 0.08  # of L: the surely-hand bones' thickness
BONE_PROBABLE = 0.18  # of L: within a finger's width, so the hand's colour model learns little background
FINGER_BAND = 0.32  # of L: no finger is wider than this round its bones (a finger is 0.2-0.25 L wide)
PALM_GROW = 0.06  # of L: the envelope's margin round the bands and the palm (the landmarks' own error)
WRIST_WIDTH = 0.9  # of L: the wrist's and forearm's width at most
GAP_MIN = 0.3  # of L: fingertips farther apart than this have background between them
WEB = 0.35  # the web between two fingers: this far from their knuckles toward their first joints
MARGIN = 0.45  # of L: probably background round the probable hand
WRIST_REACH = 0.5  # of L: the wrist continued away from the fingers, probably hand
WRIST_CUT = 0.6  # of L: nothing of the silhouette farther than this beyond the wrist
# BGR of the shared photographs' plain background (the median of their pixels outside the hand mask)
PLAIN_BGR = (185, 185, 186)


def _bones(points: np.ndarray) -> list[tuple[int, int]]:
    pairs = []
    for finger in FINGERS:
        chain = (0, *finger)
        pairs += list(itertools.pairwise(chain))
    pairs += [(5, 9), (9, 13), (13, 17)]
    return pairs


def _seed(shape: tuple[int, int], pts: np.ndarray, length: float) -> np.ndarray:
    """GrabCut's initial labels for a picture of `shape` with landmarks `pts` (its pixels)."""
    h, w = shape
    axis = pts[9] - pts[0]
    axis = axis / max(float(np.linalg.norm(axis)), 1e-6)
    wrist_end = pts[0] - axis * WRIST_REACH * length
    probable = np.zeros((h, w), np.uint8)
    sure = np.zeros((h, w), np.uint8)
    ip = np.round(pts).astype(np.int32)

    def line(img: np.ndarray, a: np.ndarray, b: np.ndarray, t: float) -> None:
        cv2.line(img, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), 1, max(1, int(round(t))), cv2.LINE_8)

    for a, b in _bones(pts):
        line(probable, ip[a], ip[b], BONE_PROBABLE * length)
        line(sure, ip[a], ip[b], BONE_SURE * length)
    line(probable, ip[0], np.round(wrist_end).astype(np.int32), BONE_PROBABLE * length * 1.5)
    palm = pts[list(PALM)]
    cv2.fillPoly(probable, [np.round(palm).astype(np.int32)], 1)
    centre = palm.mean(0)
    cv2.fillPoly(sure, [np.round(centre + 0.6 * (palm - centre)).astype(np.int32)], 1)
    k = max(3, int(round(2 * MARGIN * length)) | 1)
    near = cv2.dilate(probable, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)))
    labels = np.full((h, w), cv2.GC_BGD, np.uint8)
    labels[near > 0] = cv2.GC_PR_BGD
    band = np.zeros((h, w), np.uint8)  # a finger's widest reach round its bones
    for a, b in _bones(pts):
        line(band, ip[a], ip[b], FINGER_BAND * length)
    # between two spread fingers: background (the web's triangle up to their tips); the fingers' own
    # bands are drawn over it
    for f, g in itertools.pairwise(FINGERS):
        if np.linalg.norm(pts[f[-1]] - pts[g[-1]]) < GAP_MIN * length:
            continue
        web = (pts[f[0]] + pts[g[0]]) / 2 + WEB * ((pts[f[1]] + pts[g[1]]) / 2 - (pts[f[0]] + pts[g[0]]) / 2)
        tri = np.round(np.array([web, pts[f[-1]], pts[g[-1]]])).astype(np.int32)
        gap = np.zeros((h, w), np.uint8)
        cv2.fillPoly(gap, [tri], 1)
        labels[(gap > 0) & (band == 0)] = cv2.GC_BGD
    labels[probable > 0] = cv2.GC_PR_FGD
    labels[sure > 0] = cv2.GC_FGD
    return labels


def envelope(shape: tuple[int, int], pts: np.ndarray, length: float) -> np.ndarray:
    """Where a hand with landmarks `pts` can be at all: its bones' bands FINGER_BAND wide, the palm
    polygon grown by PALM_GROW, the wrist continued away from the fingers (bool)."""
    h, w = shape
    out = np.zeros((h, w), np.uint8)
    ip = np.round(pts).astype(np.int32)
    t = max(1, int(round(FINGER_BAND * length)))
    for a, b in _bones(pts):
        cv2.line(out, (int(ip[a][0]), int(ip[a][1])), (int(ip[b][0]), int(ip[b][1])), 1, t, cv2.LINE_8)
    cv2.fillPoly(out, [ip[list(PALM)]], 1)
    k = max(3, int(round(2 * PALM_GROW * length)) | 1)
    out = cv2.dilate(out, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))) if PALM_GROW > 0 else out
    axis = pts[9] - pts[0]
    axis = axis / max(float(np.linalg.norm(axis)), 1e-6)
    end = np.round(pts[0] - axis * 2 * WRIST_CUT * length).astype(np.int32)
    cv2.line(
        out, (int(ip[0][0]), int(ip[0][1])), (int(end[0]), int(end[1])), 1, max(1, int(round(WRIST_WIDTH * length)))
    )
    return out > 0


def hand_box(points: np.ndarray, length: float, shape: tuple[int, int]) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1) of the picture round the landmarks with room for the seeds' margins."""
    pad = (MARGIN + BONE_PROBABLE + WRIST_REACH) * length
    x0, y0 = np.floor(points.min(0) - pad).astype(int)
    x1, y1 = np.ceil(points.max(0) + pad).astype(int) + 1
    h, w = shape
    return max(0, x0), max(0, y0), min(w, x1), min(h, y1)


def silhouette(image_bgr: np.ndarray, hand: HandLandmarks) -> np.ndarray:
    """The hand's silhouette, bool, the picture's shape (empty if GrabCut keeps no hand part)."""
    h, w = image_bgr.shape[:2]
    length = max(hand.palm_length(), 2.0)
    x0, y0, x1, y1 = hand_box(hand.points, length, (h, w))
    out = np.zeros((h, w), bool)
    if x1 - x0 < 4 or y1 - y0 < 4:
        return out
    region = image_bgr[y0:y1, x0:x1]
    f = min(1.0, WORK_SIDE / max(region.shape[:2]))
    small = cv2.resize(region, None, fx=f, fy=f, interpolation=cv2.INTER_AREA) if f < 1.0 else region
    pts = (hand.points - (x0, y0)) * f
    labels = _seed(small.shape[:2], pts, length * f)
    sure = labels == cv2.GC_FGD
    if (labels == cv2.GC_BGD).sum() < 16 and (labels == cv2.GC_PR_BGD).sum() < 16:
        return out
    bgd, fgd = np.zeros((1, 65), np.float64), np.zeros((1, 65), np.float64)
    cv2.setRNGSeed(0)  # GrabCut's k-means start: the same frame gives the same silhouette
    try:
        cv2.grabCut(  # type: ignore[call-overload]  # cv2's stubs require rect; unused with GC_INIT_WITH_MASK
            np.ascontiguousarray(small), labels, None, bgd, fgd, GRABCUT_ITERATIONS, cv2.GC_INIT_WITH_MASK
        )
    except cv2.error:  # one of the two colour models had no pixels: keep the seeds' probable hand
        pass
    hand_px = ((labels == cv2.GC_FGD) | (labels == cv2.GC_PR_FGD)).astype(np.uint8)
    _n, comp = cv2.connectedComponents(hand_px, connectivity=4)
    keep = np.unique(comp[sure & (comp > 0)])
    mask = np.isin(comp, keep) & (comp > 0)
    mask = _fill_holes(mask) & envelope(mask.shape, pts, length * f)
    # beyond the wrist: nothing farther than WRIST_CUT along the hand's axis
    axis = pts[9] - pts[0]
    axis = axis / max(float(np.linalg.norm(axis)), 1e-6)
    yy, xx = np.mgrid[0 : mask.shape[0], 0 : mask.shape[1]]
    along = (xx - pts[0][0]) * axis[0] + (yy - pts[0][1]) * axis[1]
    mask &= along >= -WRIST_CUT * length * f
    big = cv2.resize(mask.astype(np.uint8), (x1 - x0, y1 - y0), interpolation=cv2.INTER_NEAREST) if f < 1.0 else mask
    out[y0:y1, x0:x1] = big.astype(bool)
    return out


def _fill_holes(mask: np.ndarray) -> np.ndarray:
    m = mask.astype(np.uint8)
    padded = np.pad(m, 1)
    ff = padded.copy()
    cv2.floodFill(ff, None, (0, 0), 1)
    holes = ff[1:-1, 1:-1] == 0
    return mask | holes


def clean_crop(image_bgr: np.ndarray, mask: np.ndarray, side: int = 100) -> tuple[np.ndarray, np.ndarray]:
    """(picture, silhouette) side x side: a square round the silhouette's box (its longer side + 30 %),
    its bottom edge on the silhouette's lowest row (the wrist of a raised hand, as in the shared
    photographs), everything but the silhouette painted PLAIN_BGR."""
    ys, xs = np.nonzero(mask)
    y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
    s = int(round(max(y1 - y0, x1 - x0) * 1.3))
    # the square's bottom on the silhouette's lowest row: the classifier's crop (features.crop_square)
    # continues a silhouette cut by the picture's edge beyond it, as it does the photographs' wrists
    cx, cy = (x0 + x1) / 2.0, y1 - s / 2.0
    # only the square's pixels are blended (the whole frame cost 9 ms of a room frame's time): the part of
    # the picture the square covers, one pixel more for the interpolation
    h, w = mask.shape
    bx0, by0 = max(0, int(np.floor(cx - s / 2)) - 1), max(0, int(np.floor(cy - s / 2)) - 1)
    bx1, by1 = min(w, int(np.ceil(cx + s / 2)) + 2), min(h, int(np.ceil(cy + s / 2)) + 2)
    cx, cy = cx - bx0, cy - by0
    m = np.array([[side / s, 0, side / 2 - cx * side / s], [0, side / s, side / 2 - cy * side / s]], np.float32)
    inside = mask[by0:by1, bx0:bx1].astype(bool)
    alpha = inside.astype(np.float32)
    # the silhouette's pixels as they are, the rest plain (what blending by the 0/1 alpha gave, without floats)
    mixed = np.where(inside[..., None], image_bgr[by0:by1, bx0:bx1], np.array(PLAIN_BGR, np.uint8))
    pic = cv2.warpAffine(mixed, m, (side, side), flags=cv2.INTER_AREA, borderValue=PLAIN_BGR)
    sil = cv2.warpAffine(alpha, m, (side, side), flags=cv2.INTER_LINEAR, borderValue=0) >= 0.5
    return pic, sil
