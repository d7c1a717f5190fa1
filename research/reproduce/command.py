"""`python -m research reproduce [--quick] [--out DIR]`: every claim group, then the report and its plots."""

from __future__ import annotations

import time
from pathlib import Path

from agent.protocol.errors import UserError
from research.reproduce import classifier, decentralised, equations, gestures, report, stiffness, timings, viscosity
from research.reproduce.claim import Context

GROUPS = (stiffness, viscosity, equations, decentralised, gestures, classifier, timings)
REPORT_NAME = "thesis-reproduction.md"


def register(sub) -> None:
    p = sub.add_parser("reproduce", help="re-measure the thesis' quantitative claims; write thesis-reproduction.md")
    p.add_argument("--quick", action="store_true", help="a reduced set (fewer particles and steps), under a minute")
    p.add_argument(
        "--out",
        default="docs",
        help="folder of thesis-reproduction.md; plots go to OUT/reproduction/ (default: %(default)s)",
    )
    p.set_defaults(func=run)


def run(args) -> int:
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {args.out}: not a folder")
    try:
        (out / "reproduction").mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"--out {args.out}: cannot create ({exc.strerror})") from None
    ctx = Context(quick=args.quick, image_dir=out / "reproduction")
    t0 = time.perf_counter()
    groups = []
    for module in GROUPS:
        t = time.perf_counter()
        found = module.measure(ctx)
        groups += found
        rows = sum(len(g.claims) for g in found)
        print(f"{module.__name__.rsplit('.', 1)[-1]}: {rows} claims in {time.perf_counter() - t:.1f} s", flush=True)
    command = "python -m research reproduce" + (" --quick" if args.quick else "")
    path = report.write(out / REPORT_NAME, groups, args.quick, time.perf_counter() - t0, command)
    claims = [c for g in groups for c in g.claims]
    for verdict in ("agree", "disagree", "not comparable"):
        print(f"{verdict.replace(' ', '_')}={sum(c.verdict.value == verdict for c in claims)}")
    print(f"claims={len(claims)}")
    print(f"report={path}")
    return 0
