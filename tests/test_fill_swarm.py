"""A native swarm following a fill command (the silhouette as rings, agent/fill.py) equals the reference drivers.

The shape is an annulus, so the command carries an outer ring and a hole: agents start partly outside the
vessel (in the hole and beyond the outer edge) and pull themselves in by the fill law, each deciding from its
own position only. The compiled agents (agent/native/src/fill.rs, route.rs) must land where the Python
oracle (coordinator/control/route.py FillFollower through followers_for) puts them, to rounding.
"""

from __future__ import annotations

import threading
import time
from dataclasses import replace

import numpy as np
import pytest
import zenoh

from agent.fill import inside, zone_material
from agent.protocol import keys
from agent.protocol.access import PASSWORD_ENV, USER_ENV
from agent.protocol.command import Zone
from agent.protocol.session import client_config
from agent.sph.particle import X, Y
from agent.sph.reference import PerParticleDriver, VectorisedDriver
from coordinator.control.imitation_setup import imitation_for
from coordinator.control.observe import Observation
from coordinator.control.route import followers_for
from swarmhost.launcher import Launcher, run_swarm

pytestmark = pytest.mark.swarm  # starts agents, routers or the CLI (tests/conftest.py)

N_AGENTS = 16
STEPS = 150


def annulus_setup():
    yy, xx = np.mgrid[0:120, 0:120]
    r = np.hypot(xx - 60, yy - 60)
    mask = (r < 50) & (r > 22)
    return imitation_for([Observation("hand", mask, "annulus")], N_AGENTS, controller="fill")


def test_native_swarm_fills_a_shape_with_a_hole_like_the_reference():
    im = annulus_setup()
    setup = im.setup
    # A material zone over the left half of the ring (as the arms of a body get): agents crossing its edge
    # switch stiffness and viscosity, each by its own position.
    outer = np.array(im.command.fill.rings[0])
    (x0, y0), (x1, y1) = outer.min(axis=0), outer.max(axis=0)
    zone = Zone(
        float(x0 + 0.25 * (x1 - x0)), float(0.5 * (y0 + y1)), 0.0, 1.0, 0.5 * (y1 - y0), 0.25 * (x1 - x0), 20.0, 1.0
    )
    cmd = replace(im.command, fill=replace(im.command.fill, zones=(zone,)))
    assert cmd.fill is not None and len(cmd.fill.rings) == 2  # the outer boundary and the hole
    start = setup.states[:, [X, Y]]
    outside = [not inside(cmd.fill.rings, x, y) for x, y in start]
    assert 0 < sum(outside) < N_AGENTS  # the law has both branches to decide

    stop = threading.Event()
    with Launcher(commands=True, agent_timeout=15.0) as la:
        payload = cmd.encode(bytes.fromhex(la.secret))

        def coordinator():  # the coordinator (its own credentials: only it may put the command) republishes it
            cred = la.access.env_for("coordinator")
            s = zenoh.open(client_config([la.endpoint], cred.get(USER_ENV, ""), cred.get(PASSWORD_ENV, "")))
            try:
                while not stop.is_set():
                    s.put(keys.command_key(la.run), payload)
                    time.sleep(0.05)
            finally:
                s.close()

        t = threading.Thread(target=coordinator, daemon=True)
        t.start()
        try:
            res = run_swarm(setup, STEPS, launcher=la)
        finally:
            stop.set()
            t.join(10)

    got = np.array([res.finals[int(i)].state for i in setup.ids])
    vec = VectorisedDriver(setup.ids, setup.states, followers_for(cmd, setup.ids), setup.params).run(STEPS)
    per = PerParticleDriver(setup.ids, setup.states, followers_for(cmd, setup.ids), setup.params).run(STEPS)
    err_vec = np.abs(got[:, [X, Y]] - vec[:, [X, Y]]).max()
    err_per = np.abs(got[:, [X, Y]] - per[:, [X, Y]]).max()
    inside_end = sum(inside(cmd.fill.rings, x, y) for x, y in got[:, [X, Y]])
    in_zone = [
        zone_material(cmd.fill.zones, x, y, 0.0, 0.0) != (0.0, 0.0) for x, y in np.vstack([start, got[:, [X, Y]]])
    ]
    assert 0 < sum(in_zone) < len(in_zone)  # both materials are in play
    print(
        f"fill swarm: max |native - vectorised| {err_vec:.2e} m, |native - per-particle| {err_per:.2e} m; "
        f"inside {N_AGENTS - sum(outside)} -> {inside_end} of {N_AGENTS}"
    )
    assert err_vec <= 1e-9 and err_per <= 1e-9
    assert np.abs(got[:, [X, Y]] - start).max() > 1.0  # the command moved them
    assert inside_end > N_AGENTS - sum(outside)  # and the shape drew them in
    for i in setup.ids:
        r = res.finals[int(i)]
        assert (r.command_seq, r.particle_class, r.waypoint_index) == (cmd.seq, 0, 0), r
