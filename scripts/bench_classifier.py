"""How long does the hand classifier take to train? CPU and wall seconds of `EigenClassifier(method).fit` on a
whole class-folder set (feature extraction included: that is what training costs), repeated, and the size of
the model it saves. The issue's target: training <= 10 s of CPU on the whole shared set.

    flock /tmp/fluidswarm-cpu.lock .venv/bin/python scripts/bench_classifier.py [--train FOLDER] \\
        [--method best|eigen] [--repeats 3] > docs/benchmarks/classifier.txt

A benchmark prints figures; nothing here passes or fails on time (a timed unit test breaks on a loaded
machine and proves nothing on an idle one). CPU time is this process's (one BLAS thread, as training runs).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from perception.dataset import load_folder, shared_hands_root
from perception.eigen import EigenClassifier
from perception.io import InputError


def commit() -> str:
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=True)
        return out.stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--train", help="folder with one sub-folder per class (default: the whole shared hand set)")
    ap.add_argument("--method", choices=["best", "eigen"], default="best")
    ap.add_argument("--repeats", type=int, default=3, help="trainings timed (default 3)")
    args = ap.parse_args(argv)
    if args.repeats < 1:
        print(f"--repeats: need at least 1, got {args.repeats}", file=sys.stderr)
        return 2
    try:
        root = Path(args.train) if args.train else shared_hands_root()
        images, labels, names, _files = load_folder(root)
    except InputError as exc:
        print(exc, file=sys.stderr)
        return 2
    y = np.array(names)[labels]
    load = os.getloadavg()
    print(
        f"# .venv/bin/python scripts/bench_classifier.py  ({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
        f"commit {commit()}, {os.cpu_count()} cores, load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f})"
    )
    print(f"set={root} images={len(images)} classes={len(names)} method={args.method}")
    cpus, walls = [], []
    clf = None
    for k in range(args.repeats):
        t, c = time.perf_counter(), time.process_time()
        clf = EigenClassifier(args.method).fit(images, y)
        cpu, wall = time.process_time() - c, time.perf_counter() - t
        cpus.append(cpu)
        walls.append(wall)
        print(f"  training {k + 1}: cpu_seconds={cpu:.2f} wall_seconds={wall:.2f}")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "model.npz"
        clf.save(path)
        size = path.stat().st_size
    t = time.perf_counter()
    clf.predict(images[:100])
    infer_ms = (time.perf_counter() - t) / min(100, len(images)) * 1000
    print(f"training_cpu_seconds_median={statistics.median(cpus):.2f} min={min(cpus):.2f} max={max(cpus):.2f}")
    print(f"training_wall_seconds_median={statistics.median(walls):.2f} min={min(walls):.2f} max={max(walls):.2f}")
    print(f"model_bytes={size} ({size / 1e6:.1f} MB)")
    print(f"inference_ms_per_image={infer_ms:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
