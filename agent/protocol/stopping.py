"""How our long-running processes (router, recorder, coordinator) are told to stop: SIGTERM (what
swarmhost.supervisor.stop_process and the launcher send) or SIGINT (Ctrl-C) set a flag, nothing else.

A flag, not an exception: an exception raised from a handler lands wherever the main thread happens to be.
In the recorder it once landed inside a step's write, after the step's states had been taken and before they
were written, and lost the whole step (CI, 2026-11-27: sequence_cylindrical_pinching lacked step 799 of 800).
"""

from __future__ import annotations

import signal
import threading


def stop_on_signals() -> threading.Event:
    """An event that SIGTERM and SIGINT set; the process's loop checks it and ends cleanly."""
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *a: stop.set())
    signal.signal(signal.SIGINT, lambda *a: stop.set())
    return stop
