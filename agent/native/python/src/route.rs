//! The fill law (agent crate: fill.rs) and how an agent follows a command (route.rs) for agent/fill.py and
//! coordinator/control/route.py: the reference drivers (`fluidswarm verify`, `reproduce`) then follow a
//! command with the agents' own code.

use fluidswarm_agent::command::{Fill, Waypoint, Zone};
use fluidswarm_agent::fill::{self, Ring};
use fluidswarm_agent::route;
use fluidswarm_agent::sph::Control;
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

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(fill_inside, m)?)?;
    m.add_function(wrap_pyfunction!(fill_nearest_point, m)?)?;
    m.add_function(wrap_pyfunction!(fill_zone_material, m)?)?;
    m.add_function(wrap_pyfunction!(route_class_counts, m)?)?;
    m.add_function(wrap_pyfunction!(route_class_of, m)?)?;
    m.add_class::<RouteFollower>()?;
    m.add_class::<FillFollower>()?;
    Ok(())
}
