"""Bad input: each gives one line naming the file and the problem, exit 1, no traceback."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from fluidswarm.cli import main
from perception.dataset import load_folder
from perception.io import InputError, load_frames, load_image


def run_cli(capsys, *argv):
    code = main(list(argv))
    err = capsys.readouterr().err.strip()
    return code, err


def assert_one_line_error(capsys, argv, path, problem):
    code, err = run_cli(capsys, *argv)
    assert code == 1, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert str(path) in err and problem in err, err


def noise(h=100, w=100, seed=0):
    return np.random.default_rng(seed).integers(0, 255, (h, w, 3), dtype=np.uint8)


def test_missing_file(tmp_path, capsys):
    p = tmp_path / "missing.jpg"
    with pytest.raises(InputError, match="no such file"):
        load_image(p)
    assert_one_line_error(capsys, ["perceive", str(p), "--out", str(tmp_path / "o.png")], p, "no such file")


def test_unreadable_file(tmp_path, capsys):
    p = tmp_path / "notes.png"
    p.write_bytes(b"this is not a picture at all" * 10)
    assert_one_line_error(capsys, ["perceive", str(p), "--out", str(tmp_path / "o.png")], p, "unreadable")


def test_truncated_jpeg(tmp_path, capsys):
    _ok, buf = cv2.imencode(".jpg", noise())
    p = tmp_path / "cut.jpg"
    p.write_bytes(buf.tobytes()[: len(buf) // 2])  # half a JPEG: OpenCV would decode a grey bottom half
    with pytest.raises(InputError, match="truncated"):
        load_image(p)
    assert_one_line_error(capsys, ["perceive", str(p), "--out", str(tmp_path / "o.png")], p, "truncated")


def test_truncated_png(tmp_path):
    _ok, buf = cv2.imencode(".png", noise())
    p = tmp_path / "cut.png"
    p.write_bytes(buf.tobytes()[:300])
    with pytest.raises(InputError, match="unreadable or truncated"):
        load_image(p)


@pytest.mark.parametrize("value", [255, 0])
def test_empty_or_all_white_image(tmp_path, capsys, value):
    p = tmp_path / f"blank{value}.png"
    cv2.imwrite(str(p), np.full((100, 100, 3), value, np.uint8))
    assert_one_line_error(capsys, ["perceive", str(p), "--out", str(tmp_path / "o.png")], p, "empty")


def test_zero_byte_file(tmp_path, capsys):
    p = tmp_path / "zero.jpg"
    p.write_bytes(b"")
    assert_one_line_error(capsys, ["perceive", str(p), "--out", str(tmp_path / "o.png")], p, "empty file")


def test_20000_by_20000_png_is_refused_from_its_header(tmp_path, capsys):
    p = tmp_path / "huge.png"
    ihdr = b"IHDR" + (20000).to_bytes(4, "big") * 2 + b"\x08\x02\x00\x00\x00"
    p.write_bytes(b"\x89PNG\r\n\x1a\n" + (13).to_bytes(4, "big") + ihdr + b"\x00" * 100)
    assert_one_line_error(capsys, ["perceive", str(p), "--out", str(tmp_path / "o.png")], p, "too large")


def test_20000_by_20000_jpeg_is_refused_from_its_header(tmp_path):
    _ok, buf = cv2.imencode(".jpg", noise(16, 16))
    data = bytearray(buf.tobytes())
    i = data.find(b"\xff\xc0")
    data[i + 5 : i + 9] = (20000).to_bytes(2, "big") * 2  # height, width in the start-of-frame header
    p = tmp_path / "huge.jpg"
    p.write_bytes(bytes(data))
    with pytest.raises(InputError, match="too large"):
        load_image(p)


def test_video_with_no_motion(tmp_path, capsys):
    p = tmp_path / "still.avi"
    writer = cv2.VideoWriter(str(p), cv2.VideoWriter_fourcc(*"MJPG"), 10, (64, 64))
    frame = noise(64, 64, seed=3)
    for _ in range(20):
        writer.write(frame)
    writer.release()
    assert len(load_frames(p)) == 20
    assert_one_line_error(capsys, ["perceive", str(p), "--out", str(tmp_path / "o.png")], p, "no motion")


def test_folder_without_frames(tmp_path, capsys):
    d = tmp_path / "frames"
    d.mkdir()
    assert_one_line_error(capsys, ["perceive", str(d), "--out", str(tmp_path / "o.png")], d, "no images")


def make_class_tree(root, classes=("a", "b"), n=2):
    for c in classes:
        (root / c).mkdir(parents=True)
        for k in range(n):
            cv2.imwrite(str(root / c / f"{k}.png"), noise(seed=k))


def test_unknown_class_folder_layout(tmp_path, capsys):
    flat = tmp_path / "flat"
    flat.mkdir()
    for k in range(3):
        cv2.imwrite(str(flat / f"{k}.png"), noise(seed=k))
    with pytest.raises(InputError, match="unknown class folder layout"):
        load_folder(flat)
    good = tmp_path / "good"
    make_class_tree(good)
    assert_one_line_error(
        capsys, ["eval-classifier", "--train", str(flat), "--test", str(good)], flat, "unknown class folder layout"
    )
    one = tmp_path / "one"
    make_class_tree(one, classes=("a",))
    assert_one_line_error(
        capsys, ["eval-classifier", "--train", str(good), "--test", str(one)], one, "unknown class folder layout"
    )
    empty_class = tmp_path / "emptyclass"
    make_class_tree(empty_class)
    (empty_class / "c").mkdir()
    assert_one_line_error(
        capsys,
        ["eval-classifier", "--train", str(empty_class), "--test", str(good)],
        empty_class / "c",
        "holds no images",
    )


def test_eval_classifier_with_folders_runs_on_a_tiny_set(tmp_path, capsys):
    train, test = tmp_path / "train", tmp_path / "test"
    for root, seeds in ((train, range(6)), (test, range(6, 8))):
        for c, colour in (("dark", 60), ("light", 190)):
            (root / c).mkdir(parents=True)
            for s in seeds:
                img = np.full((100, 100, 3), 245, np.uint8)
                rng = np.random.default_rng(s)
                cv2.circle(img, (50 + int(rng.integers(-5, 5)), 50), 30 if c == "dark" else 15, (colour,) * 3, -1)
                cv2.imwrite(str(root / c / f"{s}.png"), img)
    code = main(["eval-classifier", "--train", str(train), "--test", str(test), "--method", "baseline"])
    out = capsys.readouterr().out
    assert code == 0
    assert out.strip().splitlines()[-1].startswith("accuracy=")
    assert "components=  35" in out and "confusion matrix" in out
