"""The one progress line of the project (swarm runs and renders), dependency-free, on stderr."""

from __future__ import annotations

import sys
import time
from typing import Self, TextIO


class Progress:
    """`label [#####     ] 12/40  detail  detail`.

    On a terminal the line is redrawn in place at most every `interval` s (0.2); into a file or a pipe a
    new line is written at most every `log_interval` s (5), so a log is not flooded. The first and the
    last state are always drawn. Use as `with Progress(40, "render") as bar: ... bar.update()`, or call
    `show(done, details...)` with an absolute count and `close()` at the end.
    """

    def __init__(
        self,
        total: int,
        label: str = "",
        stream: TextIO | None = None,
        width: int = 30,
        interval: float = 0.2,
        log_interval: float = 5.0,
        rate_unit: str = "",
    ):
        self.total, self.label, self.width = max(0, int(total)), label, width
        self.stream = stream if stream is not None else sys.stderr
        self.tty = self.stream.isatty() if hasattr(self.stream, "isatty") else False
        self.interval = interval if self.tty else log_interval
        self.rate_unit = rate_unit  # e.g. "steps": "12.3 steps/s" after the count
        self.done = 0
        self._t0 = time.monotonic()
        self._last = -1e9
        self._details: tuple[str, ...] = ()

    def __enter__(self) -> Self:
        self._draw()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def update(self, n: int = 1) -> None:
        self.show(self.done + n)

    def show(self, done: int, *details: str) -> None:
        self.done, self._details = min(self.total, max(0, int(done))), details
        if time.monotonic() - self._last >= self.interval or self.done == self.total:
            self._draw()

    def close(self) -> None:
        self._draw()
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()

    def _draw(self) -> None:
        now = time.monotonic()
        self._last = now
        filled = self.width * self.done // self.total if self.total else self.width
        parts = [
            f"{self.label} " if self.label else "",
            f"[{'#' * filled}{' ' * (self.width - filled)}] ",
            f"{self.done}/{self.total}",
        ]
        if self.rate_unit:
            parts.append(f"  {self.done / max(now - self._t0, 1e-9):.1f} {self.rate_unit}/s")
        parts += [f"  {d}" for d in self._details]
        line = "".join(parts)
        self.stream.write(("\r" + line) if self.tty else (line + "\n"))
        self.stream.flush()
