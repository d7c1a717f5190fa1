//! Robots as fluid particles: a port of agent/sph/robot.py (the models, the tracking law, their sources and
//! defaults are documented there and in docs/robots.md). Pure functions, evaluated in the Python order.

use std::f64::consts::PI;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    Point,
    Holonomic,
    Unicycle,
}

/// A particle's body and drive (robot.py: RobotModel); defaults are the e-puck scaled to the domain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Robot {
    pub kind: Kind,
    pub radius: f64,
    pub v_max: f64,
    pub a_max: f64,
    pub omega_max: f64,
    pub offset: f64,
}

impl Default for Robot {
    fn default() -> Self {
        Robot { kind: Kind::Point, radius: 0.25, v_max: 0.86, a_max: 1.7, omega_max: 4.9, offset: 0.1 }
    }
}

impl Robot {
    /// Fastest the tracked point can move [m/s] (robot.py: top_particle_speed).
    pub fn top_particle_speed(&self) -> f64 {
        match self.kind {
            Kind::Unicycle => self.v_max + self.offset * self.omega_max,
            _ => self.v_max,
        }
    }
}

/// x h: how far beyond contact, besides the braking distance, the bodies' repulsion begins (robot.py:
/// CONTACT_MARGIN).
pub const CONTACT_MARGIN: f64 = 0.125;

/// v_max^2 / (2 a_max), how far a robot at top speed rolls while it brakes; 0 for a point, which stops at once
/// (robot.py: braking_distance). Where the boundary forces begin, the bodies' and the obstacles'.
pub fn braking_distance(robot: &Robot) -> f64 {
    if robot.kind == Kind::Point {
        0.0
    } else {
        robot.v_max * robot.v_max / (2.0 * robot.a_max)
    }
}

/// r0 of the bodies' repulsion (robot.py: contact_onset): bodies touch at 2 radius and a robot needs its
/// braking distance to stop, so the force begins CONTACT_MARGIN h plus that distance before contact (with
/// 0.125 m before contact, less than the e-puck's 0.22 m braking distance, 60 unicycles of the obstacle
/// course touched 4 times).
pub fn contact_onset(robot: &Robot, h: f64) -> f64 {
    2.0 * robot.radius + CONTACT_MARGIN * h + braking_distance(robot)
}

/// The body's centre of a state's particle (robot.py: body_centres): a unicycle's axle centre P - l e(theta).
pub fn body_centre(x: f64, y: f64, heading: f64, robot: &Robot) -> (f64, f64) {
    match robot.kind {
        Kind::Unicycle => (x - robot.offset * heading.cos(), y - robot.offset * heading.sin()),
        _ => (x, y),
    }
}

/// One pair's acceleration of Monaghan's (1994) repulsive Lennard-Jones force between bodies whose centres
/// are (dx, dy) apart (robot.py: contact_terms).
pub fn contact_term(dx: f64, dy: f64, r0: f64, strength: f64) -> (f64, f64) {
    let d2 = dx * dx + dy * dy;
    if !(d2 < r0 * r0 && d2 > 0.0) {
        return (0.0, 0.0);
    }
    let q = r0 / d2.sqrt();
    let mag = strength * (q.powf(12.0) - q.powf(4.0)) / d2;
    (mag * dx, mag * dy)
}

/// theta in (-pi, pi] for |theta| < 3 pi (robot.py: wrap_angle).
pub fn wrap_angle(theta: f64) -> f64 {
    if theta > PI {
        theta - 2.0 * PI
    } else if theta <= -PI {
        theta + 2.0 * PI
    } else {
        theta
    }
}

fn clip(value: f64, lo: f64, hi: f64) -> f64 {
    if value < lo {
        lo
    } else if value > hi {
        hi
    } else {
        value
    }
}

/// (heading, forward speed) at step 0 (robot.py: initial_pose).
pub fn initial_pose(vx: f64, vy: f64, robot: &Robot) -> (f64, f64) {
    if robot.kind != Kind::Unicycle {
        return (0.0, 0.0);
    }
    let speed = vx.hypot(vy);
    (if speed > 0.0 { vy.atan2(vx) } else { 0.0 }, speed)
}

/// v' = v + clip(u - v, a_max dt), then |v'| <= v_max (robot.py: holonomic_velocity).
pub fn holonomic_velocity(vx: f64, vy: f64, ux: f64, uy: f64, robot: &Robot, dt: f64) -> (f64, f64) {
    let (mut dvx, mut dvy) = (ux - vx, uy - vy);
    let dv = dvx.hypot(dvy);
    let most = robot.a_max * dt;
    if dv > most {
        dvx *= most / dv;
        dvy *= most / dv;
    }
    let (mut nvx, mut nvy) = (vx + dvx, vy + dvy);
    let speed = nvx.hypot(nvy);
    if speed > robot.v_max {
        nvx *= robot.v_max / speed;
        nvy *= robot.v_max / speed;
    }
    (nvx, nvy)
}

/// (s, w) that give the point `offset` ahead of the axle the velocity (ux, uy) (robot.py: offset_tracking;
/// Lawton, Beard & Young, IEEE T-RA 2003, eq. 4).
pub fn offset_tracking(ux: f64, uy: f64, heading: f64, offset: f64) -> (f64, f64) {
    let (c, s) = (heading.cos(), heading.sin());
    (ux * c + uy * s, (-ux * s + uy * c) / offset)
}

/// (x', y', vx', vy', heading', speed') of a unicycle (robot.py: unicycle_step).
#[allow(clippy::too_many_arguments)]
pub fn unicycle_step(x: f64, y: f64, heading: f64, speed: f64, ux: f64, uy: f64, robot: &Robot, dt: f64) -> [f64; 6] {
    let (s_cmd, w_cmd) = offset_tracking(ux, uy, heading, robot.offset);
    let most = robot.a_max * dt;
    let s_new = clip(clip(s_cmd, speed - most, speed + most), -robot.v_max, robot.v_max);
    let w = clip(w_cmd, -robot.omega_max, robot.omega_max);
    let h_new = wrap_angle(heading + dt * w);
    let l = robot.offset;
    let reach = dt * s_new + l;
    let nx = x - l * heading.cos() + reach * h_new.cos();
    let ny = y - l * heading.sin() + reach * h_new.sin();
    [nx, ny, (nx - x) / dt, (ny - y) / dt, h_new, s_new]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unicycle() -> Robot {
        Robot { kind: Kind::Unicycle, ..Robot::default() }
    }

    #[test]
    fn an_unsaturated_unicycle_tracks_the_desired_velocity_exactly() {
        // heading 0, already moving at 0.3 m/s: a small sideways request is met by the offset point
        let r = unicycle();
        let out = unicycle_step(1.0, 2.0, 0.0, 0.3, 0.3, 0.02, &r, 0.01);
        let (vx, vy) = (out[2], out[3]);
        assert!((vx - 0.3).abs() < 2e-3 && (vy - 0.02).abs() < 2e-3, "{vx} {vy}");
    }

    #[test]
    fn limits_hold() {
        let r = unicycle();
        let out = unicycle_step(0.0, 0.0, 0.0, 0.0, 100.0, 100.0, &r, 0.01);
        assert!((out[5] - r.a_max * 0.01).abs() < 1e-15); // acceleration limited
        assert!((out[4] - r.omega_max * 0.01).abs() < 1e-15); // turn rate limited
        let (vx, vy) = holonomic_velocity(0.0, 0.0, 100.0, 0.0, &Robot { kind: Kind::Holonomic, ..r }, 0.01);
        assert!((vx - r.a_max * 0.01).abs() < 1e-15 && vy == 0.0);
    }

    #[test]
    fn wraps() {
        assert_eq!(wrap_angle(PI + 0.5), PI + 0.5 - 2.0 * PI);
        assert_eq!(wrap_angle(-PI), PI);
        assert_eq!(wrap_angle(1.0), 1.0);
    }
}
