"""Imitation scenarios for `fluidswarm run` / `fluidswarm demo` (fluidswarm/scenario_commands.py)."""

from __future__ import annotations

from pathlib import Path

from coordinator.imitate import imitate
from coordinator.imitation_setup import DEFAULT_STEPS
from fluidswarm.errors import UserError


def run_imitation_scenario(sc, agents: int, out: Path):
    from fluidswarm.failures import FailureInjector
    from fluidswarm.recording.replay import replay
    from fluidswarm.scenario_commands import ProgressLine, RunSummary
    from perception.io import InputError
    from perception.segmentation import SegmentationError

    path = sc.input_path()
    if path is None or not path.exists():
        raise UserError(f"{sc.path}: key 'input': {sc.input} does not exist")
    steps = sc.steps or DEFAULT_STEPS
    drop = {f.agent: {"drop_out": f.fraction} for f in sc.failures if f.kind == "drop"}
    state = {}

    def hook(launcher, im):
        state["injector"] = FailureInjector(launcher, sc.failures, im.setup.ids, sc.seed,
                                            coordinator=getattr(launcher, "coordinator", None))
        state["bar"] = ProgressLine(launcher, steps, state["injector"])

    try:
        res = imitate(str(path), agents=agents, steps=steps, out=out, name=sc.name, failures=sc.failures, seed=sc.seed,
                      launcher_hook=hook, on_started=lambda la: state["injector"].start(),
                      progress=lambda: state["bar"](), per_agent=drop)
    except (InputError, SegmentationError) as exc:
        raise UserError(f"{sc.path}: input {sc.input}: {exc}") from None
    finally:
        if "injector" in state:
            state["injector"].stop()
            state["bar"].done()
    finished = sum(1 for r in res.finals.values() if r.get("status") == "done")
    summary = RunSummary(sc.name, agents, steps, res.steps_per_second, finished, res.mcap,
                         failures=state["injector"].log.injected)
    f = res.fidelity
    summary.figures.update({"fidelity_iou": f.iou, "fidelity_inside": f.inside, "fidelity_coverage": f.coverage})
    rep = replay(res.mcap, out)
    summary.pictures = [str(res.png)] + [str(p) for p in rep.paths]
    if f.iou < sc.passing.min_fidelity_iou:
        summary.passed = False
        summary.why.append(f"fidelity_iou {f.iou:.3f} < {sc.passing.min_fidelity_iou}")
    if f.inside < sc.passing.min_fidelity_inside:
        summary.passed = False
        summary.why.append(f"fidelity_inside {f.inside:.3f} < {sc.passing.min_fidelity_inside}")
    return summary
