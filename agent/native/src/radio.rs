//! The imperfect radio and localisation (docs/robots.md, "The imperfect radio"): a port of agent/sph/radio.py.
//!
//! Every decision is a function of the run's seed, ids and a step, never of arrival order, so a swarm of agents
//! and the reference driver draw the same numbers: a counter-based generator (splitmix64's finaliser chained over
//! (seed, stream, a, b, step); Steele, Lea & Flood, *Fast splittable pseudorandom number generators*, OOPSLA 2014).
//! - loss: receiver i does not use sender j's state of step s when u(seed, LOSS, i, j, s) < loss;
//! - noise: j's localisation reports its position of step s off by sigma (gx, gy), a Box-Muller pair of
//!   u(seed, NOISE_R, j, 0, s) and u(seed, NOISE_A, j, 0, s): the same error for every receiver;
//! - latency: at step t a receiver uses j's state of step t - latency (the oldest it holds of t - latency .. t).

use std::f64::consts::PI;

/// The subscription radius R_sub = 2h + 10 v_max dt covers where a neighbour k steps back can have published
/// (2k v_max dt of relative motion, one step of it before the cells are updated): k <= 4 (docs/protocol.md).
pub const MAX_LATENCY: u32 = 4;

const LOSS: u64 = 1;
const NOISE_R: u64 = 2;
const NOISE_A: u64 = 3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Radio {
    /// probability that a state is lost to a receiver, [0, 1)
    pub loss: f64,
    /// steps a state takes to be used, 0..=MAX_LATENCY
    pub latency: u32,
    /// sigma [m] of each coordinate of a neighbour's reported position
    pub noise: f64,
    pub seed: u64,
}

impl Default for Radio {
    fn default() -> Self {
        Radio { loss: 0.0, latency: 0, noise: 0.0, seed: 0 }
    }
}

/// splitmix64's step and finaliser.
fn mix(z: u64) -> u64 {
    let mut z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A uniform number in [0, 1) for (seed, stream, a, b, step) (radio.py: uniform).
pub fn uniform(seed: u64, stream: u64, a: u64, b: u64, step: u64) -> f64 {
    let mut z = mix(seed);
    for v in [stream, a, b, step] {
        z = mix(z ^ v);
    }
    (z >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

impl Radio {
    pub fn is_perfect(&self) -> bool {
        self.loss == 0.0 && self.latency == 0 && self.noise == 0.0
    }

    /// Whether `receiver` does not use `sender`'s state of `step` (radio.py: lost).
    pub fn lost(&self, receiver: u32, sender: u32, step: u32) -> bool {
        self.loss > 0.0 && uniform(self.seed, LOSS, receiver as u64, sender as u64, step as u64) < self.loss
    }

    /// The error (dx, dy) [m] of `sender`'s reported position of `step` (radio.py: position_error).
    pub fn position_error(&self, sender: u32, step: u32) -> (f64, f64) {
        if self.noise == 0.0 {
            return (0.0, 0.0);
        }
        let u1 = 1.0 - uniform(self.seed, NOISE_R, sender as u64, 0, step as u64); // (0, 1]: ln is finite
        let u2 = uniform(self.seed, NOISE_A, sender as u64, 0, step as u64);
        let r = self.noise * (-2.0 * u1.ln()).sqrt();
        let a = 2.0 * PI * u2;
        (r * a.cos(), r * a.sin())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniforms_are_in_range_and_depend_on_every_counter() {
        let base = uniform(7, 1, 2, 3, 4);
        assert!((0.0..1.0).contains(&base));
        for other in [uniform(8, 1, 2, 3, 4), uniform(7, 2, 2, 3, 4), uniform(7, 1, 3, 3, 4), uniform(7, 1, 2, 4, 4)] {
            assert_ne!(base, other);
        }
        assert_ne!(base, uniform(7, 1, 2, 3, 5));
    }

    #[test]
    fn the_loss_rate_is_the_probability() {
        let r = Radio { loss: 0.1, seed: 3, ..Radio::default() };
        let lost = (0..20_000u32).filter(|&s| r.lost(1, 2, s)).count();
        assert!((1800..2200).contains(&lost), "{lost}");
    }
}
