"""The learned models shipped in the package (perception/data/models), run by OpenCV's DNN module.

The three TensorFlow Lite files are MediaPipe's (Apache-2.0, perception/data/models/LICENSE-mediapipe.txt),
copied unchanged from the mediapipe 0.10.21 wheel on PyPI, the last release that bundled them:
`palm_detection_lite.tflite` and `hand_landmark_lite.tflite` (the hand landmarker's two stages) and
`selfie_segmentation.tflite` (a person's silhouette). They run with `cv2.dnn.readNetFromTFLite` of the
opencv-python-headless the project already pins, so no runtime is added and nothing is fetched at run time
(README, "Dependencies": why not mediapipe itself). A file that is missing or does not load is a
`ModelError` naming it, one line.
"""

from __future__ import annotations

import hashlib
import threading
from pathlib import Path

import cv2

from agent.protocol.errors import UserError

MODELS_DIR = Path(__file__).resolve().parent / "data" / "models"
# sha256 of each shipped file: a truncated or replaced file is named, not run
SHA256 = {
    "palm_detection_lite.tflite": "e9a4aaddf90dda56a87235303cf00e4c2d3fb28725f68fd88772997dac905c18",
    "hand_landmark_lite.tflite": "048edd3645c9bf7397d19a9f6e3a42957d6e414c9bea6598030a2e9b624156e6",
    "selfie_segmentation.tflite": "9ee168ec7c8f2a16c56fe8e1cfbc514974cbbb7e434051b455635f1bd1462f5c",
}

_nets: dict[tuple[str, int], cv2.dnn.Net] = {}
_lock = threading.Lock()


class ModelError(UserError):
    """A shipped model file is missing or corrupt; the message names it (the command line prints it as one
    line and exits 1)."""


def model_path(name: str, folder: Path | None = None) -> Path:
    return (folder or MODELS_DIR) / name


def load_net(name: str, folder: Path | None = None) -> cv2.dnn.Net:
    """The network in `name` (one of SHA256), checked and loaded once per thread (a cv2.dnn.Net is not
    shared between threads). Raises ModelError."""
    path = model_path(name, folder)
    key = (str(path), threading.get_ident())
    with _lock:
        if key in _nets:
            return _nets[key]
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ModelError(
            f"{path}: the model file cannot be read ({exc.strerror or exc}); reinstall fluidswarm"
        ) from None
    if name in SHA256 and hashlib.sha256(data).hexdigest() != SHA256[name]:
        raise ModelError(f"{path}: the model file is corrupt (its checksum differs from the shipped one); reinstall")
    try:
        net = cv2.dnn.readNetFromTFLite(str(path))
    except cv2.error:
        raise ModelError(f"{path}: the model file does not load as a TensorFlow Lite model; reinstall") from None
    net.setPreferableBackend(cv2.dnn.DNN_BACKEND_OPENCV)
    with _lock:
        _nets[key] = net
    return net
