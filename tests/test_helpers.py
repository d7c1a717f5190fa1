"""swarmhost/helpers.py: a helper process of the run that ends is named in one line, with how and when; a planned
end (a failure injected on purpose) and a finished job (exit 0, where allowed) are not losses."""

from __future__ import annotations

import signal
import subprocess

import pytest

from swarmhost.helpers import HelperLost, Helpers, describe_exit


def started(*cmd: str) -> subprocess.Popen:
    return subprocess.Popen(list(cmd), stdin=subprocess.DEVNULL)


def test_a_killed_helper_is_named_with_its_signal_its_time_and_the_step():
    helpers = Helpers(step=lambda: 412)
    proc = started("sleep", "30")
    try:
        helpers.watch("embedded router (fluidswarm-router, pid 1)", proc, why=lambda: "its last words")
        helpers.check()  # alive: nothing to say
        proc.send_signal(signal.SIGKILL)
        proc.wait(5)
        with pytest.raises(HelperLost) as info:
            helpers.check()
        text = str(info.value)
        assert text.startswith(
            "lost the embedded router (fluidswarm-router, pid 1): it was killed by signal 9 (SIGKILL)"
        )
        assert "s into the run, at step 412 (its last words); the swarm was stopped" in text and "\n" not in text
        with pytest.raises(HelperLost):  # and again at every later check
            helpers.check()
    finally:
        proc.kill()
        proc.wait()


def test_planned_ends_and_finished_jobs_are_not_losses():
    helpers = Helpers()
    planned, done, failed = started("sleep", "30"), started("true"), started("false")
    try:
        helpers.watch("coordinator", planned, fine_exit=True)
        helpers.expect_loss(planned)
        planned.kill()
        planned.wait()
        helpers.watch("coordinator", done, fine_exit=True)
        done.wait()
        helpers.check()
        helpers.watch("recorder", failed)
        failed.wait()
        with pytest.raises(HelperLost, match="lost the recorder: it exited with code 1 .* before the first step"):
            helpers.check()
    finally:
        for p in (planned, done, failed):
            if p.poll() is None:
                p.kill()


def test_a_helper_stopped_by_the_launcher_itself_is_forgotten():
    helpers = Helpers()
    proc = started("sleep", "30")
    helpers.watch("recorder", proc)
    helpers.forget(proc)
    proc.terminate()
    proc.wait()
    helpers.check()
    assert describe_exit(-15) == "was killed by signal 15 (SIGTERM)" and describe_exit(2) == "exited with code 2"
