//! How an agent follows a gesture command, decided locally from its id: a port of coordinator/control/route.py.
//!
//! The Python module stays the oracle (the reference drivers use it), so the arithmetic here is Python's,
//! operation for operation: a different rounding could put a particle in another class or make it reach a
//! waypoint one step earlier than the reference.
//!
//! Here the class split and the followers of one command (route, fill); `CommandFollower` (accepting signed
//! commands, switching at the next step) is in route/command_follower.rs.

mod command_follower;

pub use command_follower::CommandFollower;

use crate::command::{Fill, GestureCommand, Waypoint, Zone};
use crate::fill::{inside, nearest_point, zone_material, Ring};
use crate::sph::Control;

/// Largest-remainder split of n particles over the class shares (deterministic).
pub fn class_counts(n: u64, shares: &[f64]) -> Vec<u64> {
    let total: f64 = shares.iter().fold(0.0, |acc, s| acc + s); // Python's sum: left to right from 0
    let exact: Vec<f64> = shares.iter().map(|s| n as f64 * s / total).collect();
    let mut counts: Vec<u64> = exact.iter().map(|e| e.floor() as u64).collect();
    let rest = n as i64 - counts.iter().sum::<u64>() as i64;
    let mut order: Vec<usize> = (0..shares.len()).collect();
    // sorted by (-(remainder), k): largest remainder first, ties to the lower class
    order.sort_by(|&a, &b| {
        let (ra, rb) = (-(exact[a] - counts[a] as f64), -(exact[b] - counts[b] as f64));
        ra.partial_cmp(&rb).unwrap_or(std::cmp::Ordering::Equal).then(a.cmp(&b))
    });
    // Python's order[:rest], a negative rest included (it drops from the end)
    let take = if rest >= 0 {
        (rest as usize).min(order.len())
    } else {
        order.len().saturating_sub(rest.unsigned_abs() as usize)
    };
    for &k in &order[..take] {
        counts[k] += 1;
    }
    counts
}

/// The class of particle `agent_id`: ids 0..n-1 in order fill class 0, then 1, ...; ids >= n (late
/// joiners) are spread over the classes with particles, round-robin.
pub fn class_of(agent_id: u64, n: u64, shares: &[f64]) -> usize {
    let counts = class_counts(n, shares);
    if agent_id >= n {
        let nonzero: Vec<usize> = (0..counts.len()).filter(|&k| counts[k] > 0).collect();
        // (Python divides by zero here; a validated command always has a class with particles.)
        return nonzero.get((agent_id % nonzero.len().max(1) as u64) as usize).copied().unwrap_or(0);
    }
    let mut edge = 0;
    for (k, c) in counts.iter().enumerate() {
        edge += c;
        if agent_id < edge {
            return k;
        }
    }
    counts.len().saturating_sub(1)
}

/// Python's `d ** 2` is the C library's pow(d, 2.0), which rounds differently from d * d for about one
/// argument in a thousand (glibc 2.36); LLVM would rewrite a literal pow(d, 2.0) into d * d, hence the
/// opaque exponent.
fn py_square(d: f64) -> f64 {
    d.powf(std::hint::black_box(2.0))
}

/// Waypoint after waypoint: advance when within r of the current one (the last one is kept); switch
/// beta/mu when a waypoint that names them is reached.
#[derive(Clone, Debug)]
pub struct RouteFollower {
    pub route: Vec<Waypoint>,
    pub index: usize,
    pub beta: f64,
    pub mu: f64,
    pub push: (f64, f64),
}

impl RouteFollower {
    /// `route` must not be empty (a validated command's routes never are).
    pub fn new(route: Vec<Waypoint>, beta: f64, mu: f64, push: (f64, f64)) -> Self {
        assert!(!route.is_empty(), "a route has at least one waypoint");
        RouteFollower { route, index: 0, beta, mu, push }
    }

    pub fn control(&mut self, x: f64, y: f64) -> Control {
        loop {
            let w = &self.route[self.index];
            let reached = py_square(x - w.x) + py_square(y - w.y) <= w.r * w.r;
            if !reached {
                break;
            }
            if let Some(beta) = w.beta {
                self.beta = beta;
            }
            if let Some(mu) = w.mu {
                self.mu = mu;
            }
            if self.index + 1 >= self.route.len() {
                break;
            }
            self.index += 1;
        }
        let w = &self.route[self.index];
        Control {
            wx: w.x,
            wy: w.y,
            r: w.r,
            s: w.s,
            alpha: w.alpha,
            beta: self.beta,
            mu: self.mu,
            push_x: self.push.0,
            push_y: self.push.1,
        }
    }
}

/// The fill law (agent/fill.py): no body force inside the shape, eq. 6.2 towards the nearest boundary point
/// outside it (r = 0, so the pull fades to nothing on the boundary); the stiffness and viscosity of the zone
/// the particle is in, else the command's.
#[derive(Clone, Debug)]
pub struct FillFollower {
    pub rings: Vec<Ring>,
    pub alpha: f64,
    pub s: f64,
    pub zones: Vec<Zone>,
    pub beta: f64,
    pub mu: f64,
}

impl FillFollower {
    pub fn new(fill: &Fill, beta: f64, mu: f64) -> Self {
        FillFollower { rings: fill.rings.clone(), alpha: fill.alpha, s: fill.s, zones: fill.zones.clone(), beta, mu }
    }

    pub fn control(&self, x: f64, y: f64) -> Control {
        let (beta, mu) = zone_material(&self.zones, x, y, self.beta, self.mu);
        let (wx, wy, alpha) = if inside(&self.rings, x, y) {
            (x, y, 0.0)
        } else {
            let (px, py) = nearest_point(&self.rings, x, y);
            (px, py, self.alpha)
        };
        Control { wx, wy, r: 0.0, s: self.s, alpha, beta, mu, push_x: 0.0, push_y: 0.0 }
    }
}

/// What an agent follows (coordinator/control/route.py `follower`): the command's shape if it has one, else its class'
/// route.
#[derive(Clone, Debug)]
pub enum Follower {
    Route(RouteFollower),
    Fill(FillFollower),
}

impl Follower {
    pub fn for_command(cmd: &GestureCommand, particle_class: usize) -> Self {
        match &cmd.fill {
            Some(fill) => Follower::Fill(FillFollower::new(fill, cmd.beta, cmd.mu)),
            None => Follower::Route(RouteFollower::new(
                cmd.classes[particle_class].route.clone(),
                cmd.beta,
                cmd.mu,
                (0.0, 0.0),
            )),
        }
    }

    pub fn control(&mut self, x: f64, y: f64) -> Control {
        match self {
            Follower::Route(f) => f.control(x, y),
            Follower::Fill(f) => f.control(x, y),
        }
    }

    /// The waypoint reached so far; a shape has none (reported as waypoint 0).
    pub fn index(&self) -> usize {
        match self {
            Follower::Route(f) => f.index,
            Follower::Fill(_) => 0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wp(x: f64, y: f64, r: f64, beta: Option<f64>) -> Waypoint {
        Waypoint { x, y, r, s: 1.0, alpha: 2.0, beta, mu: None }
    }

    #[test]
    fn largest_remainder() {
        assert_eq!(class_counts(10, &[1.0, 1.0, 1.0]), vec![4, 3, 3]);
        assert_eq!(class_counts(7, &[0.5, 0.0, 0.5]), vec![4, 0, 3]);
        assert_eq!(class_of(3, 10, &[1.0, 1.0, 1.0]), 0);
        assert_eq!(class_of(4, 10, &[1.0, 1.0, 1.0]), 1);
        assert_eq!(class_of(9, 10, &[1.0, 1.0, 1.0]), 2);
        // late joiners: round-robin over the classes that have particles
        assert_eq!(class_of(7, 7, &[0.5, 0.0, 0.5]), 2);
        assert_eq!(class_of(8, 7, &[0.5, 0.0, 0.5]), 0);
    }

    #[test]
    fn follows_the_route() {
        let mut f =
            RouteFollower::new(vec![wp(0.0, 0.0, 1.0, Some(5.0)), wp(10.0, 0.0, 1.0, None)], 2.0, 0.0, (0.0, 0.0));
        let c = f.control(5.0, 5.0);
        assert_eq!((c.wx, c.beta, f.index), (0.0, 2.0, 0));
        let c = f.control(0.5, 0.0);
        assert_eq!((c.wx, c.beta, f.index), (10.0, 5.0, 1));
        let c = f.control(10.0, 0.0); // the last waypoint is kept
        assert_eq!((c.wx, f.index), (10.0, 1));
    }

    #[test]
    fn static_until_a_command() {
        let mut cf = CommandFollower::new(vec![1, 2, 3], 0, Control::default());
        assert!(!cf.has_command());
        assert_eq!(cf.control(&[0.0; crate::sph::NFIELDS]), Control::default());
        assert_eq!(cf.offer(b"junk", 1.0), Some("malformed"));
        let r = cf.report();
        assert_eq!((r.waypoint_index, r.first_command_at), (-1, None));
    }
}
