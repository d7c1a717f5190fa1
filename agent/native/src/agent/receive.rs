//! The receive path: what each input does to the agent's neighbour table (states, the launcher's ctl
//! messages with the liveliness it relays as ctl/gone, gesture commands, a stop).

use super::{AgentCore, Halt, Input, Phase, BEHIND_SENDERS, BEHIND_STEPS, MAX_AHEAD, REJOIN_WINDOW};
use crate::ctl::{self, Ctl};
use crate::event::EventKind;
use crate::keys;
use crate::spec::Mode;
use crate::sph::{X, Y};
use crate::wire;

impl AgentCore {
    pub(super) fn receive(&mut self, input: Input, now: f64) {
        match input {
            Input::State { record, on_key } => {
                if matches!(self.phase, Phase::Joining { .. }) {
                    self.join_on(&record, on_key);
                } else {
                    self.handle_state(&record, on_key, now);
                }
            }
            Input::Ctl { key, payload } => self.handle_ctl(&key, &payload),
            Input::Command(payload) => self.handle_command(&payload, now),
            Input::Stop => self.halt = Some(Halt::Stop),
        }
    }

    fn gone(&mut self, j: u32) {
        if j != self.spec.id && self.dead.insert(j) {
            self.latest.remove(&j);
            self.fresh.remove(&j);
            self.counters.deaths_seen += 1;
        }
    }

    fn handle_ctl(&mut self, key: &str, payload: &[u8]) {
        // Exact keys only: a put on a wildcard key (`fluidswarm/**`) reaches this subscriber too, and the
        // router's deny rules cannot name every wildcard (docs/security.md).
        let Some(msg) = ctl::decode(keys::ctl_what(&self.spec.run, key), payload) else {
            self.reject("ctl");
            return;
        };
        match msg {
            Ctl::Start => {
                self.started = true;
                // Paced from the first step: until the launcher's first tick (it ticks once it has seen
                // states) an agent with few expected neighbours would race CLOCK_LEAD+ steps ahead and make
                // its slower neighbours conclude they fell behind.
                self.clock.get_or_insert(0);
            }
            Ctl::Stop => self.halt = Some(Halt::Stop),
            Ctl::Clock(step) => self.clock = Some(step),
            // The launcher relays an agent's lost liveliness (docs/protocol.md: ctl/gone): one subscriber per
            // agent on every other agent's token was O(N²) messages at start-up.
            Ctl::Gone(j) => self.gone(j),
            Ctl::End(step) => self.end = Some(step),
        }
    }

    fn handle_command(&mut self, payload: &[u8], now: f64) {
        let unix = self.unix(now);
        let Some(ctl) = self.controller.as_mut() else { return };
        let first = !ctl.has_command();
        match ctl.offer(payload, unix) {
            Some(reason) => *self.counters.rejected.entry(format!("command_{reason}")).or_insert(0) += 1,
            None => {
                if first && ctl.has_command() {
                    let since = now - self.opened_at;
                    self.event(EventKind::CommandReceived { seconds_since_session_open: since });
                }
            }
        }
    }

    pub(super) fn handle_state(&mut self, data: &[u8], on_key: bool, now: f64) {
        let rec = match wire::decode_state(data) {
            Ok(r) => r,
            Err(reason) => return self.reject(reason),
        };
        // Only an exact cell key vouches for a record: at access level `acl` only the launcher's relay may put
        // there, after checking the record's id against its sender's key (docs/security.md).
        if !on_key {
            return self.reject("key");
        }
        let (j, step, values) = (rec.id, rec.step, rec.values);
        if j == self.spec.id {
            return;
        }
        if self.dead.contains(&j) {
            // A state it published while alive is genuine: an agent that finished (or died) just after
            // publishing its last steps has its liveliness DELETE delivered first (declarations travel at a
            // higher priority than data), and neighbours still a few steps behind need those states to stay
            // exact. It is used for its step, but the dead agent is never expected again.
            if step >= self.step && self.spec.mode == Mode::Lockstep {
                self.buffer.entry(step).or_default().insert(j, values);
            } else {
                self.reject("dead");
            }
            return;
        }
        if step as u64 > self.step as u64 + MAX_AHEAD as u64 {
            return self.reject("step");
        }
        self.counters.msgs_received += 1;
        let newer = self.latest.get(&j).is_none_or(|last| step as i64 >= last.0);
        if newer {
            self.latest.insert(j, (step as i64, values[X], values[Y]));
            self.heard_at.insert(j, now);
            if self.spec.mode == Mode::Async {
                self.fresh.insert(j, (now, values));
            }
        }
        if self.spec.mode == Mode::Async {
            return;
        }
        if step < self.step {
            self.counters.stale += 1;
            // A radio with latency k uses states up to k steps old: one that came after its step was done
            // (a neighbour not expected then) is kept for that (step.rs, `radio_rows`).
            let k = self.spec.radio.latency;
            if k > 0 && step + k >= self.step {
                self.history.entry(step).or_default().entry(j).or_insert(values);
            }
            return;
        }
        self.buffer.entry(step).or_default().insert(j, values);
        if self.started && step >= self.step + BEHIND_STEPS {
            // A particle within the support this far ahead is no longer waiting for us; only an agent that
            // itself stalled (SIGSTOP) concludes the swarm went on without it and rejoins at its step (a slower
            // group is waited for).
            let dx = values[X] - self.state[X];
            let dy = values[Y] - self.state[Y];
            let timeout = self.spec.timeout;
            let stalled = now - self.last_step_done > timeout
                || self.resumed_at.is_some_and(|t| now - t < REJOIN_WINDOW * timeout);
            let support = self.params.support();
            if stalled && dx * dx + dy * dy <= support * support {
                self.ahead_senders.insert(j);
                if self.ahead_senders.len() >= BEHIND_SENDERS {
                    self.behind = true;
                }
            }
        }
    }
}
