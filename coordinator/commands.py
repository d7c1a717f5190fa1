"""`fluidswarm coordinator` and `fluidswarm imitate`."""

from __future__ import annotations

from pathlib import Path

from fluidswarm.errors import UserError
from fluidswarm.recording.live import add_live_argument, live_from_args


def register(sub) -> None:
    p = sub.add_parser("coordinator", help="observe an image/frames/video and broadcast signed gesture commands")
    p.add_argument("args", nargs="*", help="see `python -m coordinator --help`")
    p.set_defaults(func=_coordinator)
    p = sub.add_parser("imitate", help="perception -> coordinator -> N agent processes -> formation, MCAP, fidelity")
    p.add_argument("input", help="image, folder of frames, or video")
    p.add_argument("--controller", default="fill", choices=["fill", "region", "pca", "ann"],
                   help="fill (default): the swarm fills the silhouette like a liquid; region: waypoints at k-means "
                        "regions (thesis ch. 6); pca: the recognised class' template; ann: skeleton -> body force")
    p.add_argument("--frame", type=int, default=None, help="which frame of a clip or folder to imitate (default 0)")
    p.add_argument("--agents", type=int, default=60)
    p.add_argument("--steps", type=int, default=None)
    p.add_argument("--out", default="out/imitate")
    add_live_argument(p)
    p.set_defaults(func=_imitate)


def _coordinator(args) -> int:
    from coordinator.process import main

    return main(args.args)


def _imitate(args) -> int:
    from coordinator.fill import ShapeError
    from coordinator.imitate import imitate
    from coordinator.imitation_setup import DEFAULT_STEPS
    from fluidswarm.recording.fidelity import format_fidelity
    from perception.io import InputError
    from perception.segmentation import SegmentationError

    if args.agents < 2:
        raise UserError(f"--agents: must be >= 2, got {args.agents}")
    steps = DEFAULT_STEPS if args.steps is None else args.steps
    if steps < 1:
        raise UserError(f"--steps: must be >= 1, got {steps}")
    live = live_from_args(args)
    try:
        res = imitate(args.input, agents=args.agents, steps=steps, out=args.out, controller=args.controller, frame=args.frame,
                      name=Path(args.input).stem or "imitate", live=live)
    except (InputError, SegmentationError, ShapeError) as exc:
        raise UserError(f"{args.input}: {exc}" if str(args.input) not in str(exc) else str(exc)) from None
    print(format_fidelity(res.fidelity))
    print(f"formation_seconds={res.formation_seconds:.2f}")
    print(f"formation_wall_seconds={res.formation_wall_seconds:.2f}")
    print(f"formation_settled={'true' if res.settled else 'false'}")
    print(f"agents_finished={sum(1 for r in res.finals.values() if r.get('status') == 'done')}")
    print(f"steps_per_second={res.steps_per_second:.2f}")
    print(f"mcap={res.mcap}")
    print(f"png={res.png}")
    return 0
