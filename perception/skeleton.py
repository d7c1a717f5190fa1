"""Skeleton of a hand silhouette and the thesis' 6-entry feature vector (thesis §3.2).

    f_v = [line edge, U-shape fit, V-shape fit, two curves fit, one curve fit, distance between branches]

Templates (thesis §3.2): a fat line -> [1,0,0,0,0,0]; a U with aperture a -> [0,1,0,0,0,a]; a V with
aperture b -> [0,0,1,0,0,b]; pinching (two curves) -> [0,0,0,1,1,ap]; a line and a curve -> [1,0,0,0,1,ap].

How the entries are decided here (the thesis gives the template, not the rule):
1. Skeleton: Zhang-Suen thinning of the silhouette (the thesis finds "the equidistant pixels from the
   boundaries"), spurs shorter than SPUR pixels pruned.
2. The branches that matter: for a photograph the forearm is removed first (the part of the silhouette
   beyond the palm on the wrist side, see `perception.ellipses.hand_regions`). The skeleton's main path is
   the longest path between two end points (the two outermost branches).
3. The path is split at its apex (the point farthest from the chord between its ends). Each half, less
   the APEX_TRIM share next to the apex (the rounded joint), is a line if a straight line fits it within
   LINE_TOL of its length, else a curve.
   - one path, no apex (chord deviation < LINE_TOL): line edge.
   - two straight arms: angle between them < U_ANGLE degrees -> U (nearly parallel fingers joined at the
     base), else V.
   - two curved arms -> two curves fit and one curve fit (pinch); one straight, one curved -> line edge
     and one curve fit.
4. Distance between branches: distance between the two end points (the aperture), divided by the
   silhouette's longer side, so the entry is in 0..1 whatever the picture's size. 0 for a line.
"""

from __future__ import annotations

from collections import deque

import cv2
import numpy as np

from perception.ellipses import PALM_SCALE, hand_regions

SPUR = 0.12  # prune skeleton spurs shorter than this share of the silhouette's longer side
LINE_TOL = 0.06  # a branch is straight if no point is farther than this share of its length from a line
U_ANGLE = 22.0  # degrees between the two arms' directions below which the shape is a U, not a V
NAMES = ("line_edge", "u_shape", "v_shape", "two_curves", "one_curve", "branch_distance")


# Zhang-Suen thinning (T. Y. Zhang and C. Y. Suen, "A fast parallel algorithm for thinning digital patterns",
# Commun. ACM 27(3), 1984), vectorised with a neighbourhood code and two lookup tables. For a foreground pixel
# P1 with neighbours P2..P9 (clockwise from north), B = number of foreground neighbours, A = number of 0->1
# transitions in the cyclic sequence P2, P3, ..., P9, P2. P1 is removed when 2 <= B <= 6, A == 1 and
#   sub-iteration 1: P2*P4*P6 == 0 and P4*P6*P8 == 0
#   sub-iteration 2: P2*P4*P8 == 0 and P2*P6*P8 == 0
# until neither sub-iteration removes a pixel. opencv-python-headless ships no `cv2.ximgproc.thinning`, and
# scikit-image is not a dependency. Bit k of the code is neighbour P(k+2); cv2.filter2D correlates, so
# kernel[dy+1, dx+1] weighs the pixel at (row + dy, col + dx).
_CODE_KERNEL = np.array(
    [
        [128, 1, 2],  # P9 (NW), P2 (N), P3 (NE)
        [64, 0, 4],  # P8 (W),         P4 (E)
        [32, 16, 8],
    ],  # P7 (SW), P6 (S), P5 (SE)
    dtype=np.float32,
)


def _removal_tables() -> tuple[np.ndarray, np.ndarray]:
    first = np.zeros(256, dtype=bool)
    second = np.zeros(256, dtype=bool)
    for code in range(256):
        p2, _p3, p4, _p5, p6, _p7, p8, _p9 = p = [(code >> k) & 1 for k in range(8)]
        b = sum(p)
        a = sum(1 for k in range(8) if p[k] == 0 and p[(k + 1) % 8] == 1)
        if 2 <= b <= 6 and a == 1:
            first[code] = p2 * p4 * p6 == 0 and p4 * p6 * p8 == 0
            second[code] = p2 * p4 * p8 == 0 and p2 * p6 * p8 == 0
    return first, second


_REMOVE_FIRST, _REMOVE_SECOND = _removal_tables()


def thin(mask: np.ndarray) -> np.ndarray:
    """One-pixel-wide skeleton of a 2-D boolean mask (Zhang-Suen); a boolean array of the same shape."""
    mask = np.asarray(mask)
    if mask.ndim != 2:
        raise ValueError(f"mask must be 2-D, got shape {mask.shape}")
    img = (mask > 0).astype(np.float32)
    while True:
        changed = False
        for table in (_REMOVE_FIRST, _REMOVE_SECOND):
            code = cv2.filter2D(img, cv2.CV_32F, _CODE_KERNEL, borderType=cv2.BORDER_CONSTANT)
            remove = table[code.astype(np.uint8)] & (img > 0)
            if remove.any():
                img[remove] = 0
                changed = True
        if not changed:
            return img > 0


_OFFSETS = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]


def _graph(skel: np.ndarray) -> dict:
    pts = list(zip(*np.nonzero(skel)))
    s = set(pts)
    return {p: [(p[0] + dy, p[1] + dx) for dy, dx in _OFFSETS if (p[0] + dy, p[1] + dx) in s] for p in pts}


def _bfs(g: dict, start) -> tuple[dict, dict]:
    dist, prev = {start: 0}, {start: None}
    q = deque([start])
    while q:
        p = q.popleft()
        for n in g[p]:
            if n not in dist:
                dist[n], prev[n] = dist[p] + 1, p
                q.append(n)
    return dist, prev


def _path(prev: dict, end) -> list:
    out = []
    while end is not None:
        out.append(end)
        end = prev[end]
    return out[::-1]


def prune(skel: np.ndarray, min_len: int) -> np.ndarray:
    """Remove branches from an end point to a junction shorter than min_len pixels (repeated twice)."""
    skel = skel.copy()
    for _ in range(2):
        g = _graph(skel)
        ends = [p for p, n in g.items() if len(n) == 1]
        for e in ends:
            branch, p, prevp = [e], e, None
            while True:
                nxt = [n for n in g[p] if n != prevp and n not in branch]
                if len(g[p]) > 2 or not nxt:
                    break
                prevp, p = p, nxt[0]
                branch.append(p)
            if len(g[p]) > 2 and len(branch) < min_len:
                for q in branch[:-1]:
                    skel[q] = False
    return skel


def main_path(skel: np.ndarray) -> np.ndarray:
    """The longest shortest-path in the skeleton (its 'diameter'), as (N, 2) array of (x, y)."""
    g = _graph(skel)
    if not g:
        return np.zeros((0, 2))
    start = next(iter(g))
    dist, _ = _bfs(g, start)
    a = max(dist, key=lambda k: dist[k])
    dist, prev = _bfs(g, a)
    b = max(dist, key=lambda k: dist[k])
    return np.array([(x, y) for y, x in _path(prev, b)], float)


def _line_residual(pts: np.ndarray) -> float:
    """Largest distance of the points from their least-squares line, over the points' extent."""
    if len(pts) < 3:
        return 0.0
    c = pts - pts.mean(axis=0)
    _u, _s, vt = np.linalg.svd(c, full_matrices=False)
    normal = vt[1]
    extent = max(float(np.ptp(c @ vt[0])), 1.0)
    return float(np.abs(c @ normal).max()) / extent


def _direction(pts: np.ndarray) -> np.ndarray:
    """Unit direction of the points from their first (the apex) to their far end."""
    c = pts - pts.mean(axis=0)
    v = np.linalg.svd(c, full_matrices=False)[2][0]
    return v if np.dot(pts[-1] - pts[0], v) >= 0 else -v


APEX_TRIM = 0.35  # share of each arm next to the apex left out of the line fits (the joint's rounding)


def _trim(arm: np.ndarray) -> np.ndarray:
    return arm[int(APEX_TRIM * len(arm)) :] if len(arm) >= 6 else arm


def shape_features(path: np.ndarray, size: float) -> np.ndarray:
    """The 6-entry feature vector of one skeleton path (N, 2); size = the silhouette's longer side."""
    fv = np.zeros(6)
    if len(path) < 3:
        fv[0] = 1.0
        return fv
    a, b = path[0], path[-1]
    chord = b - a
    length = max(float(np.hypot(*chord)), 1.0)
    rel = path - a
    dev = np.abs(chord[0] * rel[:, 1] - chord[1] * rel[:, 0]) / length
    if _line_residual(path) < LINE_TOL:
        fv[0] = 1.0
        return fv
    k = int(np.argmax(dev))
    if k < 2 or k > len(path) - 3:
        fv[4] = 1.0  # one curve, no apex
        fv[5] = length / size
        return fv
    arm1, arm2 = _trim(path[k::-1]), _trim(path[k:])
    curved = [_line_residual(arm) > LINE_TOL for arm in (arm1, arm2)]
    fv[5] = length / size
    if not any(curved):
        cos = float(np.clip(np.dot(_direction(arm1), _direction(arm2)), -1, 1))
        angle = np.degrees(np.arccos(cos))
        fv[1 if angle < U_ANGLE else 2] = 1.0
    elif all(curved):
        fv[3] = fv[4] = 1.0
    else:
        fv[0] = fv[4] = 1.0
    return fv


def skeleton(mask: np.ndarray) -> np.ndarray:
    """Pruned Zhang-Suen skeleton of a silhouette."""
    mask = np.asarray(mask, bool)
    if not mask.any():
        raise ValueError("empty silhouette")
    m = cv2.morphologyEx(mask.astype(np.uint8), cv2.MORPH_CLOSE, np.ones((3, 3), np.uint8)).astype(bool)
    ys, xs = np.nonzero(m)
    size = max(np.ptp(ys), np.ptp(xs)) + 1
    return prune(thin(m), max(3, int(SPUR * size)))


def _fingers_only(mask: np.ndarray) -> np.ndarray:
    """A hand photograph's silhouette without the forearm: drop what lies beyond the palm on the wrist side."""
    r = hand_regions(mask)
    side = r["wrist_side"]
    if side is None:
        return mask
    px, py = r["critical_points"]["palm_centre"]
    cut = PALM_SCALE * r["palm_radius"]
    yy, xx = np.mgrid[: mask.shape[0], : mask.shape[1]]
    beyond = {"bottom": yy > py + cut, "top": yy < py - cut, "left": xx < px - cut, "right": xx > px + cut}[side]
    out = mask & ~beyond
    n, labels, stats, _ = cv2.connectedComponentsWithStats(out.astype(np.uint8), connectivity=8)
    return labels == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA])) if n > 1 else mask


def feature_vector(mask: np.ndarray, hand: bool | None = None) -> np.ndarray:
    """The thesis' 6-entry feature vector of a silhouette (see the module docstring), shape (6,).

    hand: remove the forearm first (default: when the silhouette touches the picture's border, as a hand
    photographed with its wrist leaving the frame does; drawn shapes that float free are used whole)."""
    mask = np.asarray(mask, bool)
    if not mask.any():
        raise ValueError("empty silhouette")
    touches = mask[0].any() or mask[-1].any() or mask[:, 0].any() or mask[:, -1].any()
    if hand if hand is not None else touches:
        mask = _fingers_only(mask)
    ys, xs = np.nonzero(mask)
    size = float(max(np.ptp(ys), np.ptp(xs)) + 1)
    return shape_features(main_path(skeleton(mask)), size)
