"""A dependency-free progress bar on stderr for long renders."""

from __future__ import annotations

import sys
import time
from typing import TextIO


class Progress:
    """`with Progress(total, "render") as bar: ... bar.update()` draws `render [#####     ] 12/40`."""

    def __init__(self, total: int, label: str, stream: TextIO | None = None, width: int = 30, interval: float = 0.1):
        self.total, self.label, self.width, self.interval = max(0, int(total)), label, width, interval
        self.stream = stream if stream is not None else sys.stderr
        self.done = 0
        self._last = 0.0

    def __enter__(self) -> "Progress":
        self._draw()
        return self

    def __exit__(self, *exc) -> None:
        self._draw()
        self.stream.write("\n")
        self.stream.flush()

    def update(self, n: int = 1) -> None:
        self.done = min(self.total, self.done + n)
        now = time.monotonic()
        if now - self._last >= self.interval or self.done == self.total:
            self._draw()

    def _draw(self) -> None:
        self._last = time.monotonic()
        filled = self.width * self.done // self.total if self.total else self.width
        bar = "#" * filled + " " * (self.width - filled)
        self.stream.write(f"\r{self.label} [{bar}] {self.done}/{self.total}")
        self.stream.flush()
