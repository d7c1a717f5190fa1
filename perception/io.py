"""Reading what the camera saw: an image, a folder of frames, a video, or a Weizmann strip PNG.

Every problem is a `InputError` naming the file and the problem (one line, no traceback at the CLI).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

MAX_PIXELS = 40_000_000  # a 20000 x 20000 picture is refused before decoding
IMAGE_SUFFIXES = {".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff"}
VIDEO_SUFFIXES = {".mp4", ".avi", ".mov", ".mkv", ".webm"}


class InputError(ValueError):
    pass


def _header_size(path: Path) -> tuple[int, int] | None:
    """(width, height) from a PNG/JPEG header without decoding the pixels."""
    data = path.read_bytes()[:65536]
    if data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) >= 24:
        return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    if data[:2] == b"\xff\xd8":
        i = 2
        while i + 9 < len(data):
            if data[i] != 0xFF:
                i += 1
                continue
            marker = data[i + 1]
            if marker in (0xC0, 0xC1, 0xC2):
                return int.from_bytes(data[i + 7:i + 9], "big"), int.from_bytes(data[i + 5:i + 7], "big")
            i += 2 + int.from_bytes(data[i + 2:i + 4], "big")
    return None


def load_image(path: str | Path) -> np.ndarray:
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if not path.is_file():
        raise InputError(f"{path}: not a file")
    size = _header_size(path)
    if size and size[0] * size[1] > MAX_PIXELS:
        raise InputError(f"{path}: image too large ({size[0]} x {size[1]} pixels; limit {MAX_PIXELS})")
    img = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if img is None or img.size == 0:
        raise InputError(f"{path}: unreadable or truncated image")
    if float(img.std()) < 2.0:
        raise InputError(f"{path}: image is empty (uniform {'white' if img.mean() > 200 else 'colour'})")
    return img


def load_frames(path: str | Path) -> list[np.ndarray]:
    """Frames in time order: one image; a folder of images; a video; a strip of 64 x 64 frames."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file or folder")
    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        if not files:
            raise InputError(f"{path}: folder holds no images")
        return [load_image(p) for p in files]
    if path.suffix.lower() in VIDEO_SUFFIXES:
        cap = cv2.VideoCapture(str(path))
        frames = []
        while len(frames) < 10000:
            ok, frame = cap.read()
            if not ok:
                break
            frames.append(frame)
        cap.release()
        if not frames:
            raise InputError(f"{path}: unreadable video")
        return frames
    img = load_image(path)
    h, w = img.shape[:2]
    if h == 64 and w % 64 == 0 and w >= 128:  # a Weizmann strip: 64 x 64 frames side by side
        return [img[:, k:k + 64] for k in range(0, w, 64)]
    return [img]
