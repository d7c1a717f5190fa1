"""The learned models shipped in the package (perception/data/models), run on the CPU.

The four TensorFlow Lite files are MediaPipe's (Apache-2.0, perception/data/models/LICENSE-mediapipe.txt),
copied unchanged from the mediapipe 0.10.21 wheel on PyPI, the last release that bundled them:
`palm_detection_lite.tflite` and `hand_landmark_lite.tflite` (the hand landmarker's two stages),
`hand_landmark_full.tflite` (its larger landmark model, read where the two classifiers disagree:
hand_detector.full_pose) and `selfie_segmentation.tflite` (a person's silhouette). Nothing is fetched at run
time (README, "Dependencies": why not mediapipe itself).

Two runners, one answer (`run_model`: the same outputs within float rounding, tests/test_perception_models.py):
- "litert" (the default where it is installed): Google's LiteRT interpreter (`ai-edge-litert`, the TFLite
  runtime MediaPipe itself runs these files with, XNNPACK kernels), one thread;
- "opencv": OpenCV's DNN module (`cv2.dnn.readNetFromTFLite`), already a dependency: used where LiteRT has
  no wheel. It is 3-4 times slower on these files (palm detection 31 ms against 8, a landmark pass 13
  against 4, on this machine's cores: its 5 x 5 depthwise convolutions have no fast kernel), which is what
  kept a room frame above 50 ms.
A file that is missing or does not load is a `ModelError` naming it, one line.
"""

from __future__ import annotations

import hashlib
import os
import threading
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from agent.protocol.errors import UserError

MODELS_DIR = Path(__file__).resolve().parent / "data" / "models"
# sha256 of each shipped file: a truncated or replaced file is named, not run
SHA256 = {
    "palm_detection_lite.tflite": "e9a4aaddf90dda56a87235303cf00e4c2d3fb28725f68fd88772997dac905c18",
    "hand_landmark_lite.tflite": "048edd3645c9bf7397d19a9f6e3a42957d6e414c9bea6598030a2e9b624156e6",
    "hand_landmark_full.tflite": "11c272b891e1a99ab034208e23937a8008388cf11ed2a9d776ed3d01d0ba00e3",
    "selfie_segmentation.tflite": "9ee168ec7c8f2a16c56fe8e1cfbc514974cbbb7e434051b455635f1bd1462f5c",
}
RUNNERS = ("litert", "opencv")
# One thread: the camera's frame is read while the swarm's agent processes use the cores (and on two
# cores one thread was as fast: palm detection 8.1 ms, two threads 9.5).
LITERT_THREADS = 1

_nets: dict[tuple[str, str, int], object] = {}
_lock = threading.Lock()
_loading = threading.Lock()  # one load at a time: _quiet_stderr's fd 2 must come back as it was


class ModelError(UserError):
    """A shipped model file is missing or corrupt; the message names it (the command line prints it as one
    line and exits 1)."""


def model_path(name: str, folder: Path | None = None) -> Path:
    return (folder or MODELS_DIR) / name


def default_runner() -> str:
    """'litert' when its package is installed, else 'opencv'."""
    try:
        import ai_edge_litert.interpreter  # noqa: F401
    except ImportError:
        return "opencv"
    return "litert"


def _checked_bytes(path: Path, name: str) -> bytes:
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ModelError(
            f"{path}: the model file cannot be read ({exc.strerror or exc}); reinstall fluidswarm"
        ) from None
    if name in SHA256 and hashlib.sha256(data).hexdigest() != SHA256[name]:
        raise ModelError(f"{path}: the model file is corrupt (its checksum differs from the shipped one); reinstall")
    return data


def _quiet_stderr():
    """fd 2 pointed at /dev/null until the returned function is called: LiteRT's C++ side prints an INFO line
    ("Created TensorFlow Lite XNNPACK delegate") on every interpreter it builds, which no setting turns off,
    and the command line's stderr is for one-line errors."""
    saved = os.dup(2)
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 2)
    os.close(null)

    def restore() -> None:
        os.dup2(saved, 2)
        os.close(saved)

    return restore


def _load(name: str, folder: Path | None, runner: str):
    path = model_path(name, folder)
    data = _checked_bytes(path, name)
    if runner == "opencv":
        try:
            net = cv2.dnn.readNetFromTFLite(str(path))
        except cv2.error:
            raise ModelError(f"{path}: the model file does not load as a TensorFlow Lite model; reinstall") from None
        net.setPreferableBackend(cv2.dnn.DNN_BACKEND_OPENCV)
        return net
    from ai_edge_litert.interpreter import Interpreter

    restore = _quiet_stderr()
    try:
        interpreter = Interpreter(model_content=data, num_threads=LITERT_THREADS)
        interpreter.allocate_tensors()
    except (ValueError, RuntimeError):
        raise ModelError(f"{path}: the model file does not load as a TensorFlow Lite model; reinstall") from None
    finally:
        restore()
    return interpreter


def load_net(name: str, folder: Path | None = None, runner: str | None = None):
    """The model in `name` (one of SHA256) for `runner` (default `default_runner()`), checked and loaded
    once per thread (neither runner's object may be shared between threads). Raises ModelError."""
    runner = runner or default_runner()
    if runner not in RUNNERS:
        raise ValueError(f"runner must be one of {', '.join(RUNNERS)}, got {runner!r}")
    key = (str(model_path(name, folder)), runner, threading.get_ident())
    with _lock:
        if key in _nets:
            return _nets[key]
    with _loading:
        net = _load(name, folder, runner)
    with _lock:
        _nets[key] = net
    return net


def run_model(name: str, square_rgb: np.ndarray, outputs: Sequence[str], runner: str | None = None) -> list[np.ndarray]:
    """The model `name` on one square RGB uint8 picture of its input size (scaled to 0..1, as MediaPipe
    feeds these models); its `outputs` by name, in that order, each as the runner shapes it (callers
    reshape). Raises ModelError."""
    runner = runner or default_runner()
    net = load_net(name, runner=runner)
    if runner == "opencv":
        assert isinstance(net, cv2.dnn.Net)
        net.setInput(cv2.dnn.blobFromImage(square_rgb, 1.0 / 255.0))  # NCHW, as OpenCV's importer wants
        return [np.asarray(o) for o in net.forward(list(outputs))]
    x = (square_rgb.astype(np.float32) / 255.0)[None]  # NHWC, the file's own layout
    net.set_tensor(net.get_input_details()[0]["index"], x)
    net.invoke()
    by_name = {d["name"]: d["index"] for d in net.get_output_details()}
    return [np.array(net.get_tensor(by_name[o])) for o in outputs]
