//! The step loops: lockstep (paced by the launcher's clock, waiting for the expected set) and async (its own
//! rate, the neighbours heard within max_age); both advance the particle with `sph::step_particle`.

use std::time::{Duration, Instant};

use super::{Agent, Halt, CLOCK_LEAD};
use crate::event::EventKind;
use crate::sph::{self, State, X, Y};

impl Agent {
    fn advance(&mut self, neighbours: &[State]) {
        let control = match self.controller.as_mut() {
            Some(c) => c.control(&self.state),
            None => self.spec.control,
        };
        self.counters.neighbours += sph::interacting(&self.state, neighbours, &self.params).count() as u64;
        self.state = sph::step_particle(&self.state, neighbours, &control, &self.params, &self.spec.robot);
        self.step += 1;
        self.last_step_done = Instant::now();
        if let Err(e) = self.update_subscriptions() {
            eprintln!("fluidswarm agent {}: subscription failed: {e}", self.spec.id);
        }
    }

    pub(super) fn run_lockstep(&mut self) -> Result<(), Halt> {
        let mut rows: Vec<State> = Vec::with_capacity(32);
        while self.step < self.last_step() {
            if self.behind {
                self.rejoin()?; // resumed after a freeze: adopt the swarm's step (lifecycle.rs)
                continue;
            }
            // An isolated particle must not run ahead of the swarm (the launcher's clock).
            if self.clock.is_some_and(|c| self.step as u64 > c + CLOCK_LEAD) {
                self.shared.inbox.lock().unwrap_or_else(|e| e.into_inner()).wake_on_clock = true;
                while self.clock.is_some_and(|c| self.step as u64 > c + CLOCK_LEAD) && !self.behind {
                    self.drain(0.05)?;
                }
                self.shared.inbox.lock().unwrap_or_else(|e| e.into_inner()).wake_on_clock = false;
                if self.behind {
                    continue;
                }
            }
            self.publish();
            let expected = self.expected();
            self.wait_for(&expected)?;
            self.drain(0.0)?;
            if self.behind {
                continue;
            }
            rows.clear();
            if let Some(current) = self.buffer.remove(&self.step) {
                rows.extend(current.into_values()); // BTreeMap: sorted by id, as the reference driver
            }
            // Drop what is older than the current step (late duplicates would pile up otherwise).
            let step = self.step;
            self.buffer.retain(|&s, _| s > step);
            self.advance(&rows);
        }
        Ok(())
    }

    /// Async mode: the latest state of every neighbour heard within max_age; older ones are forgotten.
    fn fresh_neighbours(&mut self, now: Instant) -> Vec<State> {
        let max_age = Duration::from_secs_f64(self.spec.max_age);
        let support2 = self.params.support() * self.params.support();
        let mut rows = Vec::new();
        let mut expired = Vec::new();
        let mut ids: Vec<u32> = self.fresh.keys().copied().collect();
        ids.sort_unstable();
        for j in ids {
            let (t, values) = self.fresh[&j];
            if now.saturating_duration_since(t) <= max_age {
                rows.push(values);
                continue;
            }
            self.fresh.remove(&j);
            let dx = values[X] - self.state[X];
            let dy = values[Y] - self.state[Y];
            // Within the support when last heard: it went silent rather than moved away.
            if dx * dx + dy * dy <= support2 {
                expired.push(j);
            }
        }
        if !expired.is_empty() {
            self.counters.timeouts += expired.len() as u64;
            self.event(EventKind::NeighbourTimeout { neighbours: expired, last_seen: None });
        }
        rows
    }

    pub(super) fn run_async(&mut self) -> Result<(), Halt> {
        let period = Duration::from_secs_f64(1.0 / self.spec.rate);
        let max_age = Duration::from_secs_f64(self.spec.max_age);
        let mut due = Instant::now();
        while self.step < self.last_step() {
            self.publish();
            self.drain(0.0)?;
            let now = Instant::now();
            let rows = self.fresh_neighbours(now);
            self.advance(&rows);
            due += period;
            if now.saturating_duration_since(due) > max_age {
                due = now; // after a freeze: carry on at the rate instead of racing through missed steps
            }
            loop {
                let left = due.saturating_duration_since(Instant::now());
                if left.is_zero() {
                    break;
                }
                self.drain(left.as_secs_f64())?;
            }
        }
        Ok(())
    }
}
