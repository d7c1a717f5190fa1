"""Obstacles (issue 33 item 3): the boundary force (agent/sph/obstacles.py, the oracle of obstacle.rs), bad
obstacle tables as one-line errors naming the file and the key, and real swarms among obstacles: `verify` stays
exact beside a pillar and a wall, and `run scenarios/obstacle_course.toml` passes the wall without a body
overlapping it and forms the V sign beyond it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from agent.protocol.errors import UserError
from agent.protocol.spec import AgentSpec
from agent.sph.obstacles import Circle, Polygon, clearances, distance, obstacle_acceleration, obstacles_from
from agent.sph.params import SPHParams
from agent.sph.particle import NFIELDS, Control, initial_state, step_particle
from agent.sph.robot import RobotModel
from fluidswarm.recording.live import LiveAddress, LiveServer
from fluidswarm.recording.messages import obstacle_outlines
from fluidswarm.recording.reader import load_run
from fluidswarm.recording.writer import RunWriter
from fluidswarm.scenario import load_scenario
from swarmhost.router_host import free_port
from tests.foxglove_client import FoxgloveClient

REPO = Path(__file__).resolve().parent.parent
FS = [sys.executable, "-m", "fluidswarm"]
WALL = Polygon(((0.0, 0.0), (10.0, 0.0), (10.0, 1.0), (0.0, 1.0)))


def test_a_wall_pushes_along_its_normal_only_within_reach_and_range():
    ax, ay = obstacle_acceleration(5.0, 1.3, [WALL], 0.375, 1.0, 2.0)
    assert ax == 0.0 and ay > 0.0
    assert obstacle_acceleration(5.0, 1.4, [WALL], 0.375, 1.0, 2.0) == (0.0, 0.0)  # beyond r0
    assert obstacle_acceleration(5.0, 3.5, [WALL], 3.0, 1.0, 2.0) == (0.0, 0.0)  # beyond the sensing range
    near = obstacle_acceleration(5.0, -1.1, [Circle(5.0, 0.0, 1.0)], 0.375, 1.0, 2.0)
    far = obstacle_acceleration(5.0, -1.3, [Circle(5.0, 0.0, 1.0)], 0.375, 1.0, 2.0)
    assert near[1] < far[1] < 0.0  # radial, growing towards the edge


def test_signed_distances():
    assert distance(WALL, 5.0, 1.5) == pytest.approx(0.5)
    assert distance(WALL, 5.0, 0.8) == pytest.approx(-0.2)
    assert distance(Circle(0, 0, 1), 0, 3) == pytest.approx(2.0)
    got = clearances([[5.0, 1.5], [5.0, 0.8], [-3.0, 0.5]], [WALL])
    assert got == pytest.approx([0.5, -0.2, 3.0])


def test_no_obstacles_is_the_step_as_before_and_a_wall_stops_a_particle():
    params = SPHParams()
    for robot in (RobotModel(), RobotModel(kind="unicycle")):
        own = initial_state(5.0, 1.45, 0.0, -0.8, params, robot)
        plain = step_particle(own, np.empty((0, NFIELDS)), Control(), params, robot)
        assert np.array_equal(plain, step_particle(own, np.empty((0, NFIELDS)), Control(), params, robot, ()))
        state = own
        pull = Control(wx=5.0, wy=-5.0, s=1.0, alpha=5.0)  # pulled into the wall
        for _ in range(500):
            state = step_particle(state, np.empty((0, NFIELDS)), pull, params, robot, (WALL,))
            assert distance(WALL, state[0], state[1]) > 0.1


@pytest.mark.parametrize(
    ("table", "names"),
    [
        ({"kind": "square"}, "obstacle[0].kind"),
        ({"kind": "circle", "centre": [1, 2]}, "obstacle[0].radius"),
        ({"kind": "circle", "centre": [1, 2], "radius": -1}, "obstacle[0].radius"),
        ({"kind": "circle", "centre": [1], "radius": 1}, "obstacle[0].centre"),
        ({"kind": "circle", "centre": [1, 2], "radius": 1, "height": 2}, "obstacle[0].height"),
        ({"kind": "polygon", "vertices": [[0, 0], [1, 0]]}, "obstacle[0].vertices"),
        ({"kind": "polygon", "vertices": [[0, 0], [1, 1], [1, 0], [0, 1]]}, "intersects itself"),
        ({"kind": "polygon", "vertices": [[0, 0], [1, 1], [2, 2]]}, "no area"),
    ],
)
def test_bad_obstacles_name_the_key(tmp_path, table, names):
    with pytest.raises(ValueError, match=names.replace("[", r"\[").replace("]", r"\]")):
        obstacles_from([table])
    lines = [f"{k} = {json.dumps(v)}" for k, v in table.items()]
    path = tmp_path / "bad.toml"
    path.write_text('input = "x.png"\n[[obstacle]]\n' + "\n".join(lines) + "\n")
    with pytest.raises(UserError) as exc:
        load_scenario(path)
    message = str(exc.value)
    assert "\n" not in message and str(path) in message and names.split(".")[-1].split("[")[0] in message


def test_the_spec_carries_obstacles_and_refuses_bad_ones():
    spec = AgentSpec("r", 1, ["tcp/127.0.0.1:7447"], 5, [0, 0, 0, 0], obstacles=[WALL.as_dict()])
    again = AgentSpec.from_json(spec.to_json())
    assert again.obstacle_list() == (WALL,)
    assert "obstacles" not in json.loads(AgentSpec("r", 1, ["tcp/x:1"], 5, [0, 0, 0, 0]).to_json())
    with pytest.raises(ValueError, match=r'obstacles\[0\]\."radius"'):  # spec.rs names an unknown key quoted
        AgentSpec.from_json(spec.to_json().replace('"vertices"', '"radius":1,"vertices"'))


def test_an_obstacle_on_a_start_body_is_one_line(tmp_path, capsys):
    from fluidswarm.cli import main

    f = tmp_path / "o.toml"
    f.write_text('[[obstacle]]\nkind = "circle"\ncentre = [0.0, 0.0]\nradius = 0.5\n')
    code = main(["verify", "--agents", "4", "--steps", "2", "--obstacles", str(f)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code != 0 and len(err) == 1, err
    assert "--obstacles: key 'obstacle[0]': overlaps the swarm's start layout" in err[0]


@pytest.mark.swarm
def test_verify_among_obstacles_is_exact():
    r = subprocess.run(
        FS
        + ["verify", "--agents", "64", "--steps", "120", "--robot", "unicycle"]
        + ["--obstacles", "scenarios/inputs/block_obstacles.toml"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    err = float(next(ln for ln in r.stdout.splitlines() if ln.startswith("max_position_error=")).split("=")[1])
    assert err <= 1e-9


@pytest.mark.swarm
def test_the_obstacle_course_passes_the_wall_without_touching_it(tmp_path):
    r = subprocess.run(
        FS + ["run", "scenarios/obstacle_course.toml", "--out", str(tmp_path), "--json"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=900,
    )
    record = json.loads(r.stdout)
    assert r.returncode == 0, (record.get("why"), r.stderr[-2000:])
    assert record["obstacle_penetrations"] == 0 and record["min_obstacle_distance_m"] > 0.25
    assert record["fidelity"]["iou"] >= 0.7
    last = load_run(record["mcap"], images=False).frames[-1].positions
    scenario = load_scenario(REPO / "scenarios/obstacle_course.toml")
    obstacles = scenario.obstacles
    _assert_outlines(_recorded_outlines(record["mcap"]), obstacles)  # the recorder drew them in the scene
    _assert_bodies(record["mcap"], scenario.robot)
    wall_top = max(y for o in obstacles if isinstance(o, Polygon) for _x, y in o.vertices)
    assert (last[:, 1] > wall_top).mean() >= 0.95  # the swarm is beyond the wall


def _outlines(scene_update: dict) -> list[np.ndarray]:
    """The line loops of a `foxglove.SceneUpdate`'s entity `obstacles`, as (n, 2) arrays."""
    return [
        np.array([(p["x"], p["y"]) for p in line["points"]])
        for e in scene_update["entities"]
        if e["id"] == "obstacles"
        for line in e["lines"]
    ]


def _recorded_outlines(mcap: str | Path) -> list[np.ndarray]:
    with open(mcap, "rb") as f:
        found = [
            _outlines(json.loads(m.data))
            for _s, ch, m in make_reader(f).iter_messages()
            if ch.topic.endswith("/scene") and b'"obstacles"' in m.data
        ]
    assert len(found) == 1, f"{len(found)} scene updates with obstacles"
    return found[0]


def _assert_outlines(loops: list[np.ndarray], obstacles) -> None:
    assert len(loops) == len(obstacles)
    for loop, o in zip(loops, obstacles):
        if isinstance(o, Circle):
            assert len(loop) >= 32
            np.testing.assert_allclose(np.hypot(loop[:, 0] - o.x, loop[:, 1] - o.y), o.radius)
        else:
            np.testing.assert_array_equal(loop, np.array(o.vertices))


def test_the_obstacles_are_scene_entities_live_and_recorded(tmp_path):
    """Written once at the start: in the MCAP's scene and sent to a viewer that connects later."""
    obstacles = (Circle(3.0, 4.0, 0.6), WALL)
    port = free_port()
    live = LiveServer(LiveAddress("127.0.0.1", port), "obstacles")
    try:
        with RunWriter(tmp_path / "run.mcap", {"run": "obstacles"}, live=live) as w:
            w.write_obstacles(0.0, obstacles)
            client = FoxgloveClient(f"ws://127.0.0.1:{port}")
            client.subscribe(client.channel("scene")["id"], 1)
            got = client.message(timeout=5)
            client.close()
    finally:
        assert live.close()
    assert got is not None and got[0] == 1
    _assert_outlines(_outlines(json.loads(got[2])), obstacles)
    _assert_outlines(_recorded_outlines(tmp_path / "run.mcap"), obstacles)
    with pytest.raises(ValueError, match="at least one"):
        obstacle_outlines(0.0, ())


def _assert_bodies(mcap: str | Path, robot) -> None:
    """The recorder draws the unicycles' bodies and headings in the scene (entity `bodies`) every few steps:
    a disc of the body radius at each axle centre, which lies `offset` behind the recorded particle, and an
    arrow along the heading, pointing from the axle centre to the particle."""
    run = load_run(mcap, images=False)
    by_t = {f.t: f for f in run.frames}
    with open(mcap, "rb") as f:
        updates = [
            (m.log_time / 1e9, json.loads(m.data))
            for _s, ch, m in make_reader(f).iter_messages()
            if ch.topic.endswith("/scene") and b'"bodies"' in m.data
        ]
    assert len(updates) >= len(run.frames) // 10, (len(updates), len(run.frames))
    t, last = updates[-1]
    (bodies,) = [e for e in last["entities"] if e["id"] == "bodies"]
    frame = min(by_t.values(), key=lambda fr: abs(fr.t - t))
    assert abs(frame.t - t) < 1e-6 and len(bodies["cylinders"]) == len(bodies["arrows"]) == len(frame.ids)
    centres = np.array([(c["pose"]["position"]["x"], c["pose"]["position"]["y"]) for c in bodies["cylinders"]])
    assert all(c["size"]["x"] == pytest.approx(2 * robot.radius) for c in bodies["cylinders"])
    np.testing.assert_allclose(np.hypot(*(frame.positions - centres).T), robot.offset, rtol=1e-6)
    yaw = np.array(
        [2 * np.arctan2(a["pose"]["orientation"]["z"], a["pose"]["orientation"]["w"]) for a in bodies["arrows"]]
    )
    ahead = frame.positions - centres
    np.testing.assert_allclose(np.column_stack([np.cos(yaw), np.sin(yaw)]) * robot.offset, ahead, atol=1e-6)
