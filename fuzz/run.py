"""`make fuzz`: every decoder's fuzz target for FUZZ_SECONDS each, one after the other (2 cores: one engine at
a time), with one line per target: `fuzz target=<engine>/<name> inputs=<n> seconds=<s> crashes=<k>`.

Rust targets (agent/native/fuzz, cargo-fuzz/libFuzzer, built with debug assertions so an integer overflow is a
crash too) and Python ones (fuzz/python_targets.py under atheris). Each starts from its seeds (fuzz/seeds.py)
plus the corpus earlier runs kept (agent/native/fuzz/corpus/, not committed). A crash leaves its input in
agent/native/fuzz/artifacts/<engine>_<name>/ and makes the command exit 1; the input belongs in
tests/vectors/fuzz/<engine>_<name>/ with a fix (docs/benchmarks/fuzz.md).

    python fuzz/run.py [--seconds S] [--runs N] [--only NAME,...]   the driver: S seconds per target, or N
                                                                    inputs (libFuzzer -runs), whichever first
    python fuzz/run.py --atheris NAME CORPUS... [libFuzzer flags]  one Python target (what the driver starts)
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
# The Python targets whose decoder is the Rust one (through agent._native) that a Rust target fuzzes: atheris
# sees no coverage inside the compiled module (its corpus would shrink to the few inputs that differ in the
# Python wrapper), so such a target also starts from the corpus its Rust twin grew under libFuzzer's coverage
# (the same input layout) and keeps every one of those inputs to mutate (-keep_seed=1); new inputs go to the
# Python target's own corpus.
TWINS = {"state": "wire", "ctl": "ctl", "command": "command", "event": "event", "report": "report", "spec": "spec"}
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
    atheris.Fuzz()


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


def _run(
    label: str, cmd: list[str], seconds: int, runs: int, artifacts: Path, log: Path, flags: list[str] | None = None
) -> tuple[int, int, bool]:
    """(inputs tried, crashes, ok) of one libFuzzer run: `seconds` long, or `runs` inputs (0: no bound)."""
    if artifacts.exists():
        shutil.rmtree(artifacts)
    artifacts.mkdir(parents=True)
    t0 = time.monotonic()
    with open(log, "wb") as out:
        proc = subprocess.run(
            [
                *cmd,
                f"-max_total_time={seconds}",
                f"-runs={runs or -1}",
                "-print_final_stats=1",
                "-timeout=30",
                "-rss_limit_mb=2048",
                f"-artifact_prefix={artifacts}/",
                *(flags or []),
            ],
            stdout=out,
            stderr=subprocess.STDOUT,
            timeout=seconds + 300 if seconds else None,
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

    ap = argparse.ArgumentParser(description="run every fuzz target for --seconds each, or to --runs inputs each")
    ap.add_argument("--seconds", type=int, default=None, help="per target (default FUZZ_SECONDS, else 30)")
    ap.add_argument("--runs", type=int, default=0, help="inputs per target; with --seconds, whichever comes first")
    ap.add_argument("--only", default="", help="comma-separated targets (rust/wire, python/mcap, or a bare name)")
    args = ap.parse_args(argv)
    if args.seconds is None:
        args.seconds = 0 if args.runs else int(os.environ.get("FUZZ_SECONDS", "30"))
    if args.runs < 0 or args.seconds < 0 or not (args.runs or args.seconds):
        print(f"fuzz: --seconds and --runs must be >= 1, got {args.seconds} and {args.runs}", file=sys.stderr)
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
                    args.runs,
                    FUZZ_DIR / "artifacts" / f"rust_{name}",
                    logs / f"rust_{name}.log",
                )
            )
    for name in python:
        corpus = FUZZ_DIR / "corpus" / f"python_{name}"
        _write_seeds(corpus, seeds.PYTHON[name]())
        twin = FUZZ_DIR / "corpus" / f"rust_{TWINS.get(name)}"
        twinned = name in TWINS and twin.is_dir()
        dirs = [str(corpus)] + ([str(twin)] if twinned else [])
        results.append(
            _run(
                f"python/{name}",
                [sys.executable, str(Path(__file__).resolve()), "--atheris", name, *dirs],
                args.seconds,
                args.runs,
                FUZZ_DIR / "artifacts" / f"python_{name}",
                logs / f"python_{name}.log",
                ["-keep_seed=1"] if twinned else [],
            )
        )
    failed = sum(not ok for _, _, ok in results)
    print(f"fuzz targets={len(results)} inputs={sum(i for i, _, _ in results)} failed={failed}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
