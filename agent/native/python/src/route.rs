//! The fill law (agent crate: fill.rs) and how an agent follows a command (route.rs) for agent/fill.py and
//! coordinator/control/route.py: the reference drivers (`fluidswarm verify`, `reproduce`) then follow a
//! command with the agents' own code.

use fluidswarm_agent::command::{Fill, Waypoint, Zone};
use fluidswarm_agent::fill::{self, Ring};
use fluidswarm_agent::route;
use fluidswarm_agent::sph::{Control, NFIELDS, X, Y};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// A control as the tuple (wx, wy, r, s, alpha, beta, mu, push_x, push_y) of agent/sph/particle.py Control.
type ControlTuple = (f64, f64, f64, f64, f64, f64, f64, f64, f64);

fn tuple(c: Control) -> ControlTuple {
    (c.wx, c.wy, c.r, c.s, c.alpha, c.beta, c.mu, c.push_x, c.push_y)
}

/// A zone as (x, y, ux, uy, a, b, beta, mu).
type ZoneTuple = (f64, f64, f64, f64, f64, f64, f64, f64);

fn zone((x, y, ux, uy, a, b, beta, mu): ZoneTuple) -> Zone {
    Zone { x, y, ux, uy, a, b, beta, mu }
}

#[pyfunction]
fn fill_inside(rings: Vec<Ring>, x: f64, y: f64) -> bool {
    fill::inside(&rings, x, y)
}

#[pyfunction]
fn fill_nearest_point(rings: Vec<Ring>, x: f64, y: f64) -> (f64, f64) {
    fill::nearest_point(&rings, x, y)
}

#[pyfunction]
fn fill_zone_material(zones: Vec<ZoneTuple>, x: f64, y: f64, beta: f64, mu: f64) -> (f64, f64) {
    fill::zone_material(&zones.into_iter().map(zone).collect::<Vec<_>>(), x, y, beta, mu)
}

#[pyfunction]
fn route_class_counts(n: u64, shares: Vec<f64>) -> Vec<u64> {
    route::class_counts(n, &shares)
}

#[pyfunction]
fn route_class_of(agent_id: u64, n: u64, shares: Vec<f64>) -> usize {
    route::class_of(agent_id, n, &shares)
}

/// Waypoint after waypoint (route.rs RouteFollower); a waypoint is (x, y, r, s, alpha, beta | None, mu | None).
#[pyclass(module = "agent._native")]
struct RouteFollower(route::RouteFollower);

type WaypointTuple = (f64, f64, f64, f64, f64, Option<f64>, Option<f64>);

#[pymethods]
impl RouteFollower {
    #[new]
    fn new(route: Vec<WaypointTuple>, beta: f64, mu: f64, push: (f64, f64)) -> PyResult<Self> {
        if route.is_empty() {
            return Err(PyValueError::new_err("a route has at least one waypoint"));
        }
        let route = route.into_iter().map(|(x, y, r, s, alpha, beta, mu)| Waypoint { x, y, r, s, alpha, beta, mu });
        Ok(RouteFollower(route::RouteFollower::new(route.collect(), beta, mu, push)))
    }

    fn control(&mut self, x: f64, y: f64) -> ControlTuple {
        tuple(self.0.control(x, y))
    }

    #[getter]
    fn index(&self) -> usize {
        self.0.index
    }

    #[getter]
    fn beta(&self) -> f64 {
        self.0.beta
    }

    #[getter]
    fn mu(&self) -> f64 {
        self.0.mu
    }
}

/// The fill law for one agent (route.rs FillFollower): the shape's rings, gain, ramp and zones.
#[pyclass(module = "agent._native")]
struct FillFollower(route::FillFollower);

#[pymethods]
impl FillFollower {
    #[new]
    fn new(rings: Vec<Ring>, alpha: f64, s: f64, zones: Vec<ZoneTuple>, beta: f64, mu: f64) -> Self {
        let fill = Fill { rings, alpha, s, zones: zones.into_iter().map(zone).collect() };
        FillFollower(route::FillFollower::new(&fill, beta, mu))
    }

    fn control(&self, x: f64, y: f64) -> ControlTuple {
        tuple(self.0.control(x, y))
    }
}

/// The agent's controller (route.rs CommandFollower): accepts signed commands, follows the newest from the
/// next `control`; `static_control` until the first.
#[pyclass(module = "agent._native")]
struct CommandFollower(route::CommandFollower);

/// The controller's part of the final report: (commands_accepted, particle_class, waypoint_index, command_seq,
/// first_command_at).
type FollowingTuple = (u64, u16, i64, i64, Option<f64>);

#[pymethods]
impl CommandFollower {
    #[new]
    fn new(secret: Vec<u8>, agent_id: u32, static_control: ControlTuple) -> Self {
        let (wx, wy, r, s, alpha, beta, mu, push_x, push_y) = static_control;
        let c = Control { wx, wy, r, s, alpha, beta, mu, push_x, push_y };
        CommandFollower(route::CommandFollower::new(secret, agent_id, c))
    }

    /// None: accepted, or a republication of the current command; else why it was refused.
    fn offer(&mut self, payload: &[u8], now_unix: f64) -> Option<&'static str> {
        self.0.offer(payload, now_unix)
    }

    #[getter]
    fn has_command(&self) -> bool {
        self.0.has_command()
    }

    fn control(&mut self, x: f64, y: f64) -> ControlTuple {
        let mut state = [0.0; NFIELDS];
        (state[X], state[Y]) = (x, y);
        tuple(self.0.control(&state))
    }

    fn report(&self) -> FollowingTuple {
        let f = self.0.report();
        (f.commands_accepted, f.particle_class, f.waypoint_index, f.command_seq, f.first_command_at)
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(fill_inside, m)?)?;
    m.add_function(wrap_pyfunction!(fill_nearest_point, m)?)?;
    m.add_function(wrap_pyfunction!(fill_zone_material, m)?)?;
    m.add_function(wrap_pyfunction!(route_class_counts, m)?)?;
    m.add_function(wrap_pyfunction!(route_class_of, m)?)?;
    m.add_class::<RouteFollower>()?;
    m.add_class::<FillFollower>()?;
    m.add_class::<CommandFollower>()?;
    Ok(())
}
