"""The whole person in a static-camera clip: GrabCut seeded by the clip's own evidence (thesis §5.2, extended).

Why not background subtraction alone: the clip's temporal median holds the person's still body (torso,
legs, head), so frame - median finds only what moves (the arms). GrabCut (Rother, Kolmogorov, Blake,
SIGGRAPH 2004; OpenCV `cv2.grabCut`) labels each pixel person or wall from one colour mixture model each
plus the contrast between neighbours; it needs to be told roughly where the person is. Each frame is
seeded from what the clip says about the person, with no per-clip constant:

- surely person: nothing (a ghost in the median can make any prior wrong; colour decides);
- probably person: a vertical band round the still body's centre column, from the top of the still body
  to the bottom of the picture (torso and legs), and the pixels that move in this frame (the arms);
- probably wall: a margin round those;
- surely wall: everything farther away (the wall beside the person and above the arms' reach).

The person is what GrabCut keeps, in parts that touch the band or the moving pixels and are at least
MIN_PART_SHARE of the largest part (a belt or a bare midriff, wall-coloured, can cut a person in two). All
lengths scale with the person's height in the picture (the still body's top to the picture's bottom), not with
the picture.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

MIN_PART_SHARE = 0.1  # of the largest part's area: smaller parts are wall that GrabCut got wrong


@dataclass(frozen=True)
class PersonSeed:
    """How a frame's GrabCut is seeded (shares of the person's visible height: body top to picture bottom).

    band_share: half-width of the 'probably person' band round the body's centre column (0.18: 8 px of a
        44 px tall person, a little more than half a shoulder width).
    margin_share: width of the 'probably wall' margin round the band and the moving pixels (0.11: 5 px).
    iterations: GrabCut's iterations (the result no longer changes after about 4 on 64 x 64 frames).
    """

    band_share: float = 0.18
    margin_share: float = 0.11
    iterations: int = 4


def seed_mask(
    shape: tuple[int, int], centre_col: int, top_row: int, moving: np.ndarray, seed: PersonSeed = PersonSeed()
) -> np.ndarray:
    """GrabCut's initial labels (cv2.GC_*) for one frame: see the module docstring."""
    rows, _cols = shape
    height = max(rows - top_row, 1)
    half = max(2, int(round(seed.band_share * height)))
    margin = max(2, int(round(seed.margin_share * height)))
    band = np.zeros(shape, bool)
    band[top_row:, max(0, centre_col - half) : centre_col + half + 1] = True
    likely = band | moving
    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * margin + 1, 2 * margin + 1))
    near = cv2.dilate(likely.astype(np.uint8), k).astype(bool)
    init = np.full(shape, cv2.GC_BGD, np.uint8)
    init[near] = cv2.GC_PR_BGD
    init[likely] = cv2.GC_PR_FGD
    return init


def grabcut_person(frame_bgr: np.ndarray, init: np.ndarray, iterations: int = PersonSeed.iterations) -> np.ndarray:
    """The parts GrabCut labels person (see the module docstring), as a boolean mask (empty if none)."""
    if not (init == cv2.GC_PR_FGD).any() or not np.isin(init, (cv2.GC_BGD, cv2.GC_PR_BGD)).any():
        return np.zeros(init.shape, bool)
    mask = init.copy()
    bgd, fgd = np.zeros((1, 65), np.float64), np.zeros((1, 65), np.float64)
    cv2.setRNGSeed(0)  # GrabCut's k-means start: the same frame gives the same silhouette
    # cv2's stubs require rect; the binding takes None (unused with GC_INIT_WITH_MASK)
    cv2.grabCut(frame_bgr, mask, None, bgd, fgd, iterations, cv2.GC_INIT_WITH_MASK)  # type: ignore[call-overload]
    person = ((mask == cv2.GC_FGD) | (mask == cv2.GC_PR_FGD)).astype(np.uint8)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(person, connectivity=8)
    if n <= 1:
        return np.zeros(init.shape, bool)
    seeded = np.unique(labels[init == cv2.GC_PR_FGD])
    big = stats[:, cv2.CC_STAT_AREA] >= MIN_PART_SHARE * stats[1:, cv2.CC_STAT_AREA].max()
    keep = [i for i in seeded if i > 0 and big[i]]
    return np.isin(labels, keep)


def person_masks(
    frames: list[np.ndarray], moving: list[np.ndarray], centre_col: int, top_row: int, seed: PersonSeed = PersonSeed()
) -> list[np.ndarray]:
    """The whole person in each frame (BGR frames, their moving-pixel masks, the still body's centre column
    and top row)."""
    shape = frames[0].shape[:2]
    return [
        grabcut_person(f, seed_mask(shape, centre_col, top_row, m, seed), seed.iterations)
        for f, m in zip(frames, moving)
    ]
