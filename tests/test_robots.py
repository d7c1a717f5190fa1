"""Robots as fluid particles (issue 33): the models' physics, the wire record's pose, the contact counter,
the spec's and the scenario's checks. Pure logic; the agent processes are in test_robots_swarm.py."""

from __future__ import annotations

import json
import math
import struct

import numpy as np
import pytest

from agent.protocol.errors import UserError
from agent.protocol.spec import AgentSpec
from agent.protocol.wire import REJECT_VERSION, STATE_SIZE, decode_state, encode_state, peek_id_position
from agent.sph.particle import HEADING, NFIELDS, SPEED, VX, VY, Control, X, Y, initial_state, step_particle
from agent.sph.reference import PerParticleDriver, VectorisedDriver
from agent.sph.robot import (
    CONTACT_MARGIN,
    POINT,
    RobotModel,
    body_centres,
    braking_distance,
    check_layout,
    contact_onset,
    contact_terms,
    holonomic_velocity,
    offset_tracking,
    unicycle_step,
    wrap_angle,
)
from agent.sph.setups import spread_block
from fluidswarm.recording.contacts import ContactCounter
from fluidswarm.scenario import load_scenario

UNICYCLE = RobotModel(kind="unicycle")
HOLONOMIC = RobotModel(kind="holonomic")


@pytest.mark.parametrize(
    "fields, key",
    [
        ({"kind": "tank"}, "robot.kind"),
        ({"kind": "unicycle", "radius": -0.1}, "robot.radius"),
        ({"kind": "unicycle", "radius": 0.0}, "robot.radius"),
        ({"kind": "holonomic", "v_max": math.inf}, "robot.v_max"),
        ({"kind": "holonomic", "a_max": math.nan}, "robot.a_max"),
        ({"kind": "unicycle", "omega_max": 0.0}, "robot.omega_max"),
        ({"kind": "unicycle", "offset": -1.0}, "robot.offset"),
    ],
)
def test_bad_robot_models_name_the_key(fields, key):
    with pytest.raises(ValueError, match=f"^{key}: "):
        RobotModel(**fields)


def test_a_robot_faster_than_the_fluid_or_too_big_for_the_layout_is_refused():
    with pytest.raises(ValueError, match="^robot.v_max: "):
        UNICYCLE.check_fits(1.0)  # 0.86 + 0.1 * 4.9 = 1.35 m/s
    UNICYCLE.check_fits(1.35)
    block = spread_block(16)  # spacing 1 m
    with pytest.raises(ValueError, match="^robot.radius: 0.6 m does not fit the start layout"):
        block.with_robot(RobotModel(kind="holonomic", radius=0.6))
    assert block.with_robot(RobotModel(kind="holonomic", radius=0.5)).robot.radius == 0.5
    check_layout(np.array([[0.0, 0.0], [0.3, 0.0]]), RobotModel(radius=0.0))  # a point of no size fits


def test_the_point_model_is_the_thesis_particle_unchanged():
    setup = spread_block(25)
    a = PerParticleDriver(setup.ids, setup.states, setup.controls, setup.params).run(30)
    b = PerParticleDriver(setup.ids, setup.states, setup.controls, setup.params, POINT).run(30)
    assert np.array_equal(a, b)
    assert not a[:, [HEADING, SPEED]].any()


def test_holonomic_limits():
    vx, vy = holonomic_velocity(0.0, 0.0, 10.0, 0.0, HOLONOMIC, 0.01)
    assert vx == pytest.approx(HOLONOMIC.a_max * 0.01) and vy == 0.0
    v = (0.0, 0.0)
    for _ in range(200):
        v = holonomic_velocity(*v, 10.0, 10.0, HOLONOMIC, 0.01)
    assert math.hypot(*v) == pytest.approx(HOLONOMIC.v_max)
    assert holonomic_velocity(0.3, 0.1, 0.31, 0.1, HOLONOMIC, 0.01) == (0.31, 0.1)  # within the limits: as asked


def test_the_offset_law_inverts_the_point_offset_kinematics():
    # P' = R(theta) [s, l w]: the (s, w) of offset_tracking give the desired velocity back exactly
    for heading in (-2.5, -0.3, 0.0, 1.0, 3.0):
        ux, uy = 0.4, -0.7
        s, w = offset_tracking(ux, uy, heading, 0.1)
        c, sn = math.cos(heading), math.sin(heading)
        assert (c * s - sn * 0.1 * w, sn * s + c * 0.1 * w) == pytest.approx((ux, uy), abs=1e-15)


def test_an_unsaturated_unicycle_moves_its_point_as_asked_and_its_limits_hold():
    nx, ny, vx, vy, h, s = unicycle_step(1.0, 2.0, 0.0, 0.3, 0.3, 0.02, UNICYCLE, 0.01)
    assert (vx, vy) == pytest.approx((0.3, 0.02), abs=2e-3)  # one step's turn bends the path slightly
    assert (nx, ny) == pytest.approx((1.0 + 0.01 * vx, 2.0 + 0.01 * vy))
    _x, _y, _vx, _vy, h, s = unicycle_step(0.0, 0.0, 0.0, 0.0, -50.0, 50.0, UNICYCLE, 0.01)
    assert s == pytest.approx(-UNICYCLE.a_max * 0.01) and h == pytest.approx(UNICYCLE.omega_max * 0.01)
    assert wrap_angle(math.pi + 0.1) == pytest.approx(-math.pi + 0.1) and wrap_angle(-math.pi) == math.pi


def test_a_unicycle_turns_towards_its_waypoint_and_gets_there():
    params = spread_block(1).params.with_(drag=2.0)  # damped, so it settles instead of orbiting
    state = initial_state(0.0, 0.0, 0.0, 0.0, params, UNICYCLE)  # facing +x
    control = Control(wx=0.0, wy=5.0, r=0.0, s=2.0, alpha=2.0)  # the waypoint is to its left
    for _ in range(1500):
        state = step_particle(state, np.empty((0, NFIELDS)), control, params, UNICYCLE)
        assert math.hypot(state[VX], state[VY]) <= UNICYCLE.top_particle_speed + 1e-9
        assert abs(state[SPEED]) <= UNICYCLE.v_max
    assert math.hypot(state[X], state[Y] - 5.0) < 0.3
    assert state[HEADING] != 0.0


@pytest.mark.parametrize("robot", [HOLONOMIC, UNICYCLE], ids=lambda r: r.kind)
def test_both_reference_drivers_agree_on_robots(robot):
    setup = spread_block(36).with_robot(robot)
    a = PerParticleDriver(setup.ids, setup.states, setup.controls, setup.params, robot).run(150)
    b = VectorisedDriver(setup.ids, setup.states, setup.controls, setup.params, robot).run(150)
    assert np.abs(a[:, [X, Y, HEADING]] - b[:, [X, Y, HEADING]]).max() < 1e-9
    assert np.abs(a[:, [X, Y]] - setup.states[:, [X, Y]]).max() > 0.1  # they did move


def test_bodies_repulsion_begins_a_braking_distance_before_the_margin():
    # a robot at v_max braking at a_max rolls v_max^2 / (2 a_max) = 0.2175 m: the force must begin that much
    # earlier than contact plus the margin, or it drives into a crowded neighbour's body
    assert braking_distance(UNICYCLE) == pytest.approx(0.86**2 / 3.4)
    assert braking_distance(POINT) == 0.0
    assert contact_onset(UNICYCLE, 1.0) == pytest.approx(2 * 0.25 + CONTACT_MARGIN + 0.86**2 / 3.4)
    assert contact_onset(UNICYCLE, 1.0) - 2 * UNICYCLE.radius > braking_distance(UNICYCLE)


def test_bodies_repel_at_close_range_only():
    r0 = contact_onset(UNICYCLE, 1.0)
    tx, ty = contact_terms(np.array([0.4, r0, 1.0, 0.0]), np.array([0.0, 0.0, 0.0, 0.0]), r0, 1.0)
    assert tx[0] > 0 and ty[0] == 0  # pushed apart along x_ij
    assert list(tx[1:]) == [0.0, 0.0, 0.0]  # at r0, beyond it and on top (no direction): nothing


def test_unicycle_bodies_sit_behind_their_tracked_point():
    s = np.zeros((1, NFIELDS))
    s[0, [X, Y, HEADING]] = 2.0, 3.0, math.pi / 2
    assert body_centres(s, UNICYCLE)[0] == pytest.approx([2.0, 3.0 - UNICYCLE.offset])
    assert body_centres(s, HOLONOMIC)[0] == pytest.approx([2.0, 3.0])


def test_wire_v2_carries_the_pose_and_refuses_v1_by_its_version():
    state = np.zeros(NFIELDS)
    state[[X, Y, 4, HEADING, SPEED]] = 1.0, 2.0, 0.9, -1.5, 0.4
    data = encode_state(3, 7, state, 2)
    assert len(data) == STATE_SIZE == 104
    (agent, step, cls, values), _ = decode_state(data)
    assert (agent, step, cls) == (3, 7, 2) and values[HEADING] == -1.5 and values[SPEED] == 0.4
    v1 = struct.pack("<BBHIIHH9d", 1, 1, 0, 3, 7, 0, 0, 1.0, 2.0, 0, 0, 0.9, 0, 0, 0, 0)
    assert decode_state(v1) == (None, REJECT_VERSION)
    assert peek_id_position(v1) == (None, REJECT_VERSION)
    state[HEADING] = 4.0
    assert decode_state(encode_state(3, 7, state, 2)) == (None, "value")


def test_collisions_are_counted_once_per_pair_and_episode():
    cc = ContactCounter(HOLONOMIC)  # radius 0.25: bodies touch below 0.5 m
    ids = np.array([4, 9, 12])

    def rows(gap):
        s = np.zeros((3, NFIELDS))
        s[:, X] = [0.0, gap, 10.0]
        return s

    for gap in (1.0, 0.45, 0.4, 0.45, 0.8, 0.3, 2.0):
        cc.update(ids, rows(gap))
    assert cc.collisions == 2  # (4, 9) touched twice: steps 2-4 and step 6
    assert cc.min_separation_m == pytest.approx(0.3)
    assert cc.figures()["collisions"] == 2


def test_the_spec_carries_the_robot_and_checks_it():
    setup = spread_block(4)
    base = {
        "run": "r1",
        "id": 0,
        "connect": ["tcp/127.0.0.1:7447"],
        "steps": 1,
        "initial": [0, 0, 0, 0],
        "params": {k: (list(v) if k == "domain" else v) for k, v in setup.params.as_dict().items()},
    }
    spec = AgentSpec.from_json(json.dumps({**base, "robot": UNICYCLE.as_dict()}))
    assert spec.robot_model() == UNICYCLE
    for bad, key in (
        ({"kind": "tank"}, "robot.kind"),
        ({"kind": "unicycle", "radius": -1}, "robot.radius"),
        ({"kind": "unicycle", "wheels": 3}, "wheels"),
        ({"kind": "unicycle", "v_max": 9.0}, "robot.v_max"),
    ):
        with pytest.raises(ValueError, match=key):
            AgentSpec.from_json(json.dumps({**base, "robot": bad}))


@pytest.mark.parametrize(
    "table, message",
    [
        ('kind = "tank"', "key 'robot.kind': must be one of"),
        ('kind = "unicycle"\nradius = -0.2', "key 'robot.radius': must be >= 0"),
        ('kind = "unicycle"\nwheels = 2', "key 'robot.wheels': unknown key"),
        ('kind = "holonomic"\nv_max = "fast"', "key 'robot.v_max': must be a finite number"),
    ],
)
def test_a_scenarios_robot_table_is_checked_on_load(tmp_path, table, message):
    path = tmp_path / "s.toml"
    path.write_text(f'experiment = "drag"\n[robot]\n{table}\n')
    with pytest.raises(UserError, match=message):
        load_scenario(path)
    path.write_text('experiment = "drag"\n[robot]\nkind = "unicycle"\nradius = 0.3\n')
    assert load_scenario(path).robot == RobotModel(kind="unicycle", radius=0.3)


def test_a_bad_robot_on_the_command_line_is_one_line_before_anything_starts(tmp_path, capsys):
    # in this process: tests/conftest.py fails a unit test that starts an agent, a router or a session
    from fluidswarm.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["verify", "--robot", "tank"])
    assert exc.value.code == 2 and "invalid choice: 'tank'" in capsys.readouterr().err
    path = tmp_path / "bad.toml"
    path.write_text('experiment = "drag"\n[robot]\nkind = "unicycle"\nradius = 0.7\n')  # the block is 1 m apart
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "key 'robot.radius': 0.7 m does not fit the start layout" in err[0], err
