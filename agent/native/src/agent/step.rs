//! The steps: lockstep (paced by the launcher's clock, waiting for the expected set) and async (its own rate,
//! the neighbours heard within max_age); both advance the particle with `sph::step_particle`, put the state
//! and follow it with the cells they hear.

use std::collections::BTreeMap;

use super::{Action, AgentCore, Lock, Phase, Wake, SLICE};
use crate::event::EventKind;
use crate::final_report::Status;
use crate::keys;
use crate::sph::{self, State, X, Y};
use crate::wire;

impl AgentCore {
    fn advance(&mut self, neighbours: &[State], now: f64) {
        let control = match self.controller.as_mut() {
            Some(c) => c.control(&self.state),
            None => self.spec.control,
        };
        self.counters.neighbours += sph::interacting(&self.state, neighbours, &self.params).count() as u64;
        self.state =
            sph::step_particle(&self.state, neighbours, &control, &self.params, &self.spec.robot, &self.spec.obstacles);
        self.step += 1;
        self.last_step_done = now;
        self.update_cells();
    }

    /// Lockstep: the states of the step waited for (sorted by id, as the reference driver), the next state.
    pub(super) fn finish_step(&mut self, now: f64) {
        let current = self.buffer.remove(&self.step).unwrap_or_default();
        // Drop what is older than the current step (late duplicates would pile up otherwise).
        let step = self.step;
        self.buffer.retain(|&s, _| s > step);
        let rows: Vec<State> =
            if self.spec.radio.is_perfect() { current.into_values().collect() } else { self.radio_rows(current) };
        self.advance(&rows, now);
    }

    /// What the imperfect radio makes of the step's states (agent/sph/radio.py; the reference driver does the
    /// same): the neighbours are those the step-t states put within the support (lockstep guarantees them
    /// all), each as its state of step t - latency (the oldest held of t - latency .. t), unless that state is
    /// lost to this receiver, with its localisation's error on the position. Sorted by id.
    fn radio_rows(&mut self, current: BTreeMap<u32, State>) -> Vec<State> {
        let radio = self.spec.radio;
        let step = self.step;
        let oldest = step.saturating_sub(radio.latency);
        if radio.latency > 0 {
            self.history.entry(step).or_default().extend(current.iter().map(|(&j, s)| (j, *s)));
            self.history.retain(|&s, _| s >= oldest);
        }
        let mut rows = Vec::new();
        for (&j, now_state) in &current {
            if sph::interacting(&self.state, std::slice::from_ref(now_state), &self.params).next().is_none() {
                continue;
            }
            let (s, mut used) = self
                .history
                .range(oldest..step)
                .find_map(|(&s, states)| states.get(&j).map(|st| (s, *st)))
                .unwrap_or((step, *now_state));
            if radio.lost(self.spec.id, j, s) {
                continue;
            }
            let (ex, ey) = radio.position_error(j, s);
            used[X] += ex;
            used[Y] += ey;
            rows.push(used);
        }
        rows
    }

    fn paced(&self) -> bool {
        self.clock.is_some_and(|c| super::paced(u64::from(self.step), c))
    }

    pub(super) fn lockstep(&mut self, now: f64, lock: Lock) -> Option<Phase> {
        match lock {
            Lock::Top => {
                if self.step >= self.last_step() {
                    return self.finish(now, Status::Done);
                }
                if self.behind {
                    self.rejoin(now); // resumed after a freeze: adopt the swarm's step (lifecycle.rs)
                    return Some(Phase::Lockstep(Lock::Top));
                }
                // An isolated particle must not run ahead of the swarm (the launcher's clock).
                if self.paced() {
                    return Some(Phase::Lockstep(Lock::Paced));
                }
                Some(self.publish_and_wait(now))
            }
            Lock::Paced => {
                if self.paced() && !self.behind {
                    self.phase = Phase::Lockstep(Lock::Paced);
                    // The tick it waits for wakes it (the shell runs the core on it); the slice only bounds the
                    // sleep. A 50 ms slice here woke the shell's main thread about every other step of a
                    // paced swarm for nothing (the clock moves only by a tick).
                    self.sleep(now + SLICE, Wake { on_clock: true, ..Wake::default() });
                    return None;
                }
                if self.behind {
                    return Some(Phase::Lockstep(Lock::Top));
                }
                Some(self.publish_and_wait(now))
            }
            Lock::Waiting(w) => self.wait(now, w),
        }
    }

    fn publish_and_wait(&mut self, now: f64) -> Phase {
        self.publish();
        let expected = self.expected(now);
        Phase::Lockstep(Lock::Waiting(self.begin_wait(now, expected)))
    }

    /// Async mode: the latest state of every neighbour heard within max_age; older ones are forgotten.
    fn fresh_neighbours(&mut self, now: f64) -> Vec<State> {
        let max_age = self.spec.max_age;
        let support2 = self.params.support() * self.params.support();
        let mut rows = Vec::new();
        let mut expired = Vec::new();
        let mut ids: Vec<u32> = self.fresh.keys().copied().collect();
        ids.sort_unstable();
        for j in ids {
            let (t, values) = self.fresh[&j];
            if (now - t).max(0.0) <= max_age {
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

    /// Async mode: a step when it is due, then a sleep until the next is.
    pub(super) fn async_step(&mut self, now: f64, mut due: f64) -> Option<Phase> {
        if now < due {
            self.phase = Phase::Async { due };
            self.sleep(due, Wake::default());
            return None;
        }
        if self.step >= self.last_step() {
            return self.finish(now, Status::Done);
        }
        self.publish();
        let rows = self.fresh_neighbours(now);
        self.advance(&rows, now);
        due += 1.0 / self.spec.rate;
        if now - due > self.spec.max_age {
            due = now; // after a freeze: carry on at the rate instead of racing through missed steps
        }
        Some(Phase::Async { due })
    }

    pub(super) fn publish(&mut self) {
        if self.spec.drop_out > 0.0 && self.random() < self.spec.drop_out {
            self.counters.dropped_out += 1;
            return;
        }
        let class = self.controller.as_ref().map_or(0, |c| c.particle_class());
        let record = wire::encode_state(self.spec.id, self.step, &self.state, class);
        let cell = keys::cell_of(self.state[X], self.state[Y], self.cell);
        self.out.push(Action::Publish { cell, record });
    }

    /// The cells heard (docs/protocol.md, "Key expressions"): every cell within R_sub subscribed, those beyond
    /// R_keep dropped (hysteresis). After every step, before the next state goes out.
    pub(super) fn update_cells(&mut self) {
        let (x, y) = (self.state[X], self.state[Y]);
        let (keep, cell) = (self.r_keep, self.cell);
        // covering_cells' own test, without building the set on every step
        let gone: Vec<(i64, i64)> =
            self.cells.iter().filter(|c| keys::cell_distance2(x, y, **c, cell) > keep * keep).copied().collect();
        for c in gone {
            self.cells.remove(&c);
            self.out.push(Action::Unsubscribe(c));
        }
        for c in keys::covering_cells(x, y, self.r_sub, self.cell) {
            if self.cells.insert(c) {
                self.out.push(Action::Subscribe(c));
            }
        }
    }
}
