"""`fluidswarm bench [--quick]`: measured figures, side by side in one run, written to docs/benchmarks/.

What it measures (issue 8): lockstep runs of agent processes for several N (steps/s, wall time, state
messages per agent per step, CPU seconds, peak RSS per agent and in total, start-up time); the same set-ups
through the per-particle and the vectorised centralised drivers (the cost of decentralisation); a log-log
fit of step time against N; hand-gesture imitation wall time; eigen-image training time.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from agent.protocol.errors import UserError
from fluidswarm.orchestration.bench_record import (
    BenchRecord,
    BenchRecordError,
    FailedRun,
    Formation,
    LockstepRun,
    Machine,
    with_readme_section,
)
from fluidswarm.scenario import scenarios_dir

FULL_NS = (25, 50, 100, 200, 300, 1000)
FIT_MAX_N = 300  # the step-time exponent is fitted over N <= 300 (issue 14); N = 1000 is recorded beside it
QUICK_NS = (9, 16, 25)
# gesture -> sign-digit class of its shipped photo: V, the "C" (fingers curved round a cylinder), the thumb
# touching the index finger
GESTURES = {"scissor": "2", "cylindrical": "0", "pinching": "9"}


def register(sub) -> None:
    p = sub.add_parser("bench", help="measure swarm scaling, decentralisation cost and perception speed")
    p.add_argument("--quick", action="store_true", help="small N and few steps (CI): checks every field is produced")
    p.add_argument("--out", default="docs/benchmarks", help="folder for results.json/.md/.png (default: %(default)s)")
    p.add_argument("--ns", help="comma-separated agent counts (default: 25,50,100,200,300; quick: 9,16,25)")
    p.add_argument("--steps", type=int, help="lockstep steps per run (default 300; quick 30)")
    p.add_argument("--gesture-agents", type=int, help="agents per gesture imitation (default 300; quick 20)")
    p.add_argument(
        "--json",
        action="store_true",
        help="print the bench's record (fluidswarm/orchestration/bench_record.py BenchRecord, the object of "
        "results.json) as one JSON object instead of key=value lines",
    )
    p.add_argument(
        "--readme",
        metavar="README",
        nargs="?",
        const="README.md",
        help="measure nothing: rewrite the benchmark figures of README (default: %(const)s) from OUT/results.json",
    )
    p.set_defaults(func=run)


def machine() -> Machine:
    mem = 0
    try:
        with open("/proc/meminfo") as f:
            mem = int(f.readline().split()[1]) // 1024
    except OSError:
        pass
    return Machine(
        cores=os.cpu_count() or 1, memory_mb=mem, python=platform.python_version(), platform=platform.platform()
    )


def process_cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of process `pid` so far, all its threads, ended ones too; 0.0 once it is gone.

    From the kernel's per-process CPU clock (clock_getcpuclockid(3): clock id ((~pid) << 3) | CPUCLOCK_SCHED),
    nanoseconds, where /proc/PID/stat counts 10 ms ticks: too coarse for a short run's router."""
    try:
        return time.clock_gettime((~pid << 3) | 2)
    except OSError:
        return 0.0


def lockstep(n: int, steps: int, record: bool = True) -> LockstepRun:
    """`record`: with the run's recorder writing an MCAP (as every user's run does; into a temporary folder,
    removed after), so its CPU is part of all_cpu_us_per_agent_step; False for a side-by-side with older trees."""
    import resource
    import shutil
    import tempfile

    from agent.protocol.spec import NEIGHBOUR_TIMEOUT
    from agent.sph.reference import PerParticleDriver, VectorisedDriver
    from fluidswarm.block import Block
    from fluidswarm.orchestration.run import Run, RunOptions
    from fluidswarm.orchestration.run_config import Recording

    # 3 minutes for N = 1000 to come up (it did not in 9 min on this machine: docs/benchmarks/native.md)
    # A stalled swarm fails after a few minutes (a healthy one needs ~0.1-0.3 s per step up to N = 300),
    # not after run_swarm's default of 0.004 s x N per step (14 min at N = 1000).
    scratch = Path(tempfile.mkdtemp(prefix="fluidswarm-bench-")) if record else None
    kind = Block(
        n,
        steps,
        startup_timeout=60.0 + 0.12 * n,
        run_timeout=120.0 + 0.5 * steps,
        kind="bench",
        record=str(scratch / f"bench_{n}.mcap") if scratch else None,
    )
    # The helper processes' CPU while the agents step (start-up left out, as for the agents' own figure): the
    # embedded router, the recorder and this process (the launcher: its pacer, relay requests, supervisor).
    helpers: dict[str, list[float]] = {}

    def helper_pids(run: Run) -> dict[str, int]:
        la = run.launcher
        router = la.router.process.proc.pid if la.router.process is not None else None
        recorder = la.recorder.proc.pid if la.recorder.proc is not None else None
        pids = {"router": router, "recorder": recorder, "launcher": os.getpid()}
        return {k: v for k, v in pids.items() if v is not None}

    def snapshot(run: Run) -> None:
        for name, pid in helper_pids(run).items():
            helpers.setdefault(name, []).append(process_cpu_seconds(pid))

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    try:
        with Run(kind, RunOptions(Recording(None, f"bench_{n}"), NEIGHBOUR_TIMEOUT.benchmark)) as run:
            run.on_start(lambda: snapshot(run))
            run.on_stop(lambda: snapshot(run))
            kind.drive(run)
    finally:
        if scratch is not None:
            shutil.rmtree(scratch, ignore_errors=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    res, setup = run.record, kind.setup
    done = [r for r in res.finals.values() if r.done]
    sps = res.steps_per_second
    rss = [r.rss_mb for r in res.finals.values()]  # each agent's own peak (VmHWM)
    pss = [r.pss_mb for r in res.finals.values() if r.pss_mb > 0]  # its share of the pages it maps with others
    # CPU of the stepping alone (start-up, imports and session opening excluded), per agent and step.
    stepping = [
        (r.cpu_seconds - r.cpu_seconds_at_start) / r.steps
        for r in done
        if r.cpu_seconds_at_start is not None and r.steps
    ]
    agent_steps = sum(r.steps for r in done)
    helpers_us = {  # name -> its CPU during the stepping per agent-step [µs]
        name: 1e6 * (cpu[-1] - cpu[0]) / agent_steps for name, cpu in helpers.items() if len(cpu) == 2 and agent_steps
    }

    central_steps = min(steps, 60)
    t = time.perf_counter()
    PerParticleDriver(setup.ids, setup.states, setup.controls, setup.params).run(central_steps)
    pp_sps = central_steps / (time.perf_counter() - t)
    t = time.perf_counter()
    VectorisedDriver(setup.ids, setup.states, setup.controls, setup.params).run(steps)
    vec_sps = steps / (time.perf_counter() - t)
    return LockstepRun(
        n=n,
        steps=steps,
        agents_finished=len(done),
        steps_per_second=round(sps, 3),
        wall_seconds=round(steps / sps, 3) if sps else None,
        startup_seconds=round(res.startup_seconds, 3),
        msgs_per_agent_step=round(res.msgs_per_agent_step, 3),
        neighbours_per_agent=round(res.neighbours_per_agent, 3),
        cpu_seconds=round((after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime), 2),
        cpu_ms_per_agent_step=round(1000 * float(np.mean(stepping)), 3) if stepping else None,
        cpu_us_per_agent_step=round(1e6 * float(np.mean(stepping)), 1) if stepping else None,
        rss_mb_per_agent=round(float(np.mean(rss)), 1) if rss else None,
        rss_mb_total=round(float(np.sum(rss)), 1),
        centralised_steps_per_second=round(pp_sps, 2),
        vectorised_steps_per_second=round(vec_sps, 2),
        decentralisation_ratio=round(pp_sps / sps, 3) if sps else None,
        decentralisation_ratio_vectorised=round(vec_sps / sps, 3) if sps else None,
        pss_mb_per_agent=round(float(np.mean(pss)), 1) if pss else None,
        all_cpu_us_per_agent_step=(
            round(1e6 * float(np.mean(stepping)) + sum(helpers_us.values()), 1) if stepping and helpers_us else None
        ),
        helpers_cpu_us_per_agent_step={k: round(v, 1) for k, v in sorted(helpers_us.items())},
    )


def fit_exponent(runs: list[LockstepRun | FailedRun]) -> float | None:
    pts = [
        (r.n, 1.0 / r.steps_per_second)
        for r in runs
        if isinstance(r, LockstepRun) and r.steps_per_second and r.n <= FIT_MAX_N
    ]
    if len(pts) < 2:
        return None
    x = np.log([p[0] for p in pts])
    y = np.log([p[1] for p in pts])
    return round(float(np.polyfit(x, y, 1)[0]), 3)


def gesture_image(cls: str) -> Path | None:
    """The shipped photograph of a class if the repository has one, else the shared set's."""
    cands = sorted((scenarios_dir() / "inputs").glob(f"digit{cls}_*"))
    return cands[0] if cands else None


def imitation_seconds(
    agents: int, steps: int | None, side_by_side: bool = False
) -> tuple[dict, dict, dict[str, Formation | None]]:
    """Wall time of `fluidswarm imitate` per gesture (start-up included), the fidelity it reached, and when
    its formation settled ({"seconds": simulated, "settled": false when the step cap ended it}).
    `side_by_side` (--quick, which checks that every field is produced): the three run at once, so their
    times share the machine and are no figures."""
    out: dict = {}
    fid: dict = {}
    formed: dict = {}
    running: dict[str, tuple[subprocess.Popen, float]] = {}

    def start(gesture: str, image: Path) -> None:
        cmd = [sys.executable, "-m", "fluidswarm", "imitate", str(image), "--agents", str(agents)]
        cmd += ["--out", f"out/bench/{gesture}", "--json"] + (["--steps", str(steps)] if steps else [])
        print(f"gesture {gesture}: {agents} agents ...", file=sys.stderr, flush=True)
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        running[gesture] = (proc, time.perf_counter())

    def finish(gesture: str) -> None:
        proc, t = running[gesture]
        stdout, _ = proc.communicate()
        del running[gesture]
        out[gesture] = round(time.perf_counter() - t, 2) if proc.returncode == 0 else None
        record = json.loads(stdout) if proc.returncode == 0 else None
        fid[gesture] = record["fidelity"]["iou"] if record else None
        formed[gesture] = (
            Formation(seconds=record["formation_seconds"], settled=record["formation_settled"]) if record else None
        )

    try:
        for gesture, cls in GESTURES.items():
            image = gesture_image(cls)
            if image is None:
                out[gesture] = fid[gesture] = formed[gesture] = None
                continue
            start(gesture, image)
            if not side_by_side:
                finish(gesture)
        for gesture in list(running):
            finish(gesture)
    finally:  # interrupted: no imitation outlives the bench
        for proc, _t in running.values():
            proc.kill()
            proc.wait()
    return out, fid, formed


def region_controller_timing() -> dict:
    """Region controller per video frame: person regions (median background over the clip) + ellipses +
    the command, on the shipped Weizmann clip; and on one shipped hand photograph."""
    from coordinator.control.imitation_setup import build_command
    from coordinator.control.observe import observe
    from coordinator.control.region import fit_transform
    from perception.io import load_frames

    inputs = scenarios_dir() / "inputs"
    out = {}
    for key, path in (
        ("region_controller_ms_per_video_frame", inputs / "weizmann_wave2_person0.png"),
        ("region_controller_ms_per_hand_photo", inputs / "digit2_IMG_1140.JPG"),
    ):
        frames = load_frames(path)
        t = time.perf_counter()
        obs = observe(path, frames)
        transform = fit_transform(obs[0].mask, 60)
        for o in obs:
            build_command(o, transform, 60, "region")
        out[key] = round((time.perf_counter() - t) / len(frames) * 1000, 2)
    return out


def perception_timings(classes: list[str] | None = None) -> dict:
    """Eigen-image training on the shared hand set (features + fit, 'best' method), inference per image;
    `classes`: only these (--quick: three of the ten, a field check, not the figure)."""
    out: dict[str, Any] = {"eigen_training_seconds": None, "eigen_inference_ms": None}
    from threadpoolctl import threadpool_limits

    from perception.dataset import SHARED_HANDS, load_folder
    from perception.eigen import EigenClassifier

    if not SHARED_HANDS.is_dir():
        out["perception_error"] = f"{SHARED_HANDS} missing"
        return out
    images, labels = load_folder(SHARED_HANDS, classes)[:2]
    with threadpool_limits(1):
        clf = EigenClassifier(method="best")
        t = time.perf_counter()
        clf.fit(images, labels)
        out["eigen_training_seconds"] = round(time.perf_counter() - t, 3)
        t = time.perf_counter()
        clf.predict(images[:100])
        out["eigen_inference_ms"] = round((time.perf_counter() - t) / 100 * 1000, 3)
    return out


def write_outputs(record: BenchRecord, out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.json").write_text(record.to_json(indent=2) + "\n")
    lines = [
        (
            f"Measured {record.date} on {record.machine.cores} cores, "
            f"{record.machine.memory_mb // 1024} GiB ({'quick' if record.quick else 'full'} run)."
        ),
        "",
        (
            "| N | steps/s | wall s | start-up s | msgs/agent/step | neighbours | CPU s | CPU ms/agent-step "
            "| all processes' CPU µs/agent-step (the helpers') "
            "| RSS MB/agent | PSS MB/agent | RSS MB total | per-particle central steps/s | vectorised steps/s "
            "| decentralised/central time |"
        ),
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in record.runs:
        if isinstance(r, FailedRun):
            lines.append(f"| {r.n} | failed: {r.error} |" + " |" * 13)
            continue
        helpers = ", ".join(f"{k} {v}" for k, v in (r.helpers_cpu_us_per_agent_step or {}).items())
        lines.append(
            f"| {r.n} | {r.steps_per_second} | {r.wall_seconds} | {r.startup_seconds} | {r.msgs_per_agent_step} | "
            f"{r.neighbours_per_agent} | {r.cpu_seconds} | {r.cpu_ms_per_agent_step} | "
            f"{r.all_cpu_us_per_agent_step} ({helpers}) | "
            f"{r.rss_mb_per_agent} | "
            f"{r.pss_mb_per_agent} | {r.rss_mb_total} | "
            f"{r.centralised_steps_per_second} | {r.vectorised_steps_per_second} | {r.decentralisation_ratio} |"
        )
    lines += [
        "",
        f"Step time ~ N^{record.step_time_exponent} (log-log fit).",
        "",
        "Gesture imitation wall time [s]: "
        + ", ".join(f"{k} {v}" for k, v in record.gesture_imitation_seconds.items()),
        f"(with {record.gesture_agents} agent processes; thesis Table 6.1: 126-219 s per gesture)",
        "",
        "Fidelity (iou) of those runs: "
        + ", ".join(f"{k} {v}" for k, v in record.gesture_imitation_fidelity_iou.items()),
        "",
        f"Eigen-image training: {record.eigen_training_seconds} s; inference {record.eigen_inference_ms} ms/image.",
        "",
        (
            f"Region controller: {record.region_controller_ms_per_video_frame} ms per video frame (Weizmann clip, "
            f"person regions + ellipses + command), {record.region_controller_ms_per_hand_photo} ms per hand "
            "photograph."
        ),
    ]
    (out / "results.md").write_text("\n".join(lines) + "\n")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4), dpi=100)
    ok = [r for r in record.runs if isinstance(r, LockstepRun)]
    ns = [r.n for r in ok]
    ax.loglog(ns, [r.steps_per_second for r in ok], "o-", label="agent processes (Zenoh)")
    ax.loglog(ns, [r.centralised_steps_per_second for r in ok], "s--", label="per-particle driver")
    ax.loglog(ns, [r.vectorised_steps_per_second for r in ok], "^:", label="vectorised driver")
    ax.set_xlabel("particles N")
    ax.set_ylabel("steps per second")
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "results.png")
    plt.close(fig)


def print_lines(record: BenchRecord, results: Path) -> None:
    """The key=value summary `bench` prints without --json (the per-N lines are printed as each run ends)."""
    print(f"step_time_exponent={record.step_time_exponent}")
    for g, v in record.gesture_imitation_seconds.items():
        print(f"gesture_imitation_seconds[{g}]={v}")
    print(f"eigen_training_seconds={record.eigen_training_seconds}")
    print(f"region_controller_ms_per_video_frame={record.region_controller_ms_per_video_frame}")
    print(f"results={results}")


def write_readme(readme: Path, results: Path) -> None:
    """README's benchmark figures rewritten from `results` (a BenchRecord); UserError naming the bad file."""
    try:
        record = BenchRecord.load(results)
        text = readme.read_text()
    except OSError as exc:
        raise UserError(f"cannot read {exc.filename}: {exc.strerror}") from None
    except BenchRecordError as exc:
        raise UserError(str(exc)) from None
    try:
        readme.write_text(with_readme_section(text, record, FIT_MAX_N))
    except ValueError as exc:
        raise UserError(f"{readme}: {exc}") from None
    print(f"readme={readme} results={results}")


def run(args) -> int:
    if args.readme:
        write_readme(Path(args.readme), Path(args.out) / "results.json")
        return 0
    if args.ns:
        try:
            ns = tuple(int(v) for v in args.ns.split(","))
        except ValueError:
            raise UserError(f"--ns {args.ns!r}: expected comma-separated integers") from None
        if any(n < 2 for n in ns):
            raise UserError(f"--ns {args.ns!r}: every N must be >= 2")
    else:
        ns = QUICK_NS if args.quick else FULL_NS
    steps = args.steps or (30 if args.quick else 300)
    if steps < 2:
        raise UserError(f"--steps: must be >= 2, got {steps}")
    gesture_agents = args.gesture_agents or (20 if args.quick else 300)
    lines = sys.stderr if args.json else sys.stdout  # with --json, stdout holds the record alone
    runs: list[LockstepRun | FailedRun] = []
    for n in ns:
        print(f"lockstep N={n} ...", file=sys.stderr, flush=True)
        try:
            r = lockstep(n, steps)
        except (TimeoutError, RuntimeError) as exc:  # recorded, not hidden: the run did not come up or finish
            print(f"n={n} failed: {exc}", file=lines, flush=True)
            runs.append(FailedRun(n=n, steps=steps, error=str(exc)))
            continue
        print(
            f"n={n} steps_per_second={r.steps_per_second} msgs_per_agent_step={r.msgs_per_agent_step} "
            f"cpu_us_per_agent_step={r.cpu_us_per_agent_step} all_cpu_us_per_agent_step={r.all_cpu_us_per_agent_step} "
            f"rss_mb_per_agent={r.rss_mb_per_agent} pss_mb_per_agent={r.pss_mb_per_agent} "
            f"decentralisation_ratio={r.decentralisation_ratio}",
            file=lines,
            flush=True,
        )
        runs.append(r)
    print("gesture imitation ...", file=sys.stderr, flush=True)
    gestures, gesture_fidelity, gesture_formation = imitation_seconds(
        gesture_agents, 60 if args.quick else None, side_by_side=args.quick
    )
    perception = perception_timings(["0", "1", "2"] if args.quick else None)
    perception.update(region_controller_timing())
    record = BenchRecord(
        date=_dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        quick=bool(args.quick),
        machine=machine(),
        runs=tuple(runs),
        step_time_exponent=fit_exponent(runs),
        gesture_agents=gesture_agents,
        gesture_imitation_seconds=gestures,
        gesture_imitation_fidelity_iou=gesture_fidelity,
        gesture_imitation_formation=gesture_formation,
        **perception,
    )
    write_outputs(record, Path(args.out))
    if args.json:
        print(record.to_json(), flush=True)
    else:
        print_lines(record, Path(args.out) / "results.json")
    return 0
