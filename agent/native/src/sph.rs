//! One particle's SPH step: a port of `agent/sph` (kernel.py, equations.py, particle.py).
//!
//! The Python module stays the oracle: `fluidswarm verify` compares a swarm of these agents with the
//! per-particle reference driver. Every formula below is the one of the Python function named in its
//! comment, evaluated in the same order, so the two agree to rounding (numpy's pairwise summation of a
//! handful of terms versus a plain loop: ~1e-16 relative).

use std::f64::consts::PI;

use crate::obstacle::{self, Obstacle};
use crate::robot::{self, Kind, Robot};

/// State layout (agent/sph/particle.py): position, velocity, the lagged rho/p/stress, frozen flag, a robot's
/// heading and forward speed (robot.rs).
pub const X: usize = 0;
pub const Y: usize = 1;
pub const VX: usize = 2;
pub const VY: usize = 3;
pub const RHO: usize = 4;
pub const P: usize = 5;
pub const SXX: usize = 6;
pub const SXY: usize = 7;
pub const SYY: usize = 8;
pub const FROZEN: usize = 9;
pub const HEADING: usize = 10;
pub const SPEED: usize = 11;
pub const NFIELDS: usize = 12;

pub type State = [f64; NFIELDS];

/// SPH parameters (agent/sph/params.py: units, thesis defaults and validation live there; the launcher
/// hands the validated values over in the agent spec).
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    pub h: f64,
    pub mass: f64,
    pub rho0: f64,
    pub gamma: f64,
    pub beta: f64,
    pub beta_pi: f64,
    pub mu: f64,
    pub kappa: f64,
    pub dt: f64,
    pub v_max: f64,
    pub drag: f64,
    pub domain: [f64; 4],
    /// true: 'reflect'; false: 'freeze' (thesis §4.7)
    pub reflect: bool,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            h: 1.0,
            mass: 1.0,
            rho0: 0.85,
            gamma: 7.0,
            beta: 2.0,
            beta_pi: 1.0,
            mu: 0.0,
            kappa: 2.0,
            dt: 0.01,
            v_max: 5.0,
            drag: 0.0,
            domain: [0.0, 60.0, 0.0, 30.0],
            reflect: false,
        }
    }
}

impl Params {
    pub fn support(&self) -> f64 {
        self.kappa * self.h
    }
    pub fn max_step_displacement(&self) -> f64 {
        self.v_max * self.dt
    }
}

/// What the controller sets for one particle at one step (agent/sph/particle.py: Control).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Control {
    pub wx: f64,
    pub wy: f64,
    pub r: f64,
    pub s: f64,
    pub alpha: f64,
    pub beta: f64,
    pub mu: f64,
    pub push_x: f64,
    pub push_y: f64,
}

impl Default for Control {
    fn default() -> Self {
        Control { wx: 0.0, wy: 0.0, r: 0.0, s: 0.0, alpha: 0.0, beta: 2.0, mu: 0.0, push_x: 0.0, push_y: 0.0 }
    }
}

pub fn initial_state(x: f64, y: f64, vx: f64, vy: f64, params: &Params, robot: &Robot) -> State {
    let mut s = [0.0; NFIELDS];
    s[X] = x;
    s[Y] = y;
    s[VX] = vx;
    s[VY] = vy;
    s[RHO] = params.rho0;
    (s[HEADING], s[SPEED]) = robot::initial_pose(vx, vy, robot);
    s
}

/// Gaussian kernel W(r) of eq. 3.3 (kernel.py: gaussian_kernel).
#[inline]
fn kernel(r: f64, h: f64, kappa: f64) -> f64 {
    let rr = r / h;
    let r2 = rr * rr;
    if r2 <= kappa * kappa {
        (-r2).exp() / (PI * h * h)
    } else {
        0.0
    }
}

/// Neighbour rows that interact with `own`: within the support and not frozen (particle.py: interacting).
pub fn interacting<'a>(own: &State, neighbours: &'a [State], params: &Params) -> impl Iterator<Item = &'a State> {
    let (x, y) = (own[X], own[Y]);
    let support = params.support();
    let s2 = support * support;
    neighbours.iter().filter(move |n| {
        let dx = x - n[X];
        let dy = y - n[Y];
        dx * dx + dy * dy <= s2 && n[FROZEN] == 0.0
    })
}

/// Body force of eq. 3.14 / 6.2 per unit mass towards a waypoint (equations.py: body_force).
fn body_force(x: f64, y: f64, c: &Control) -> (f64, f64) {
    let ex = c.wx - x;
    let ey = c.wy - y;
    let d = ex.hypot(ey);
    let magnitude = if d < c.r {
        0.0
    } else if d <= c.r + c.s {
        c.alpha * (d - c.r)
    } else {
        c.alpha * c.s
    };
    let safe = if d > 0.0 { d } else { 1.0 };
    (magnitude * ex / safe, magnitude * ey / safe)
}

/// Next state of one particle (particle.py: step_particle). `neighbours` sorted by id, self excluded; a
/// robot takes the SPH velocity update as its desired velocity (robot.rs); `obstacles` push its body away
/// (obstacle.rs; an empty list costs one length check).
pub fn step_particle(
    own: &State,
    neighbours: &[State],
    control: &Control,
    params: &Params,
    robot: &Robot,
    obstacles: &[Obstacle],
) -> State {
    if own[FROZEN] != 0.0 {
        return *own;
    }
    let h = params.h;
    let m = params.mass;
    let kappa = params.kappa;
    let k2 = kappa * kappa;
    let h2 = h * h;
    let grad_c = -2.0 / (PI * h.powf(4.0)); // Python: math.pi * h ** 4 (C pow)
    let (mut ax, mut ay) = (0.0f64, 0.0f64);
    let mut rho = m * kernel(0.0, h, kappa);
    let (mut exx, mut exy, mut eyy) = (0.0f64, 0.0f64, 0.0f64);
    let rho_i = own[RHO];
    let p_i = own[P];
    let eps2 = (0.1 * h) * (0.1 * h);
    for nb in interacting(own, neighbours, params) {
        let dx = own[X] - nb[X];
        let dy = own[Y] - nb[Y];
        let dvx = own[VX] - nb[VX];
        let dvy = own[VY] - nb[VY];
        // kernel_gradient (eq. 3.3 differentiated)
        let r2 = (dx * dx + dy * dy) / h2;
        let factor = if r2 <= k2 { grad_c * (-r2).exp() } else { 0.0 };
        let dwdx = factor * dx;
        let dwdy = factor * dy;
        // artificial_viscosity (eq. 3.9-3.10)
        let vdotx = dvx * dx + dvy * dy;
        let phi = h * vdotx / (dx * dx + dy * dy + eps2);
        let rho_bar = 0.5 * (rho_i + nb[RHO]);
        let pi_ij = if vdotx < 0.0 { params.beta_pi * phi * phi / rho_bar } else { 0.0 };
        // momentum_terms (eq. 3.7-3.8)
        let rr = rho_i * nb[RHO];
        let pres = (p_i + nb[P]) / rr + pi_ij;
        ax += m * (-pres * dwdx + ((own[SXX] + nb[SXX]) * dwdx + (own[SXY] + nb[SXY]) * dwdy) / rr);
        ay += m * (-pres * dwdy + ((own[SXY] + nb[SXY]) * dwdx + (own[SYY] + nb[SYY]) * dwdy) / rr);
        // density_terms (eq. 3.5) at r = hypot(dx, dy)
        rho += m * kernel(dx.hypot(dy), h, kappa);
        // stress_rate_terms (eq. 3.11) with u_ji = -dvx, v_ji = -dvy
        let w = m / nb[RHO];
        let (du, dv) = (-dvx, -dvy);
        exx += (2.0 / 3.0) * w * (2.0 * du * dwdx - dv * dwdy);
        exy += w * (dv * dwdx + du * dwdy);
        eyy += (2.0 / 3.0) * w * (2.0 * dv * dwdy - du * dwdx);
    }
    let (fx, fy) = body_force(own[X], own[Y], control);
    let mut acc_x = ax + fx + control.push_x - params.drag * own[VX];
    let mut acc_y = ay + fy + control.push_y - params.drag * own[VY];
    if robot.kind != Kind::Point {
        // robots keep their bodies apart (robot.py: contact_acceleration), summed in neighbour order
        let (cx, cy) = robot::body_centre(own[X], own[Y], own[HEADING], robot);
        let r0 = robot::contact_onset(robot, params.h);
        let strength = robot.v_max * robot.v_max;
        let (mut tx, mut ty) = (0.0f64, 0.0f64);
        for nb in interacting(own, neighbours, params) {
            let (nx, ny) = robot::body_centre(nb[X], nb[Y], nb[HEADING], robot);
            let (px, py) = robot::contact_term(cx - nx, cy - ny, r0, strength);
            tx += px;
            ty += py;
        }
        acc_x += tx;
        acc_y += ty;
    }
    if !obstacles.is_empty() {
        let (ox, oy) = obstacle_push(own, obstacles, params, robot);
        acc_x += ox;
        acc_y += oy;
    }

    let mut new = *own;
    new[VX] = own[VX] + params.dt * acc_x;
    new[VY] = own[VY] + params.dt * acc_y;
    if robot.kind == Kind::Unicycle {
        let moved = robot::unicycle_step(own[X], own[Y], own[HEADING], own[SPEED], new[VX], new[VY], robot, params.dt);
        for (k, v) in [X, Y, VX, VY, HEADING, SPEED].into_iter().zip(moved) {
            new[k] = v;
        }
    } else {
        if robot.kind == Kind::Holonomic {
            (new[VX], new[VY]) = robot::holonomic_velocity(own[VX], own[VY], new[VX], new[VY], robot, params.dt);
        }
        cap_speed(&mut new, params);
        new[X] = own[X] + params.dt * new[VX];
        new[Y] = own[Y] + params.dt * new[VY];
    }
    apply_border(&mut new, params);

    new[RHO] = rho;
    // tait_pressure (eq. 3.13)
    new[P] = control.beta * ((rho / params.rho0).powf(params.gamma) - 1.0);
    new[SXX] = control.mu * exx;
    new[SXY] = control.mu * exy;
    new[SYY] = control.mu * eyy;
    if new[FROZEN] != 0.0 {
        for k in [VX, VY, P, SXX, SXY, SYY, SPEED] {
            new[k] = 0.0;
        }
    }
    new
}

/// The obstacles' boundary force on the body of `own` (particle.py: obstacle_push): from its body centre,
/// beginning OBSTACLE_MARGIN h plus a robot's braking distance beyond its radius, of strength v_max^2 (the robot's; the fluid's for a point),
/// from the edges within the kernel support.
fn obstacle_push(own: &State, obstacles: &[Obstacle], params: &Params, robot: &Robot) -> (f64, f64) {
    let (mut cx, mut cy) = (own[X], own[Y]);
    if robot.kind == Kind::Unicycle {
        let heading = own[HEADING];
        (cx, cy) = (cx - robot.offset * heading.cos(), cy - robot.offset * heading.sin());
    }
    let top = if robot.kind == Kind::Point { params.v_max } else { robot.v_max };
    // a robot's drive brakes at a_max: the force begins its braking distance earlier (a point stops at once)
    let r0 = robot.radius + obstacle::OBSTACLE_MARGIN * params.h + robot::braking_distance(robot);
    obstacle::obstacle_acceleration(cx, cy, obstacles, r0, top * top, params.support())
}

fn cap_speed(s: &mut State, params: &Params) {
    let speed = s[VX].hypot(s[VY]);
    if speed > params.v_max {
        let scale = params.v_max / speed;
        s[VX] *= scale;
        s[VY] *= scale;
    }
}

fn apply_border(s: &mut State, params: &Params) {
    let [xmin, xmax, ymin, ymax] = params.domain;
    if !params.reflect {
        if s[X] < xmin || s[X] > xmax || s[Y] < ymin || s[Y] > ymax {
            s[FROZEN] = 1.0;
        }
        return;
    }
    for (pos, vel, lo, hi) in [(X, VX, xmin, xmax), (Y, VY, ymin, ymax)] {
        let p = s[pos];
        if p < lo {
            s[pos] = 2.0 * lo - p;
            s[vel] = -s[vel];
        } else if p > hi {
            s[pos] = 2.0 * hi - p;
            s[vel] = -s[vel];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lone_particle_moves_ballistically() {
        let p = Params::default();
        let own = initial_state(10.0, 10.0, 1.0, 0.0, &p, &Robot::default());
        let next = step_particle(&own, &[], &Control::default(), &p, &Robot::default(), &[]);
        assert_eq!(next[X], 10.0 + 0.01 * 1.0);
        assert_eq!(next[RHO], 1.0 / PI);
    }

    #[test]
    fn pair_forces_are_antisymmetric() {
        let p = Params::default();
        let pt = Robot::default();
        let a = initial_state(10.0, 10.0, 0.5, 0.0, &p, &pt);
        let b = initial_state(10.8, 10.3, -0.2, 0.1, &p, &pt);
        let na = step_particle(&a, &[b], &Control::default(), &p, &pt, &[]);
        let nb = step_particle(&b, &[a], &Control::default(), &p, &pt, &[]);
        let momentum = (na[VX] - a[VX]) + (nb[VX] - b[VX]);
        assert!(momentum.abs() < 1e-15);
    }
}
