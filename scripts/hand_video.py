"""Write a test video for `fluidswarm imitate --camera VIDEO --subject hand` from pictures, each shown for
`--seconds` at `--fps` (MJPG), as tests/test_camera_hand.py's `write_video` does:

    .venv/bin/python scripts/hand_video.py OUT.avi PART [PART ...] [--seconds 6] [--fps 8]

A PART is a picture file (a shared hand photograph, say), `blank` (the plain background of the part before,
or of the first picture: its median colour, a hand gone out of the picture), `lowered` (the picture before
moved down out of the picture over the plain background, 5 px every second frame), `white` (a plain white-ish
frame, 235 grey, the size of the first picture) or a Weizmann strip PNG (its frames in turn, enlarged to the
first picture's size; on its own: at its own size). Prints the file and its frame count.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

from perception.io import InputError, load_frames, load_image

SIZE = (100, 100)  # (w, h) of a video made of special parts only


def _plain(picture: np.ndarray) -> np.ndarray:
    colour = np.median(picture.reshape(-1, 3), axis=0).astype(np.uint8)
    return np.broadcast_to(colour, picture.shape).copy()


def parts_to_frames(parts: list[str], seconds: float, fps: float) -> list[np.ndarray]:
    """Every frame of the video, in order."""
    n = int(round(seconds * fps))
    pictures = [p for p in parts if p not in ("blank", "white", "lowered")]
    size = SIZE
    if pictures and not pictures[0].endswith(".png"):
        size = load_image(pictures[0]).shape[1::-1]
    frames: list[np.ndarray] = []
    last: np.ndarray | None = None
    for part in parts:
        if part == "white":
            frames += [np.full((size[1], size[0], 3), 235, np.uint8)] * n
        elif part == "blank":
            ref = last if last is not None else (load_image(pictures[0]) if pictures else None)
            plain = _plain(ref) if ref is not None else np.full((size[1], size[0], 3), 235, np.uint8)
            frames += [plain] * n
        elif part == "lowered":
            if last is None:
                raise InputError("lowered: give a picture before it")
            plain = _plain(last)
            for k in range(5, last.shape[0], 5):
                moved = plain.copy()
                moved[k:] = last[: last.shape[0] - k]
                frames += [moved, moved]
        elif part.endswith(".png") and "weizmann" in part:
            clip = [f if f.ndim == 3 else cv2.cvtColor(f, cv2.COLOR_GRAY2BGR) for f in load_frames(part)]
            clip = [cv2.resize(f, size, interpolation=cv2.INTER_LINEAR) for f in clip]
            frames += [clip[i % len(clip)] for i in range(n)]
            last = clip[-1]
        else:
            last = cv2.resize(load_image(part), size, interpolation=cv2.INTER_AREA)
            frames += [last] * n
    return frames


def write_video(path: Path, frames: list[np.ndarray], fps: float) -> None:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, frames[0].shape[1::-1])
    for f in frames:
        writer.write(f)
    writer.release()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("parts", nargs="+", help="picture files, 'blank', 'white' or Weizmann strip PNGs")
    ap.add_argument("--seconds", type=float, default=6.0, help="each part is shown this long")
    ap.add_argument("--fps", type=float, default=8.0)
    args = ap.parse_args(argv)
    try:
        frames = parts_to_frames(args.parts, args.seconds, args.fps)
    except InputError as exc:
        print(f"hand_video: {exc}", file=sys.stderr)
        return 1
    write_video(args.out, frames, args.fps)
    print(f"{args.out} frames={len(frames)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
