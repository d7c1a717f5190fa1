"""Thesis §4.6-4.7 (stiffness-only branching, Figs. 4.10-4.13), ch. 3's constant-force remark and ch. 6's
~350-particle remark, on the branching set-up of agent/sph/setups.py.

Two set-ups side by side:
- *pinned* (thesis-faithful, `setups.branching`): every particle starts at 1 m/s along +x and is pushed
  by a constant force balanced by a linear drag (terminal speed 1 m/s), the thesis' "constant velocity
  along x". The balance pins each particle's vx near 1 m/s, which hides a speed difference between bands.
- *free* (measurable): the same block starts at 1 m/s (thesis §4.7: "the initial velocity is 1 m/s") with
  neither push nor drag, so pressure can slow the stiff particles down.
"""

from __future__ import annotations

import numpy as np

from agent.sph.params import Border, SPHParams
from agent.sph.particle import FROZEN, Y
from agent.sph.setups import branch_gap, branching
from research.reproduce import plots
from research.reproduce.claim import Claim, Context, Group, Verdict
from research.reproduce.runs import record

MIDDLE, EDGES = [1], [0, 2]
DOMAIN = (-20.0, 100.0, -40.0, 50.0)


def pinned(n: int, beta_middle: float, beta_edge: float, rows: int = 10):
    return branching(n, beta_middle=beta_middle, beta_edge=beta_edge, rows=rows)


def free(n: int, beta_middle: float, beta_edge: float, rows: int = 10):
    return branching(
        n, beta_middle=beta_middle, beta_edge=beta_edge, rows=rows, params=SPHParams(drag=0.0, domain=DOMAIN)
    )


def _agree(ok: bool) -> Verdict:
    return Verdict.AGREE if ok else Verdict.DISAGREE


def measure(ctx: Context) -> list[Group]:
    n = 100 if ctx.quick else 200
    steps = ctx.steps(800, 300)
    runs = {}
    for name, make in (("pinned", pinned), ("free", free)):
        for label, bm, be in (
            ("split", 20.0, 2.0),
            ("printed", 2.0, 20.0),
            ("uniform2", 2.0, 2.0),
            ("uniform50", 50.0, 50.0),
        ):
            setup = make(n, bm, be)
            runs[name, label] = (setup, record(setup, steps))
    dt = runs["pinned", "split"][0].params.dt
    g = Group("Stiffness-only branching (thesis §4.6-4.7, Figs. 4.10-4.13)")
    g.notes.append(
        f"Set-up: `agent/sph/setups.py` `branching`, {n} particles in 10 rows on a unit lattice, the middle 40 % "
        f"of the rows form the middle band, {steps} steps of dt = {dt} s on the vectorised reference driver. "
        "*Pinned* = the project's set-up (start at 1 m/s, a constant push along +x balanced by a drag of "
        "0.5 1/s: terminal speed 1 m/s); *free* = the same block started at 1 m/s with neither push nor drag. "
        "Speeds are time means (over all steps) of the per-step class means, as the thesis' Fig. 4.12 averages "
        "over its run."
    )

    # §4.6 Fig. 4.10: which assignment splits the flow.
    gaps = {k: branch_gap(s.classes, r.final) - branch_gap(s.classes, s.states) for k, (s, r) in runs.items()}
    for name in ("pinned", "free"):
        split, printed, uni = gaps[name, "split"], gaps[name, "printed"], gaps[name, "uniform2"]
        for reading, gap, other in (
            ("text: β middle 20, edges 2", split, printed),
            ("printed: β middle 2, edges 20", printed, split),
        ):
            g.claims.append(
                Claim(
                    "§4.6, Fig. 4.10",
                    "stiffness alone splits the flow into two branches (scissor)",
                    "split (qualitative); text: middle stiffer, printed: β_middle = 2, β_edge = 20",
                    f"{name}: branch gap grows {gap:+.2f} m ({reading}) vs {uni:+.2f} m uniform β 2 and "
                    f"{other:+.2f} m with the other reading",
                    _agree(gap > 1.5 * max(uni, 0.0) and gap > 1.0),
                    (
                        "the stiff middle's higher Tait pressure (eq. 3.13) pushes the soft edge bands apart"
                        if reading.startswith("text")
                        else "stiff edges expand outwards on their own (their free side is ±y), which also widens "
                        "the gap "
                        "between the bands' medians; the text's reading keeps the edges together as branches"
                    )
                    + (
                        " and more than the other reading"
                        if gap > other
                        else "; the other reading widens it more in this set-up"
                    ),
                    f"{name}; reading: {reading}",
                )
            )

    # Ch. 3 / §4.6: a constant body force alone gives no branching.
    uni_p = gaps["pinned", "uniform2"]
    split_p = gaps["pinned", "split"]
    g.claims.append(
        Claim(
            "§4.6 (ch. 3 remark)",
            "a constant body force along x alone gives no branching",
            "no branching (qualitative)",
            f"uniform β = 2, constant push: branch gap {uni_p:+.2f} m vs {split_p:+.2f} m with the stiff middle",
            _agree(abs(uni_p) < 0.5 * abs(split_p)),
            "a uniform fluid under a uniform force has no pressure difference between bands to drive them apart; "
            "it only relaxes its compression (ρ of the unit lattice 0.98 > ρ0 = 0.85) evenly",
            "pinned",
        )
    )

    # §4.7 Fig. 4.12: middle slower than edges.
    thesis_ratio = 0.832 / 1.052
    for name in ("pinned", "free"):
        s, r = runs[name, "split"]
        v_mid, v_edge = r.speed[1:, MIDDLE].mean(), r.speed[1:, EDGES].mean()
        vx_mid, vx_edge = r.vx[1:, MIDDLE].mean(), r.vx[1:, EDGES].mean()
        ratio = v_mid / v_edge
        late = r.speed[steps // 2 :, MIDDLE].mean() / r.speed[steps // 2 :, EDGES].mean()
        vy_mid, vy_edge = r.avy[1:, MIDDLE].mean(), r.avy[1:, EDGES].mean()
        if name == "pinned":
            why = (
                "the push balanced by the drag pins every particle's vx at the terminal speed 1 m/s "
                f"(vx middle {vx_mid:.3f}, edges {vx_edge:.3f}) and the drag damps the sideways velocity "
                f"(|vy| middle {vy_mid:.3f}, edges {vy_edge:.3f}): nothing is left to tell the bands apart"
            )
        else:
            why = (
                f"the forward velocity is the same (vx middle {vx_mid:.3f}, edges {vx_edge:.3f}: the pressure "
                "gradient acts across the bands); the edges are faster only by the sideways velocity the "
                f"middle's pressure gives them (|vy| middle {vy_mid:.3f}, edges {vy_edge:.3f}) — not, as the "
                "thesis says, because the middle slows down"
            )
        g.claims.append(
            Claim(
                "§4.7, Fig. 4.12",
                "middle particles slower than edge particles",
                f"V_middle 0.832, V_edge 1.052 m/s (ratio {thesis_ratio:.2f})",
                f"{name}: V_middle {v_mid:.3f}, V_edge {v_edge:.3f} m/s (ratio {ratio:.2f}; second half {late:.2f})",
                _agree(ratio < 0.9),
                why,
                name,
            )
        )

    # §4.7 Fig. 4.13: beta 50 everywhere is slower than "the previous case".
    for name in ("pinned", "free"):
        r50 = runs[name, "uniform50"][1]
        rsplit = runs[name, "split"][1]
        r2 = runs[name, "uniform2"][1]
        vx50, vxs, vx2 = (x.vx[1:].mean() for x in (r50, rsplit, r2))
        sp50, sps, sp2 = (x.speed[1:].mean() for x in (r50, rsplit, r2))
        for reading, a, b, c in (("mean x-velocity", vx50, vxs, vx2), ("mean speed", sp50, sps, sp2)):
            g.claims.append(
                Claim(
                    "§4.7, Fig. 4.13",
                    "β = 50 for all: the average velocity is lower than in the previous case",
                    "lower than the split case (no figure printed)",
                    f"{name}, {reading}: β 50 {a:.3f} vs split (20/2) {b:.3f} vs uniform 2 {c:.3f} m/s",
                    _agree(a < b and a < c),
                    (
                        "a stiff fluid converts its forward motion into sideways spreading: its x-velocity drops"
                        if reading.endswith("x-velocity")
                        else "the speed counts the sideways escape too: a stiffer fluid expands faster "
                        "(pressure ∝ β), so "
                        "|v| rises although the forward velocity falls"
                    )
                    if a < b or reading.endswith("x-velocity")
                    else "the stiff fluid's expansion adds sideways speed faster than pressure slows the forward "
                    "motion",
                    f"{name}; reading: {reading}",
                )
            )

    # §4.6 Fig. 4.11: beta 50 makes the particles escape along y.
    for name in ("pinned", "free"):
        y50 = float(np.std(runs[name, "uniform50"][1].final[:, Y]))
        y2 = float(np.std(runs[name, "uniform2"][1].final[:, Y]))
        y0 = float(np.std(runs[name, "uniform2"][0].states[:, Y]))
        g.claims.append(
            Claim(
                "§4.6, Fig. 4.11",
                "β = 50 for all makes the particles escape along y (cylindrical preshape)",
                "escape along y (qualitative)",
                f"{name}: y spread (std) {y50:.2f} m at β 50 vs {y2:.2f} m at β 2 (start {y0:.2f} m)",
                _agree(y50 > 1.3 * y2),
                "the Tait pressure scales with β, so the stiff block's compression drives a stronger expansion; "
                "with the motion along x the free sides are ±y",
                name,
            )
        )

    # The thesis' time series (Fig. 4.12) beside ours.
    panels = []
    for name in ("pinned", "free"):
        r = runs[name, "split"][1]
        panels.append(
            (
                f"{name}: β middle 20, edges 2",
                dt,
                {"middle (ours)": r.speed[:, MIDDLE].mean(axis=1), "edges (ours)": r.speed[:, EDGES].mean(axis=1)},
                {"middle (thesis 0.832)": 0.832, "edges (thesis 1.052)": 1.052},
            )
        )
    g.plots.append(
        (
            plots.time_series(ctx.image_dir / "branching_speeds.png", panels, "mean speed [m/s]"),
            "Fig. 4.12 re-measured: mean speed of the middle band and of the edges (dashed: the thesis' averages)",
        )
    )
    forms = []
    for name in ("pinned", "free"):
        for label, title in (
            ("split", "β mid 20 / edges 2"),
            ("printed", "printed: β mid 2 / edges 20"),
            ("uniform2", "uniform β 2"),
            ("uniform50", "uniform β 50"),
        ):
            s, r = runs[name, label]
            forms.append((f"{name}: {title}", r.final[:, :2], s.classes, s.class_names))
    g.plots.append(
        (
            plots.formations(ctx.image_dir / "branching_formations.png", forms),
            "Figs. 4.10-4.11 re-measured: final formations (blue/green edges, red middle)",
        )
    )

    border_freeze(ctx, g)
    groups = [g, particle_count(ctx)]
    return groups


def particle_count(ctx: Context) -> Group:
    """Ch. 6 (§6.3, Fig. 6.18): beyond ~300 particles the branching is no longer clearly visible."""
    g = Group("Particle count and branching (thesis §6.3, Fig. 6.18)")
    counts = (100, 200, 351) if ctx.quick else (100, 200, 351, 600)
    steps = ctx.steps(800, 300)
    result = {}
    for reading in ("10 rows (longer block)", "aspect kept (thicker block)"):
        for n in counts:
            rows = 10 if reading.startswith("10") else max(10, int(round(np.sqrt(n / 2.0))))
            setup = pinned(n, 20.0, 2.0, rows=rows)
            final = record(setup, steps).final
            height = float(np.ptp(setup.states[:, Y]))
            result[reading, n] = (branch_gap(setup.classes, final) - branch_gap(setup.classes, setup.states)) / height
    g.notes.append(
        f"Branching set-up (pinned, β middle 20, edges 2), {steps} steps, N in {counts}. 'Split clarity' = growth of "
        "the gap between the edge bands divided by the block's initial height. Two readings of a larger swarm: "
        "the same 10 rows made longer, or the block scaled with its aspect kept (thicker, like the thesis' thick "
        "wrist)."
    )
    for reading in ("10 rows (longer block)", "aspect kept (thicker block)"):
        vals = [result[reading, n] for n in counts]
        small = result[reading, 200]
        big = result[reading, 351]
        g.claims.append(
            Claim(
                "§6.3, Fig. 6.18",
                "with more than ~300 particles (351) the branching is not clearly visible",
                "351 particles: branching unclear; 319-321: thick wrist",
                f"{reading}: split clarity " + ", ".join(f"N={n}: {v:.2f}" for n, v in zip(counts, vals)),
                _agree(big < 0.75 * small),
                (
                    "a thicker block has more soft edge material per unit of stiff middle: the middle's pressure "
                    "moves the edges by a similar distance, a smaller share of the block's height"
                )
                if reading.startswith("aspect")
                else (
                    "a longer block with the same 10 rows branches per unit length as before: the count alone does "
                    "not hide the split, the thickness does"
                ),
                f"measurable; reading: {reading}",
            )
        )
    g.plots.append(
        (
            plots.lines(
                ctx.image_dir / "branching_vs_count.png",
                "split clarity vs particle count",
                np.array(counts),
                {
                    r: np.array([result[r, n] for n in counts])
                    for r in ("10 rows (longer block)", "aspect kept (thicker block)")
                },
                "particles N",
                "gap growth / block height",
            ),
            "§6.3 re-measured: split clarity against the number of particles",
        )
    )
    return g


def border_freeze(ctx: Context, g: Group) -> None:
    """Fig. 4.12's late drop: edge particles leaving the domain get their fluid parameters set to 0."""
    n = 100 if ctx.quick else 200
    steps = ctx.steps(800, 300)
    top = 9.0 + 3.0  # the block's rows are y = 0..9: borders 3 m beyond its sides
    # branching's own stiffnesses: the middle band's 20 N/m, the edges the fluid's (SPHParams.beta, 2 N/m)
    setup = branching(n, params=SPHParams(drag=0.0, domain=(-20.0, 100.0, -3.0, top), border=Border.FREEZE))
    r = record(setup, steps)
    frozen = r.final[:, FROZEN] != 0
    share = {k: float(frozen[np.isin(setup.classes, c)].mean()) for k, c in (("middle", MIDDLE), ("edges", EDGES))}
    first = int(np.argmax(r.frozen > 0)) if r.frozen.any() else -1
    v_mid, v_edge = r.speed[:, MIDDLE].mean(axis=1), r.speed[:, EDGES].mean(axis=1)
    peak_edge = float(v_edge[:first].max()) if first > 0 else float("nan")
    g.claims.append(
        Claim(
            "§4.7, Fig. 4.12",
            "from t = 250 the edge particles' mean speed drops suddenly (they leave the domain and "
            "their fluid parameters are set to 0); the middle's does not",
            "sudden drop of the edges only, near the end",
            f"free block, borders 3 m beyond its sides (freeze): first particle frozen at step {first}; at the end "
            f"{100 * share['edges']:.0f} % of the edges and {100 * share['middle']:.0f} % of the middle frozen; "
            "edge mean "
            f"speed {peak_edge:.2f} → {v_edge[-1]:.2f} m/s, middle {v_mid[first] if first > 0 else float('nan'):.2f} → "
            f"{v_mid[-1]:.2f} m/s",
            _agree(share["edges"] > 0.2 and share["middle"] < 0.5 * share["edges"] and v_edge[-1] < 0.8 * peak_edge),
            "the stiff middle's pressure drives the edge bands outwards, so they reach the side borders first; "
            "a frozen "
            "particle counts with v = 0 (thesis §4.7, SPHParams.border = 'freeze'), which pulls its class mean down",
            "measurable (the thesis' domain size is not printed)",
        )
    )
    g.plots.append(
        (
            plots.time_series(
                ctx.image_dir / "branching_border.png",
                [
                    (
                        "free block, freezing side borders 3 m away",
                        setup.params.dt,
                        {"middle": v_mid, "edges": v_edge},
                        {},
                    )
                ],
                "mean speed [m/s]",
            ),
            "Fig. 4.12's late drop re-measured: frozen edge particles (v = 0) pull the edges' mean speed down",
        )
    )
