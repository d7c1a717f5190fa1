//! The fill law (agent/fill.py) and the command's crossing check (agent/protocol/command.py `edges_cross`).
//!
//! The coordinator broadcasts the observed silhouette as a few rings (polygons, metres, closed implicitly);
//! each agent decides its body force from its own position only: inside the shape (even-odd rule over all
//! rings, so a ring inside another is a hole) no force, outside a pull towards the nearest boundary point.
//!
//! Written operation for operation like the Python (same evaluation order, no fused multiply-add, Python's
//! `min`/`max` semantics), so a native swarm equals the reference drivers to rounding; the shared vectors
//! tests/vectors/fill.json check both.

/// A ring of (x, y) vertices [m], closed implicitly (the last vertex joins the first).
pub type Ring = Vec<(f64, f64)>;

/// A material zone of the shape (agent/protocol/command.py `Zone`, sent in the command's `fill`): an ellipse
/// with centre (x, y) [m], unit major axis (ux, uy) and semi-axes a, b [m]; an agent inside it uses `beta`
/// and `mu`.
#[derive(Clone, Debug, PartialEq)]
pub struct Zone {
    pub x: f64,
    pub y: f64,
    pub ux: f64,
    pub uy: f64,
    pub a: f64,
    pub b: f64,
    pub beta: f64,
    pub mu: f64,
}

/// `inside`: the even-odd rule over every edge of every ring (a ring inside another ring is a hole).
pub fn inside(rings: &[Ring], x: f64, y: f64) -> bool {
    let mut odd = false;
    for ring in rings {
        let n = ring.len();
        for k in 0..n {
            let (x1, y1) = ring[k];
            let (x2, y2) = ring[(k + 1) % n];
            if (y1 > y) != (y2 > y) {
                // Python: x1 + (y - y1) * (x2 - x1) / (y2 - y1), left to right
                let xc = x1 + (y - y1) * (x2 - x1) / (y2 - y1);
                if x < xc {
                    odd = !odd;
                }
            }
        }
    }
    odd
}

/// `nearest_point`: the point of the rings' edges nearest to (x, y); the first one found on a tie
/// ((x, y) itself when there are no edges).
pub fn nearest_point(rings: &[Ring], x: f64, y: f64) -> (f64, f64) {
    let mut best = f64::INFINITY;
    let (mut bx, mut by) = (x, y);
    for ring in rings {
        let n = ring.len();
        for k in 0..n {
            let (x1, y1) = ring[k];
            let (x2, y2) = ring[(k + 1) % n];
            let (ex, ey) = (x2 - x1, y2 - y1);
            let ll = ex * ex + ey * ey;
            let mut t = 0.0;
            if ll > 0.0 {
                t = ((x - x1) * ex + (y - y1) * ey) / ll;
                t = py_min(1.0, py_max(0.0, t));
            }
            let (px, py) = (x1 + t * ex, y1 + t * ey);
            let d2 = (x - px) * (x - px) + (y - py) * (y - py);
            if d2 < best {
                best = d2;
                bx = px;
                by = py;
            }
        }
    }
    (bx, by)
}

/// Python's `max(a, b)`: b only if b > a (so max(0.0, -0.0) is 0.0 and max(0.0, nan) is 0.0).
fn py_max(a: f64, b: f64) -> f64 {
    if b > a {
        b
    } else {
        a
    }
}

/// Python's `min(a, b)`: b only if b < a.
fn py_min(a: f64, b: f64) -> f64 {
    if b < a {
        b
    } else {
        a
    }
}

/// `_side`: the sign of the turn a -> b -> c (+1 left, -1 right, 0 on the line).
fn side(ax: f64, ay: f64, bx: f64, by: f64, cx: f64, cy: f64) -> i32 {
    let cross = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
    i32::from(cross > 0.0) - i32::from(cross < 0.0)
}

/// `edges_cross`: do two edges of the rings cross properly (each one's ends strictly on both sides of
/// the other)? Touching (a shared vertex, a vertex on an edge, collinear overlap) is not crossing.
/// O(V^2) over all edges of all rings.
pub fn edges_cross(rings: &[Ring]) -> bool {
    let edges: Vec<(f64, f64, f64, f64)> = rings
        .iter()
        .flat_map(|ring| {
            let n = ring.len();
            (0..n).map(move |k| (ring[k].0, ring[k].1, ring[(k + 1) % n].0, ring[(k + 1) % n].1))
        })
        .collect();
    for (a, &(ax, ay, bx, by)) in edges.iter().enumerate() {
        for &(cx, cy, dx, dy) in &edges[a + 1..] {
            if side(ax, ay, bx, by, cx, cy) * side(ax, ay, bx, by, dx, dy) < 0
                && side(cx, cy, dx, dy, ax, ay) * side(cx, cy, dx, dy, bx, by) < 0
            {
                return true;
            }
        }
    }
    false
}

/// `zone_material`: (beta, mu) of the first zone (an ellipse) that holds (x, y); the given ones where none does.
pub fn zone_material(zones: &[Zone], x: f64, y: f64, beta: f64, mu: f64) -> (f64, f64) {
    for z in zones {
        let (dx, dy) = (x - z.x, y - z.y);
        let p = (dx * z.ux + dy * z.uy) / z.a;
        let q = (dy * z.ux - dx * z.uy) / z.b;
        if p * p + q * q <= 1.0 {
            return (z.beta, z.mu);
        }
    }
    (beta, mu)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(x0: f64, y0: f64, side: f64) -> Ring {
        vec![(x0, y0), (x0 + side, y0), (x0 + side, y0 + side), (x0, y0 + side)]
    }

    #[test]
    fn even_odd_with_a_hole() {
        let rings = vec![square(0.0, 0.0, 10.0), square(4.0, 4.0, 2.0)];
        assert!(inside(&rings, 1.0, 1.0));
        assert!(!inside(&rings, 5.0, 5.0)); // in the hole
        assert!(!inside(&rings, -1.0, 5.0));
        assert_eq!(nearest_point(&rings, 5.0, 4.5), (5.0, 4.0));
        assert_eq!(nearest_point(&rings, -3.0, 5.0), (0.0, 5.0));
        assert_eq!(nearest_point(&rings, 12.0, 13.0), (10.0, 10.0));
    }

    #[test]
    fn crossing() {
        let bow_tie = vec![vec![(0.0, 0.0), (1.0, 1.0), (1.0, 0.0), (0.0, 1.0)]];
        assert!(edges_cross(&bow_tie));
        assert!(!edges_cross(&[square(0.0, 0.0, 1.0)]));
        // touching at a vertex is not crossing
        assert!(!edges_cross(&[square(0.0, 0.0, 1.0), square(1.0, 1.0, 1.0)]));
        assert!(edges_cross(&[square(0.0, 0.0, 2.0), square(1.0, 1.0, 2.0)]));
    }
}
