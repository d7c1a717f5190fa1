//! Static obstacles and their SPH boundary force: a port of agent/sph/obstacles.py (Monaghan's 1994 repulsive
//! boundary force from the nearest point of each obstacle edge; its source, constants and sensing range are
//! documented there and in docs/robots.md). Pure functions, evaluated in the Python order.

/// A disc (centre, radius) or a simple polygon (vertices, closed implicitly), metres.
#[derive(Clone, Debug, PartialEq)]
pub enum Obstacle {
    Circle { x: f64, y: f64, radius: f64 },
    Polygon(Vec<(f64, f64)>),
}

/// x h: how far beyond a body's edge the boundary force begins (obstacles.py: OBSTACLE_MARGIN).
pub const OBSTACLE_MARGIN: f64 = 0.125;
/// Most vertices of one polygon (obstacles.py: MAX_VERTICES).
pub const MAX_VERTICES: usize = 256;

/// (x, y) minus the point of the segment (x1, y1)-(x2, y2) nearest to it (obstacles.py: edge_offset).
#[inline]
pub fn edge_offset(x: f64, y: f64, x1: f64, y1: f64, x2: f64, y2: f64) -> (f64, f64) {
    let (ex, ey) = (x2 - x1, y2 - y1);
    let ll = ex * ex + ey * ey;
    let mut t = 0.0;
    if ll > 0.0 {
        t = (((x - x1) * ex + (y - y1) * ey) / ll).clamp(0.0, 1.0);
    }
    (x - (x1 + t * ex), y - (y1 + t * ey))
}

/// (x, y) minus the circle's point nearest to it; (0, 0) at the centre (obstacles.py: circle_offset).
#[inline]
fn circle_offset(x: f64, y: f64, cx: f64, cy: f64, radius: f64) -> (f64, f64) {
    let (dx, dy) = (x - cx, y - cy);
    let dc = (dx * dx + dy * dy).sqrt();
    if dc <= 0.0 {
        return (0.0, 0.0);
    }
    let k = (dc - radius) / dc;
    (dx * k, dy * k)
}

/// Monaghan's repulsive boundary force per unit mass from one edge's nearest point (obstacles.py:
/// boundary_term): D ((r0/d)^12 - (r0/d)^4) (dx, dy) / d^2 for d < r0 within the sensing range.
#[inline]
pub fn boundary_term(dx: f64, dy: f64, r0: f64, strength: f64, sensing: f64) -> (f64, f64) {
    let d2 = dx * dx + dy * dy;
    if !(d2 < r0 * r0 && d2 <= sensing * sensing && d2 > 0.0) {
        return (0.0, 0.0);
    }
    let q = r0 / d2.sqrt();
    let mag = strength * (q.powf(12.0) - q.powf(4.0)) / d2;
    (mag * dx, mag * dy)
}

/// The sum of `boundary_term` over every edge of every obstacle, in order, on the body centred at (cx, cy)
/// (obstacles.py: obstacle_acceleration).
pub fn obstacle_acceleration(
    cx: f64,
    cy: f64,
    obstacles: &[Obstacle],
    r0: f64,
    strength: f64,
    sensing: f64,
) -> (f64, f64) {
    let (mut ax, mut ay) = (0.0f64, 0.0f64);
    for o in obstacles {
        match o {
            Obstacle::Circle { x, y, radius } => {
                let (dx, dy) = circle_offset(cx, cy, *x, *y, *radius);
                let (tx, ty) = boundary_term(dx, dy, r0, strength, sensing);
                ax += tx;
                ay += ty;
            }
            Obstacle::Polygon(v) => {
                let n = v.len();
                for k in 0..n {
                    let (x1, y1) = v[k];
                    let (x2, y2) = v[(k + 1) % n];
                    let (dx, dy) = edge_offset(cx, cy, x1, y1, x2, y2);
                    let (tx, ty) = boundary_term(dx, dy, r0, strength, sensing);
                    ax += tx;
                    ay += ty;
                }
            }
        }
    }
    (ax, ay)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wall_pushes_along_its_normal_and_only_close_by() {
        let wall = [Obstacle::Polygon(vec![(0.0, 0.0), (10.0, 0.0), (10.0, 1.0), (0.0, 1.0)])];
        let (ax, ay) = obstacle_acceleration(5.0, 1.3, &wall, 0.375, 1.0, 2.0);
        assert_eq!(ax, 0.0);
        assert!(ay > 0.0, "pushed away from the top side: {ay}");
        assert_eq!(obstacle_acceleration(5.0, 1.4, &wall, 0.375, 1.0, 2.0), (0.0, 0.0)); // beyond r0
                                                                                         // r0 beyond the sensing range: an edge out of range is not felt
        assert_eq!(obstacle_acceleration(5.0, 3.5, &wall, 3.0, 1.0, 2.0), (0.0, 0.0));
        assert!(obstacle_acceleration(5.0, 2.5, &wall, 3.0, 1.0, 2.0).1 > 0.0);
    }

    #[test]
    fn a_circle_pushes_radially_and_grows_near_its_edge() {
        let c = [Obstacle::Circle { x: 0.0, y: 0.0, radius: 1.0 }];
        let near = obstacle_acceleration(0.0, -1.1, &c, 0.375, 1.0, 2.0);
        let far = obstacle_acceleration(0.0, -1.3, &c, 0.375, 1.0, 2.0);
        assert!(near.0.abs() < 1e-12 && near.1 < far.1 && far.1 < 0.0, "{near:?} {far:?}");
        assert_eq!(obstacle_acceleration(0.0, 0.0, &c, 0.375, 1.0, 2.0), (0.0, 0.0));
    }
}
