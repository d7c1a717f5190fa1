"""Reading what the camera saw: an image, a folder of frames, a video, or a Weizmann strip PNG.

Every problem is an `InputError` (a `ValueError`) whose message starts with the file name and says what is
wrong, so the command line prints it as one line. Sizes are read from the PNG/JPEG header before the
pixels are decoded: a 20000 x 20000 picture is refused without allocating 1.2 GB.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from agent.protocol.errors import UserError

MAX_PIXELS = 40_000_000  # about 6300 x 6300; a 20000 x 20000 picture is refused before decoding
MAX_FRAMES = 10_000
IMAGE_SUFFIXES = {".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff"}
VIDEO_SUFFIXES = {".mp4", ".avi", ".mov", ".mkv", ".webm", ".mpg", ".mpeg"}
STRIP_SIDE = 64  # Weizmann strips: 64 x 64 frames side by side
MIN_CLIP_FRAMES = 3  # a person is found in a clip by what moves between frames: fewer hold too little motion


class InputError(UserError, ValueError):
    """A file the user gave cannot be used; the message names the file and the problem."""


def _header_size(path: Path) -> tuple[int, int] | None:
    """(width, height) from a PNG/JPEG header without decoding the pixels; None if not found."""
    with open(path, "rb") as f:
        data = f.read(262144)
    if data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) >= 24:
        return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    if data[:2] == b"\xff\xd8":
        i = 2
        while i + 9 < len(data):
            if data[i] != 0xFF:
                i += 1
                continue
            marker = data[i + 1]
            if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7 or marker == 0xFF:
                i += 1 if marker == 0xFF else 2
                continue
            if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):  # start of frame
                return int.from_bytes(data[i + 7 : i + 9], "big"), int.from_bytes(data[i + 5 : i + 7], "big")
            i += 2 + int.from_bytes(data[i + 2 : i + 4], "big")
    return None


def _ends_with_eoi(data: np.ndarray) -> bool:
    """A complete JPEG ends with the end-of-image marker FF D9 (some cameras pad it with zero bytes)."""
    nz = np.flatnonzero(data)
    return len(nz) >= 2 and data[nz[-1] - 1 : nz[-1] + 1].tobytes() == b"\xff\xd9"


def check_image(img: np.ndarray | None, path: Path) -> np.ndarray:
    """Refuse a missing, empty or uniform (all white / all one colour) picture."""
    if img is None or img.size == 0:
        raise InputError(f"{path}: unreadable or truncated image")
    _mean, std = cv2.meanStdDev(img)
    if float(std.max()) < 2.0:
        kind = "all white" if float(_mean.mean()) > 200 else "uniform colour"
        raise InputError(f"{path}: image is empty ({kind}, nothing to see)")
    return img


def load_image(path: str | Path) -> np.ndarray:
    """One picture as BGR uint8. Raises InputError: missing, not a file, too large, unreadable/truncated,
    empty/all white."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if not path.is_file():
        raise InputError(f"{path}: not a file")
    if path.stat().st_size == 0:
        raise InputError(f"{path}: empty file (0 bytes)")
    size = _header_size(path)
    if size and size[0] * size[1] > MAX_PIXELS:
        raise InputError(f"{path}: image too large ({size[0]} x {size[1]} pixels; limit {MAX_PIXELS} pixels)")
    if size and (size[0] == 0 or size[1] == 0):
        raise InputError(f"{path}: image has no pixels ({size[0]} x {size[1]})")
    data = np.fromfile(path, dtype=np.uint8)
    if data[:2].tobytes() == b"\xff\xd8" and not _ends_with_eoi(data):
        raise InputError(f"{path}: truncated JPEG (no end-of-image marker)")
    img = cv2.imdecode(data, cv2.IMREAD_COLOR)
    return check_image(img, path)


def split_strip(img: np.ndarray, side: int = STRIP_SIDE) -> list[np.ndarray] | None:
    """The frames of a Weizmann strip (side x side frames left to right), or None if img is not one."""
    h, w = img.shape[:2]
    if h == side and w % side == 0 and w >= 2 * side:
        return [np.ascontiguousarray(img[:, k : k + side]) for k in range(0, w, side)]
    return None


def load_video(path: Path) -> list[np.ndarray]:
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        raise InputError(f"{path}: unreadable video")
    w, h = cap.get(cv2.CAP_PROP_FRAME_WIDTH), cap.get(cv2.CAP_PROP_FRAME_HEIGHT)
    if w * h > MAX_PIXELS:
        cap.release()
        raise InputError(f"{path}: video frames too large ({int(w)} x {int(h)})")
    frames: list[np.ndarray] = []
    try:
        while len(frames) < MAX_FRAMES:
            ok, frame = cap.read()
            if not ok:
                break
            frames.append(frame)
    finally:
        cap.release()
    if not frames:
        raise InputError(f"{path}: unreadable video (no frames decoded)")
    return frames


def load_frames(path: str | Path) -> list[np.ndarray]:
    """Frames in time order (BGR uint8): one image -> [image]; a folder of images (sorted by name); a video
    file; a Weizmann strip PNG (64 x 64 frames side by side). Raises InputError naming the file."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file or folder")
    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)
        if not files:
            raise InputError(f"{path}: folder holds no images")
        frames = [load_image(p) for p in files]
        if len({f.shape for f in frames}) != 1:
            raise InputError(f"{path}: frames differ in size")
        return frames
    if path.suffix.lower() in VIDEO_SUFFIXES:
        return load_video(path)
    img = load_image(path)
    return split_strip(img) or [img]


def is_clip(path: str | Path, frames: list[np.ndarray]) -> bool:
    """A person in a static-camera clip: a video file, or a Weizmann strip (STRIP_SIDE-pixel square frames
    side by side), of at least MIN_CLIP_FRAMES frames. A folder is a sequence of hand photographs and a
    single picture one photograph (`frames`: what load_frames read from `path`)."""
    path = Path(path)
    if path.is_dir() or len(frames) < MIN_CLIP_FRAMES:
        return False
    return path.suffix.lower() in VIDEO_SUFFIXES or frames[0].shape[:2] == (STRIP_SIDE, STRIP_SIDE)
