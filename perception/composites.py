"""Frames of an ordinary room for the perception benchmark (`fluidswarm bench-perception`): 640 x 480
backgrounds of several families, a hand photograph or a person pasted into them, webcam degradations.

Families (`background`): `photo` (scikit-image's bundled photographs, when scikit-image is installed: the
bench extra), `wood`, `stripes`, `noise`, `skin` (a skin-coloured wall: the hardest for a colour rule),
`weizmann` (the shared clips' walls: their temporal median with the person painted out, scaled up), and
`plain` (the shared photographs' own bright grey, the control). Each is drawn from a seeded generator:
the same seed, the same frame.

A hand (`paste_hand`): a shared photograph's hand, cut out by `hand_mask` (99.9 % plausible on the set), scaled
so it is 20-50 % of the frame's height, its wrist on the bottom edge (an arm reaching up into the picture),
at a random column; its edge feathered over ~2 px (a camera's edges are not hard). A photograph that cuts
through the palm (`bottom_ratio` >= PALM_CUT: its bottom rows as wide as the hand) has no wrist to set on the
edge: the hand is raised and a forearm drawn below the cut to the bottom edge (`_forearm`: the rest of the
palm narrowing to a wrist, then the forearm widening slightly; its colour and texture the hand's own bottom
rows), feathered with the hand. Such a hand's true mask ends at the drawn wrist line (the hand and the rest of
its palm; the forearm beyond is no part of the gesture, as the pipeline's silhouette cuts it near the wrist):
the benchmark scores both masks above that line (issue 50 session 11). A person
(`paste_person`): a Weizmann frame's silhouette (the project's own, perception/person.py) scaled to 55-85 % of
the height, feet at a random row of the lower part. The true mask is where the pasted alpha is >= 0.5.
`degrade`: a lighting ramp across the frame, gamma and white-balance drift, blur, sensor noise, JPEG.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from perception.segmentation import hand_mask

W, H = 640, 480
FAMILIES = ("plain", "photo", "wood", "stripes", "noise", "skin", "weizmann")
# scikit-image's photographs that ship inside its wheel (skimage.data, no download): colour ones and a few
# grey textures; `held` ones are kept for the unseen check (not looked at while building)
# (none shows a person: astronaut and camera, a cameraman, do, so a hand-free frame of them is no empty room)
PHOTOS = ("chelsea", "coffee", "rocket", "brick", "grass", "gravel", "coins", "moon")
HELD_PHOTOS = ("hubble_deep_field", "immunohistochemistry", "retina", "text", "page", "horse", "logo", "colorwheel")
# A photograph cut through the palm: its mask's bottom rows at least this share of its widest row (a wrist: < 0.7)
PALM_CUT = 0.85
# How the photograph's hand ends at its bottom, by `bottom_ratio` (bench-perception's detections are split so,
# bench_room's detection_by_hand_end): a wrist is narrower than WRIST_END of the widest row; a photograph that cuts
# through the palm leaves it PALM_CUT or wider (until issue 50 session 11 the composite set that cut on the frame's
# edge as if it were a wrist, most of the hands missed: docs/perception.md; now `_forearm` draws one below it)
WRIST_END = 0.7
HAND_ENDS = (
    (WRIST_END, f"wrist (< {WRIST_END})"),
    (PALM_CUT, f"{WRIST_END}-{PALM_CUT}"),
    (float("inf"), f"palm cut (>= {PALM_CUT})"),
)
# the forearm drawn below such a cut, in the cut's width c and the pasted hand's height h: the rest of the palm
# narrows to a wrist of WRIST_NARROW c over WRIST_ROWS c, then the forearm widens to FOREARM_WIDEN c at the bottom
# edge, FOREARM_LENGTH h below the cut in all
WRIST_ROWS, WRIST_NARROW, FOREARM_WIDEN, FOREARM_LENGTH = 0.35, 0.75, 0.85, 0.5


@dataclass(frozen=True)
class Composite:
    frame: np.ndarray  # BGR uint8, H x W
    mask: np.ndarray | None  # bool, the pasted subject (None: a frame without one)
    label: str | None  # the hand's class, or "person"
    family: str


def _fit(img: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A random crop of `img` with the frame's aspect, scaled to W x H."""
    if img.ndim == 2:
        img = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
    if img.shape[2] == 4:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2BGR)
    h, w = img.shape[:2]
    share = rng.uniform(0.6, 1.0)
    ch = int(min(h, w * H / W) * share)
    cw = int(ch * W / H)
    y0 = int(rng.integers(0, h - ch + 1))
    x0 = int(rng.integers(0, w - cw + 1))
    return cv2.resize(img[y0 : y0 + ch, x0 : x0 + cw], (W, H), interpolation=cv2.INTER_LINEAR)


def skimage_photos(names: tuple[str, ...] = PHOTOS) -> list[np.ndarray] | None:
    """scikit-image's bundled photographs (BGR), or None when scikit-image is not installed."""
    try:
        from skimage import data  # the test extra; the benchmark says when it is missing
    except ImportError:
        return None
    out = []
    for n in names:
        img = np.asarray(getattr(data, n)())
        if img.dtype != np.uint8:
            img = (255 * (img.astype(np.float64) / max(float(img.max()), 1e-9))).astype(np.uint8)
        out.append(img[..., ::-1].copy() if img.ndim == 3 else img)
    return out


def _wood(rng: np.random.Generator) -> np.ndarray:
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float32)
    cx, cy = rng.uniform(-W, 2 * W), rng.uniform(-3 * H, -H)
    warp = cv2.GaussianBlur(rng.normal(0, 1, (H, W)).astype(np.float32), (0, 0), 25) * 60
    r = np.sqrt((xx - cx) ** 2 * rng.uniform(0.02, 0.1) + (yy - cy) ** 2) + warp
    grain = 0.5 + 0.5 * np.sin(r * rng.uniform(0.15, 0.4))
    fine = cv2.GaussianBlur(rng.normal(0, 1, (H, W)).astype(np.float32), (0, 0), 1.0) * 0.08
    t = np.clip(grain * 0.7 + fine + 0.15, 0, 1)[..., None]
    dark = np.array([30, 55, 95], np.float32) * rng.uniform(0.7, 1.2)  # BGR browns
    light = np.array([95, 150, 205], np.float32) * rng.uniform(0.8, 1.1)
    return np.clip(dark + (light - dark) * t, 0, 255).astype(np.uint8)


def _stripes(rng: np.random.Generator) -> np.ndarray:
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float32)
    a = rng.uniform(0, np.pi)
    period = rng.uniform(8, 60)
    u = (np.cos(a) * xx + np.sin(a) * yy) / period
    hard = rng.random() < 0.5
    t = (np.floor(u) % 2) if hard else 0.5 + 0.5 * np.sin(2 * np.pi * u)
    c1, c2 = rng.integers(0, 256, 3).astype(np.float32), rng.integers(0, 256, 3).astype(np.float32)
    return np.clip(c1 + (c2 - c1) * t[..., None], 0, 255).astype(np.uint8)


def _noise(rng: np.random.Generator) -> np.ndarray:
    out = np.zeros((H, W, 3), np.float32)
    for sigma in (1.0, 4.0, 16.0):
        out += cv2.GaussianBlur(rng.normal(0, 1, (H, W, 3)).astype(np.float32), (0, 0), sigma) * sigma**0.5
    out = (out - out.mean()) / max(float(out.std()), 1e-6)
    return np.clip(128 + 50 * out + rng.uniform(-40, 40, 3), 0, 255).astype(np.uint8)


def _skin(rng: np.random.Generator) -> np.ndarray:
    hsv = np.zeros((H, W, 3), np.float32)
    hsv[..., 0] = rng.uniform(5, 20)  # OpenCV hue 0-180: skin's 5-20
    hsv[..., 1] = rng.uniform(70, 140)
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float32)
    shade = 1 + 0.25 * (xx / W - 0.5) * rng.uniform(-1, 1) + 0.25 * (yy / H - 0.5) * rng.uniform(-1, 1)
    texture = cv2.GaussianBlur(rng.normal(0, 1, (H, W)).astype(np.float32), (0, 0), 3) * 8
    hsv[..., 2] = np.clip(rng.uniform(150, 220) * shade + texture, 0, 255)
    return cv2.cvtColor(np.clip(hsv, 0, 255).astype(np.uint8), cv2.COLOR_HSV2BGR)


def _plain(rng: np.random.Generator) -> np.ndarray:
    grey = rng.uniform(170, 200)
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float32)
    vignette = 1 - 0.15 * (((xx - W / 2) / W) ** 2 + ((yy - H / 2) / H) ** 2) * 4
    return np.clip(np.stack([grey * vignette] * 3, -1) + rng.normal(0, 2, (H, W, 3)), 0, 255).astype(np.uint8)


def background_maker(
    family: str, photos: list[np.ndarray] | None = None, walls: list[np.ndarray] | None = None
) -> Callable[[np.random.Generator], np.ndarray]:
    """A function rng -> a W x H BGR background of `family` (photo and weizmann need their pictures)."""
    synthetic = {"plain": _plain, "wood": _wood, "stripes": _stripes, "noise": _noise, "skin": _skin}
    if family in synthetic:
        return synthetic[family]
    pictures = photos if family == "photo" else walls if family == "weizmann" else None
    if not pictures:
        raise ValueError(f"background family {family!r}: no pictures given")
    return lambda rng: _fit(pictures[int(rng.integers(len(pictures)))], rng)


def weizmann_wall(frames: list[np.ndarray], person: np.ndarray) -> np.ndarray:
    """A clip's wall: its temporal median with the person (`person`: where they were in any frame) painted
    over from the wall round them (the median keeps a person who stands still), scaled to the frame."""
    median = np.median(np.stack(frames), axis=0).astype(np.uint8)
    hole = cv2.dilate(person.astype(np.uint8), np.ones((5, 5), np.uint8))
    return cv2.resize(cv2.inpaint(median, hole, 5, cv2.INPAINT_TELEA), (W, H), interpolation=cv2.INTER_CUBIC)


def _paste(bg: np.ndarray, src: np.ndarray, alpha: np.ndarray, x0: int, y0: int) -> tuple[np.ndarray, np.ndarray]:
    out = bg.astype(np.float32)
    full = np.zeros((H, W), np.float32)
    h, w = alpha.shape
    ys, xs = slice(max(0, y0), min(H, y0 + h)), slice(max(0, x0), min(W, x0 + w))
    sy, sx = slice(ys.start - y0, ys.stop - y0), slice(xs.start - x0, xs.stop - x0)
    full[ys, xs] = alpha[sy, sx]
    out[ys, xs] = out[ys, xs] * (1 - alpha[sy, sx, None]) + src[sy, sx].astype(np.float32) * alpha[sy, sx, None]
    return np.clip(out, 0, 255).astype(np.uint8), full >= 0.5


def _feather(mask: np.ndarray, sigma: float) -> np.ndarray:
    a = mask.astype(np.float32)
    return np.clip(cv2.GaussianBlur(a, (0, 0), sigma), 0, 1) if sigma > 0 else a


def paste_hand(
    bg: np.ndarray, photo: np.ndarray, mask: np.ndarray, rng: np.random.Generator, forearm: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """(frame, true mask): the photograph's hand (`mask`) 20-50 % of the frame's height, wrist on the bottom,
    at a random column (a palm the photograph cut: on a drawn forearm; `forearm` False: that cut on the bottom
    edge, as a hand whose wrist is below the frame, the composite before issue 50 session 11)."""
    share = rng.uniform(0.2, 0.5)
    ys, xs = np.nonzero(mask)
    width = (xs.max() - xs.min() + 1) * share * H / (ys.max() - ys.min() + 1)
    return _place(bg, photo, mask, int(rng.integers(0, max(1, W - int(width)))), share, rng, forearm)


def bottom_ratio(mask: np.ndarray) -> float:
    """The width of `mask`'s bottom 3 rows over its widest row's: a wrist is narrow (< 0.7), a photograph cut
    through the palm wide (>= PALM_CUT)."""
    ys = np.nonzero(mask.any(1))[0]
    rows = mask[ys.min() : ys.max() + 1].sum(1)
    return float(rows[-3:].mean() / max(int(rows.max()), 1))


def scored_rows(truth: np.ndarray) -> slice:
    """The rows a pasted hand's masks are compared on: down to its true mask's lowest row (a hand on a drawn
    forearm above its wrist line, as the pipeline's silhouette cuts the forearm near the wrist; a hand whose wrist
    is on the bottom edge, all of them)."""
    return slice(0, int(np.nonzero(truth.any(1))[0].max()) + 1) if truth.any() else slice(None)


def _forearm(src: np.ndarray, m: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """(picture, mask, wrist row): `src`/`m` (a hand whose palm the photograph cut, the cut on its bottom row)
    with a forearm drawn below the cut: FOREARM_LENGTH of the hand's height long, centred under the cut, the
    rest of the palm narrowing to the wrist (WRIST_ROWS, WRIST_NARROW), the forearm widening slightly below it;
    each row the colour profile across the hand's bottom rows stretched to its width, with their grain. The
    wrist row is the narrowing's end in the returned picture."""
    h, w = m.shape
    cols = np.nonzero(m[-3:].any(0))[0]
    c0, c1 = int(cols.min()), int(cols.max()) + 1
    cut = c1 - c0
    centre = (c0 + c1) / 2
    length = max(int(round(FOREARM_LENGTH * h)), 4)
    wrist = min(max(int(round(WRIST_ROWS * cut)), 2), length - 1)
    k = max(3, int(round(0.08 * h)))
    strip = src[h - k :, c0:c1].astype(np.float32)
    skin = m[h - k :, c0:c1]
    # the forearm's colour across it: the mean of each column of the hand's bottom rows (its shading from
    # side to side), columns without hand there taking the rows' mean; smoothed over a few columns
    mean = strip[skin].mean(0) if skin.any() else strip.reshape(-1, 3).mean(0)
    counts = skin.sum(0)
    profile = np.where(counts[:, None] > 0, (strip * skin[..., None]).sum(0) / np.maximum(counts, 1)[:, None], mean)
    profile = cv2.GaussianBlur(profile[None].astype(np.float32), (0, 0), sigmaX=max(1.0, cut / 30), sigmaY=0.1)[0]
    # its texture: the bottom rows' own grain about that profile, as a seeded noise of the same spread (the
    # photograph's pixels, so the same hand gets the same forearm; no draw from the composite's generator)
    grain = float(np.std(strip[skin] - profile[np.nonzero(skin)[1]])) if skin.any() else 4.0
    noise = np.random.default_rng(int(src.sum()) % (2**32))
    half = max(int(np.ceil(cut * max(1.0, FOREARM_WIDEN) / 2)) + 1, 1)
    left = int(np.floor(min(centre - half, c0)))
    right = int(np.ceil(max(centre + half, c1)))
    pad_l, pad_r = max(0, -left), max(0, right - w)
    pic = np.zeros((h + length, w + pad_l + pad_r, 3), np.uint8)
    mk = np.zeros(pic.shape[:2], bool)
    pic[:h, pad_l : pad_l + w] = src
    mk[:h, pad_l : pad_l + w] = m
    for r in range(length):
        t = r / wrist if r < wrist else 1.0
        width = (
            cut * (1 - (1 - WRIST_NARROW) * t)
            if r < wrist
            else cut * (WRIST_NARROW + (FOREARM_WIDEN - WRIST_NARROW) * (r - wrist) / max(length - 1 - wrist, 1))
        )
        n = max(int(round(width)), 2)
        a = int(round(centre - n / 2)) + pad_l
        row = cv2.resize(profile[None], (n, 1), interpolation=cv2.INTER_LINEAR)[0]
        pic[h + r, a : a + n] = np.clip(row + noise.normal(0, 0.35 * min(grain, 12.0), (n, 1)), 0, 255).astype(np.uint8)
        mk[h + r, a : a + n] = True
    return pic, mk, h + wrist


def _place(
    bg: np.ndarray,
    photo: np.ndarray,
    mask: np.ndarray,
    px: int,
    share: float,
    rng: np.random.Generator,
    forearm: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """The hand `share` of the frame's height, its left edge at column `px`, wrist on the bottom edge (a palm
    the photograph cut: raised on a drawn forearm, the true mask ending at its wrist line)."""
    # the photograph's bright wall round the hand painted over with the hand's own edge colours, so the
    # feathered edge blends hand into room, not a white halo
    grown = np.asarray(cv2.dilate(mask.astype(np.uint8), np.ones((5, 5), np.uint8))) > 0
    ring = (grown & ~mask).astype(np.uint8)
    photo = cv2.inpaint(photo, ring, 3, cv2.INPAINT_TELEA)
    ys, xs = np.nonzero(mask)
    y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
    s = share * H / (y1 - y0)
    src = cv2.resize(photo[y0:y1, x0:x1], None, fx=s, fy=s, interpolation=cv2.INTER_CUBIC)
    m = cv2.resize(mask[y0:y1, x0:x1].astype(np.uint8), (src.shape[1], src.shape[0]), interpolation=cv2.INTER_NEAREST)
    wrist = None
    if forearm and bottom_ratio(mask) >= PALM_CUT:  # decided on the photograph's own mask, never on a reading
        w0 = src.shape[1]
        src, mb, wrist = _forearm(src, m.astype(bool))
        px -= (src.shape[1] - w0) // 2
        m = mb.astype(np.uint8)
    alpha = _feather(m.astype(bool), rng.uniform(0.8, 2.0))
    # the wrist (cut by the photograph's bottom edge) or forearm stays solid to the frame's edge
    alpha[-3:] = np.maximum(alpha[-3:], m[-3:].astype(np.float32))
    y = H - src.shape[0]
    frame, truth = _paste(bg, src, alpha, min(max(0, px), max(0, W - src.shape[1])), y)
    if wrist is not None:
        truth[max(0, y + wrist) :] = False  # scored above the wrist line
    return frame, truth


def paste_person(
    bg: np.ndarray, frame: np.ndarray, mask: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """(frame, true mask): a person's silhouette from a small clip frame, 55-85 % of the frame's height."""
    ys, xs = np.nonzero(mask)
    y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
    s = rng.uniform(0.55, 0.85) * H / (y1 - y0)
    src = cv2.resize(frame[y0:y1, x0:x1], None, fx=s, fy=s, interpolation=cv2.INTER_CUBIC)
    m = cv2.resize(mask[y0:y1, x0:x1].astype(np.uint8), (src.shape[1], src.shape[0]), interpolation=cv2.INTER_LINEAR)
    alpha = _feather(m.astype(bool), rng.uniform(0.8, 2.0))
    px = int(rng.integers(0, max(1, W - src.shape[1])))
    py = int(rng.integers(max(0, H - src.shape[0] - 40), max(1, H - src.shape[0] + 1)))
    return _paste(bg, src, alpha, px, py)


def degrade(frame: np.ndarray, rng: np.random.Generator, strength: float = 1.0) -> np.ndarray:
    """A webcam's picture of `frame`: lighting ramp, gamma, white balance, blur, noise, JPEG."""
    f = frame.astype(np.float32) / 255.0
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float32)
    a = rng.uniform(0, 2 * np.pi)
    ramp = 1 + strength * rng.uniform(0.1, 0.35) * (np.cos(a) * (xx / W - 0.5) + np.sin(a) * (yy / H - 0.5)) * 2
    f = f * ramp[..., None] * rng.uniform(1 - 0.3 * strength, 1 + 0.2 * strength)
    f = f * (1 + strength * rng.uniform(-0.12, 0.12, 3))  # white balance
    f = np.clip(f, 0, 1) ** rng.uniform(1 - 0.3 * strength, 1 + 0.4 * strength)
    img = (255 * f).astype(np.float32)
    sigma = rng.uniform(0, 1.2 * strength)
    if sigma > 0.2:
        img = cv2.GaussianBlur(img, (0, 0), sigma)
    img = np.clip(img + rng.normal(0, rng.uniform(1, 6) * strength, img.shape), 0, 255).astype(np.uint8)
    q = int(rng.uniform(45, 90))
    ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, q])
    decoded = cv2.imdecode(buf, cv2.IMREAD_COLOR) if ok else None
    return img if decoded is None else np.asarray(decoded)


def room_video(
    photos: list[np.ndarray], family: str, rng: np.random.Generator, seconds: float = 6.0, fps: float = 8.0
) -> list[np.ndarray]:
    """Frames of a camera held on one room while each photograph's hand is shown in turn (`seconds` each):
    the hand at 40 % of the height, wrist on the bottom edge, swaying a few pixels; the light drifting
    (brightness and white balance) slowly over the whole video; each frame with sensor noise and JPEG."""
    room = background_maker(family)(rng)
    n = int(round(seconds * fps))
    total = n * len(photos)
    frames = []
    x = int(rng.integers(W // 4, W // 2))
    for k, photo in enumerate(photos):
        mask = hand_mask(photo)
        for j in range(n):
            t = (k * n + j) / max(total - 1, 1)
            frame, _ = _place(room, photo, mask, x + int(round(6 * np.sin(j / 3.0))), 0.4, rng)
            light = (0.85 + 0.3 * t) * np.array([1.0 + 0.08 * np.sin(3 * t), 1.0, 1.0 - 0.08 * np.sin(3 * t)])
            f = np.clip(frame.astype(np.float32) * light + rng.normal(0, 2.5, frame.shape), 0, 255).astype(np.uint8)
            ok, buf = cv2.imencode(".jpg", f, [cv2.IMWRITE_JPEG_QUALITY, 80])
            decoded = cv2.imdecode(buf, cv2.IMREAD_COLOR) if ok else None
            frames.append(f if decoded is None else np.asarray(decoded))
    return frames
