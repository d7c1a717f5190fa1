"""`make fuzz`: every decoder's fuzz target for FUZZ_SECONDS each, one after the other (2 cores: one engine at
a time), with one line per target: `fuzz target=<engine>/<name> inputs=<n> seconds=<s> crashes=<k>`.

Rust targets (agent/native/fuzz, cargo-fuzz/libFuzzer, built with debug assertions so an integer overflow is a
crash too) and Python ones (fuzz/python_targets.py under atheris). Each starts from its seeds (fuzz/seeds.py)
plus the corpus earlier runs kept (agent/native/fuzz/corpus/, not committed). A crash leaves its input in
agent/native/fuzz/artifacts/<engine>_<name>/ and makes the command exit 1; the minimised input belongs in
tests/vectors/fuzz.json with a fix (docs/benchmarks/fuzz.md).

    python fuzz/run.py [--seconds S] [--only NAME,...]      the driver
    python fuzz/run.py --atheris NAME CORPUS [libFuzzer flags]  one Python target (what the driver starts)
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
NATIVE = REPO / "agent" / "native"
FUZZ_DIR = NATIVE / "fuzz"
CARGO = os.environ.get("CARGO") or shutil.which("cargo") or str(Path.home() / ".cargo" / "bin" / "cargo")
TOOLCHAIN = "+nightly"  # libFuzzer's coverage instrumentation needs nightly rustc flags (cargo-fuzz's own rule)
_EXECUTED = re.compile(rb"stat::number_of_executed_units:\s*(\d+)")
_DONE = re.compile(rb"Done (\d+) runs in (\d+) second")


def _atheris_child(name: str, libfuzzer_args: list[str]) -> None:
    import atheris

    sys.path.insert(0, str(REPO))
    sys.path.insert(0, str(HERE))
    # Coverage of the project's decoders and what they parse with (mcap, tomllib: pure Python).
    with atheris.instrument_imports(include=["agent", "fluidswarm", "mcap", "tomllib", "python_targets"]):
        import python_targets
    target = python_targets.TARGETS[name]
    atheris.Setup([sys.argv[0], *libfuzzer_args], target)
    try:
        atheris.Fuzz()
    finally:
        python_targets.cleanup()


def _write_seeds(corpus: Path, seeds: list[bytes]) -> None:
    import hashlib

    corpus.mkdir(parents=True, exist_ok=True)
    for s in seeds:
        (corpus / f"seed-{hashlib.sha1(s).hexdigest()[:16]}").write_bytes(s)


def _build_rust() -> Path:
    """Build every Rust target (cargo fuzz builds all or one); the directory of their binaries."""
    # cargo fuzz has no --locked: check first that the committed Cargo.lock resolves as it is
    subprocess.run(
        [
            CARGO,
            TOOLCHAIN,
            "metadata",
            "--locked",
            "--format-version",
            "1",
            "--manifest-path",
            str(FUZZ_DIR / "Cargo.toml"),
        ],
        check=True,
        stdout=subprocess.DEVNULL,
    )
    subprocess.run([CARGO, TOOLCHAIN, "fuzz", "build", "--release", "--debug-assertions"], cwd=NATIVE, check=True)
    rustc = str(Path(CARGO).with_name("rustc"))
    about = subprocess.run([rustc, TOOLCHAIN, "-vV"], capture_output=True, text=True, check=True).stdout
    host = next(line.split()[1] for line in about.splitlines() if line.startswith("host:"))
    return FUZZ_DIR / "target" / host / "release"


def _run(label: str, cmd: list[str], seconds: int, artifacts: Path, log: Path) -> tuple[int, int, bool]:
    """(inputs tried, crashes, ok) of one libFuzzer run."""
    if artifacts.exists():
        shutil.rmtree(artifacts)
    artifacts.mkdir(parents=True)
    t0 = time.monotonic()
    with open(log, "wb") as out:
        proc = subprocess.run(
            [
                *cmd,
                f"-max_total_time={seconds}",
                "-print_final_stats=1",
                "-timeout=30",
                "-rss_limit_mb=2048",
                f"-artifact_prefix={artifacts}/",
            ],
            stdout=out,
            stderr=subprocess.STDOUT,
            timeout=seconds + 300,
        )
    text = log.read_bytes()
    m = _EXECUTED.findall(text) or [d[0] for d in _DONE.findall(text)]
    inputs = int(m[-1]) if m else 0
    crashes = len(list(artifacts.iterdir()))
    ok = proc.returncode == 0 and crashes == 0
    print(
        f"fuzz target={label} inputs={inputs} seconds={time.monotonic() - t0:.0f} crashes={crashes}"
        + ("" if ok else f" exit={proc.returncode} log={log} artifacts={artifacts}"),
        flush=True,
    )
    return inputs, crashes, ok


def main(argv: list[str]) -> int:
    if argv[:1] == ["--atheris"]:
        _atheris_child(argv[1], argv[2:])
        return 0
    sys.path.insert(0, str(REPO))
    import seeds

    ap = argparse.ArgumentParser(description="run every fuzz target for --seconds each")
    ap.add_argument("--seconds", type=int, default=int(os.environ.get("FUZZ_SECONDS", "30")))
    ap.add_argument("--only", default="", help="comma-separated targets (rust/wire, python/mcap, or a bare name)")
    args = ap.parse_args(argv)
    if args.seconds < 1:
        print(f"fuzz: --seconds must be >= 1, got {args.seconds}", file=sys.stderr)
        return 2
    wanted = {w for w in args.only.split(",") if w}

    def chosen(engine: str, name: str) -> bool:
        return not wanted or name in wanted or f"{engine}/{name}" in wanted

    rust = [n for n in seeds.RUST if chosen("rust", n)]
    python = [n for n in seeds.PYTHON if chosen("python", n)]
    logs = FUZZ_DIR / "logs"
    logs.mkdir(parents=True, exist_ok=True)
    results = []
    if rust:
        out_dir = _build_rust()
        for name in rust:
            corpus = FUZZ_DIR / "corpus" / f"rust_{name}"
            _write_seeds(corpus, seeds.RUST[name]())
            results.append(
                _run(
                    f"rust/{name}",
                    [str(out_dir / name), str(corpus)],
                    args.seconds,
                    FUZZ_DIR / "artifacts" / f"rust_{name}",
                    logs / f"rust_{name}.log",
                )
            )
    for name in python:
        corpus = FUZZ_DIR / "corpus" / f"python_{name}"
        _write_seeds(corpus, seeds.PYTHON[name]())
        results.append(
            _run(
                f"python/{name}",
                [sys.executable, str(Path(__file__).resolve()), "--atheris", name, str(corpus)],
                args.seconds,
                FUZZ_DIR / "artifacts" / f"python_{name}",
                logs / f"python_{name}.log",
            )
        )
    failed = sum(not ok for _, _, ok in results)
    print(f"fuzz targets={len(results)} inputs={sum(i for i, _, _ in results)} failed={failed}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
