"""What pyproject.toml cannot say: where cargo is, and one line instead of a traceback when it is not there.

cargo is taken from PATH, else from rustup's default place (~/.cargo/bin; a fresh shell may not have it on
PATH yet, the Makefile does the same). The programs themselves are [[tool.setuptools-rust.bins]].

FLUIDSWARM_PROGRAMS=cargo (the Makefile's editable install): pip builds the extension module only, and the
Makefile builds the programs with cargo beside it (agent/native/target/release, where swarmhost/executable.py
looks first): the two builds then share the 2 cores instead of one waiting for the other (docs/development.md).
A wheel (`pip install .`) still carries both programs.
"""

import os
import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_ext import build_ext

RUSTUP_BIN = Path.home() / ".cargo" / "bin"
PROGRAMS_ENV = "FLUIDSWARM_PROGRAMS"


class build_ext_with_cargo(build_ext):  # setuptools-rust's build_ext builds on this one
    def run(self) -> None:
        if shutil.which("cargo") is None and (RUSTUP_BIN / "cargo").is_file():
            os.environ["PATH"] = f"{RUSTUP_BIN}{os.pathsep}{os.environ.get('PATH', '')}"
        if shutil.which("cargo") is None or shutil.which("rustc") is None:
            raise SystemExit(
                "fluidswarm: building its agent and router programs needs a Rust toolchain "
                "(cargo and rustc on PATH): install one from https://rustup.rs, then pip install again"
            )
        if os.environ.get(PROGRAMS_ENV) == "cargo":
            from setuptools_rust import RustBin

            dist = self.distribution
            dist.rust_extensions = [e for e in dist.rust_extensions if not isinstance(e, RustBin)]  # type: ignore[attr-defined]
        super().run()


setup(cmdclass={"build_ext": build_ext_with_cargo})
