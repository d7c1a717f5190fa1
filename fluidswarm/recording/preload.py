"""Modules a process will need later, imported meanwhile on a thread of their own (render.py's figures while a
run's processes stop, the recorder's fidelity measure while it records)."""

from __future__ import annotations

import importlib
import threading


def preload(*modules: str) -> None:
    """Import `modules` on a daemon thread, now: whoever imports one of them later finds it loaded, or (Python's
    import lock) waits for the same import, never repeats it."""

    def load() -> None:
        for name in modules:
            importlib.import_module(name)

    threading.Thread(target=load, name=f"preload-{modules[0]}", daemon=True).start()
