"""Imitation scenarios for `fluidswarm run` / `fluidswarm demo` (fluidswarm/scenario_commands.py)."""

from __future__ import annotations

from pathlib import Path

from coordinator.imitate import imitate
from coordinator.control.imitation_setup import DEFAULT_STEPS
from agent.protocol.errors import UserError


def run_imitation_scenario(sc, agents: int, out: Path, watch: dict | None = None, live: str = ""):
    """Perception -> coordinator -> `agents` agent processes on the scenario's input, with its failures.

    `watch` receives the run's launcher and failure injector (for the robustness figures); `live` (HOST:PORT)
    streams the run to Foxglove."""
    from coordinator.control.fill import ShapeError
    from fluidswarm.failures import FailureInjector
    from fluidswarm.scenario_commands import ProgressLine, RunSummary
    from perception.io import InputError
    from perception.segmentation import SegmentationError

    watch = {} if watch is None else watch
    path = sc.input_path()
    if path is None or not path.exists():
        raise UserError(f"{sc.path}: key 'input': {sc.input} does not exist")
    steps = sc.steps or DEFAULT_STEPS
    drop = {f.agent: {"drop_out": f.fraction} for f in sc.failures if f.kind == "drop"}
    if any(a >= agents for a in drop):
        raise UserError(f"{sc.path}: key 'failures': drop names agent {max(drop)}, the swarm has ids 0..{agents - 1}")

    def hook(launcher, im):
        watch["launcher"] = launcher
        watch["injector"] = FailureInjector(launcher, sc.failures, im.setup.ids, sc.seed,
                                            coordinator=getattr(launcher, "coordinator", None),
                                            spawn_late=getattr(launcher, "spawn_late", None))
        watch["bar"] = ProgressLine(launcher, steps, watch["injector"])

    try:
        res = imitate(str(path), agents=agents, steps=steps, out=out, name=sc.name, controller=sc.controller,
                      failures=sc.failures, seed=sc.seed, launcher_hook=hook,
                      on_started=lambda la: watch["injector"].start(), progress=lambda: watch["bar"](),
                      per_agent=drop, frame=None if sc.frame < 0 else sc.frame, frame_steps=sc.frame_steps,
                      sph=sc.sph, dt=sc.dt, mode=sc.sync, rate=sc.async_rate, max_age=sc.async_max_age,
                      agent_timeout=sc.neighbour_timeout or 5.0,
                      # the formation may settle before the failures are due: not before they have all happened
                      settle_hold=lambda: "injector" not in watch or watch["injector"].busy(), live=live)
    except (InputError, SegmentationError, ShapeError) as exc:
        raise UserError(f"{sc.path}: input {sc.input}: {exc}") from None
    finally:
        if "injector" in watch:
            watch["injector"].stop()
            watch["bar"].done()
    finished = sum(1 for r in res.finals.values() if r.get("status") == "done")
    summary = RunSummary(sc.name, agents, steps, res.steps_per_second, finished, res.mcap, sync=sc.sync,
                         failures=watch["injector"].log.injected)
    f = res.fidelity
    summary.fidelity_iou = f.iou
    summary.figures.update({"fidelity_iou": f.iou, "fidelity_inside": f.inside, "fidelity_coverage": f.coverage,
                            "nn_cv": f.nn_cv, "formation_seconds": res.formation_seconds,
                            "formation_wall_seconds": res.formation_wall_seconds})
    summary.pictures = [str(res.png)]
    return summary
