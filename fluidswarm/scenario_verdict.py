"""A scenario's verdict on a finished run: robustness figures, replay pictures and the pass criteria."""

from __future__ import annotations

from pathlib import Path

from fluidswarm.orchestration.run import RunRecord
from fluidswarm.scenario import Scenario

# figures added here, after the run (printed after the kind's own, in this order)
ROBUSTNESS = ("finished_share", "mcap_complete", "mcap_missing_states", "baseline_fidelity_iou", "fidelity_ratio")


def judge(sc: Scenario, record: RunRecord, out: Path, baseline: RunRecord | None) -> RunRecord:
    """Add the robustness figures and the replay pictures to `record` and judge it by `sc.passing`."""
    from fluidswarm.recording.reader import check
    from fluidswarm.replay import replay

    f = record.figures
    spared = record.agents + record.failures_joined - record.failures_killed - record.failures_frozen
    f["finished_share"] = finished_share = min(1.0, record.finished / max(spared, 1))
    assert record.mcap is not None  # a scenario's run is always recorded (its verdict reads the MCAP)
    complete, _steps, missing = check(record.mcap)
    f["mcap_complete"] = complete
    f["mcap_missing_states"] = missing
    iou = record.fidelity.iou if record.fidelity is not None else None
    if baseline is not None and baseline.fidelity is not None and iou is not None:
        f["baseline_fidelity_iou"] = baseline.fidelity.iou
        f["fidelity_ratio"] = iou / max(baseline.fidelity.iou, 1e-9)
    record.pictures += [str(p) for p in replay(record.mcap, out).paths]
    crit = sc.passing

    def need(ok: bool, why: str) -> None:
        if not ok:
            record.passed = False
            record.why.append(why)

    fid = record.fidelity
    if crit.min_fidelity_iou:
        got = fid.iou if fid else 0.0
        need(got >= crit.min_fidelity_iou, f"fidelity_iou {got:.3f} < {crit.min_fidelity_iou}")
    if crit.max_nn_cv:
        got = fid.nn_cv if fid else float("nan")
        need(fid is not None and got <= crit.max_nn_cv, f"nn_cv {got:.3f} > {crit.max_nn_cv}")
    if crit.min_fidelity_inside:
        got = fid.inside if fid else 0.0
        need(got >= crit.min_fidelity_inside, f"fidelity_inside {got:.3f} < {crit.min_fidelity_inside}")
    if crit.min_branch_gap:
        got = float(f.get("branch_gap", 0.0))
        need(got >= crit.min_branch_gap, f"branch_gap {got:.2f} < {crit.min_branch_gap}")
    if crit.min_fidelity_ratio:
        ratio = f.get("fidelity_ratio")
        need(
            isinstance(ratio, (int, float)) and ratio >= crit.min_fidelity_ratio,
            f"fidelity_ratio {ratio} < {crit.min_fidelity_ratio}",
        )
    if crit.max_stall_seconds:
        got = record.longest_stall_seconds
        need(got <= crit.max_stall_seconds, f"longest_stall_seconds {got:.2f} > {crit.max_stall_seconds}")
    if crit.min_finished:
        need(finished_share >= crit.min_finished, f"finished_share {finished_share:.2f} < {crit.min_finished}")
    if crit.complete_mcap:
        need(complete, f"MCAP incomplete ({missing} missing states)")
    if crit.no_collisions:
        need(record.collisions == 0, f"collisions {record.collisions} (none allowed)")
    if crit.no_obstacle_penetrations:
        need(record.obstacle_penetrations == 0, f"obstacle_penetrations {record.obstacle_penetrations} (none allowed)")
    return record
