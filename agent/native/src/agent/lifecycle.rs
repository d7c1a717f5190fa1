//! The agent's life: start-up (fixed subscribers, the gesture command, the alive token, the start barrier or a
//! late join), the run in its mode, and its end (final state, report, exit code).

use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

use zenoh::Wait;

use super::inbox::Msg;
use super::report::cpu_seconds;
use super::{unix_now, Agent, Halt, EXIT_NO_START, EXIT_OK, EXIT_STOPPED, STOP};
use crate::event::EventKind;
use crate::final_report::Status;
use crate::keys;
use crate::spec::Mode;
use crate::sph::{X, Y};
use crate::wire;

impl Agent {
    pub fn run(&mut self) -> i32 {
        let code = match self.run_inner() {
            Ok(()) => {
                self.t_end = Some(unix_now());
                self.publish(); // the final state, so neighbours still waiting for it are not held up
                self.report(Status::Done);
                EXIT_OK
            }
            Err(Halt::Stop) => {
                self.report(Status::Stopped);
                EXIT_STOPPED
            }
            Err(Halt::NoStart) => EXIT_NO_START,
        };
        self.close_state_bus();
        self._fixed.clear();
        self.flush();
        code
    }

    fn run_inner(&mut self) -> Result<(), Halt> {
        let declared =
            self.declare_fixed().and_then(|_| self.declare_state_key()).and_then(|_| self.update_subscriptions());
        if let Err(e) = declared {
            eprintln!("fluidswarm agent {}: error: {e}", self.spec.id);
            return Err(Halt::Stop);
        }
        let start_deadline = Instant::now() + Duration::from_secs_f64(self.spec.start_timeout);
        if self.controller.is_some() && !self.spec.join {
            // Ready only once the gesture command is known, so every agent applies it from step 0.
            while !self.controller.as_ref().is_some_and(|c| c.has_command()) {
                if Instant::now() > start_deadline {
                    return Err(Halt::NoStart);
                }
                self.drain(0.25)?;
            }
        }
        // The alive token last: the launcher's start barrier waits for it, so when the swarm starts every
        // agent's state subscriptions are declared and no step-0 state is missed.
        match self.session.liveliness().declare_token(keys::alive_key(&self.spec.run, self.spec.id)).wait() {
            Ok(t) => self._tokens.push(t),
            Err(e) => {
                eprintln!("fluidswarm agent {}: error: {e}", self.spec.id);
                return Err(Halt::Stop);
            }
        }
        if self.spec.join {
            self.join(start_deadline)?;
        } else {
            while !self.started {
                if Instant::now() > start_deadline {
                    return Err(Halt::NoStart);
                }
                self.drain(0.25)?;
            }
            self.initial_neighbours();
        }
        self.event(EventKind::Started);
        self.t_start = Some(unix_now());
        self.cpu_at_start = Some(cpu_seconds());
        self.last_step_done = Instant::now();
        match self.spec.mode {
            Mode::Lockstep => self.run_lockstep(),
            Mode::Async => self.run_async(),
        }
    }

    /// Step-0 neighbours: of the agents the launcher placed nearby (the spec's `neighbours`), those whose
    /// initial cell is within R_sub — the set a query for born tokens in our cells returned before, without
    /// N × 25 liveliness queries that each walk every token in the router (docs/benchmarks/native.md).
    fn initial_neighbours(&mut self) {
        let (x0, y0) = (self.state[X], self.state[Y]);
        for &(j, x, y) in &self.spec.neighbours {
            let c = keys::cell_of(x, y, self.cell);
            if j != self.spec.id
                && keys::cell_distance(x0, y0, c, self.cell) <= self.r_sub
                && !self.latest.contains_key(&j)
            {
                self.latest.insert(j, (-1, f64::NAN, f64::NAN));
            }
        }
    }

    /// A stalled agent (SIGSTOP, a host that froze) whose neighbours went on without it rejoins as a late joiner
    /// does (docs/protocol.md, "Rejoining"): it takes what was queued while it was frozen, adopts the step after
    /// the newest it heard from those neighbours, forgets its own older steps' states, and says so (`rejoined`,
    /// with the step it was at). Its particle keeps the state it froze with; at the swarm's last step it is done.
    pub(super) fn rejoin(&mut self) -> Result<(), Halt> {
        self.drain(0.0)?; // the rest of the backlog: the newest sightings
        let from = self.step;
        let newest = self.ahead_senders.iter().filter_map(|j| self.latest.get(j)).map(|l| l.0).max();
        if let Some(s) = newest {
            let to = u32::try_from(s.saturating_add(1)).unwrap_or(from);
            self.step = to.max(from).min(self.last_step());
        }
        self.behind = false;
        self.resumed_at = None;
        self.ahead_senders.clear();
        let step = self.step;
        self.buffer.retain(|&s, _| s >= step);
        self.last_step_done = Instant::now();
        self.event(EventKind::Rejoined { from_step: from });
        Ok(())
    }

    /// A late joiner adopts the step of the first state it hears around it (docs/protocol.md).
    fn join(&mut self, deadline: Instant) -> Result<(), Halt> {
        self.shared.inbox.lock().unwrap_or_else(|e| e.into_inner()).wake_on_state = true;
        let result = self.await_first_state(deadline);
        self.shared.inbox.lock().unwrap_or_else(|e| e.into_inner()).wake_on_state = false;
        result
    }

    fn await_first_state(&mut self, deadline: Instant) -> Result<(), Halt> {
        loop {
            if STOP.load(Ordering::Relaxed) {
                return Err(Halt::Stop);
            }
            let shared = Arc::clone(&self.shared);
            let msg = {
                let mut inbox = shared.inbox.lock().unwrap_or_else(|e| e.into_inner());
                if inbox.queue.is_empty() {
                    inbox = shared
                        .bell
                        .wait_timeout(inbox, Duration::from_millis(250))
                        .unwrap_or_else(|e| e.into_inner())
                        .0;
                    inbox.rung = false;
                }
                inbox.queue.pop_front()
            };
            match msg {
                None => {
                    if Instant::now() > deadline {
                        return Err(Halt::Stop);
                    }
                }
                Some(Msg::State(data, on_key)) => {
                    if let Ok(rec) = wire::decode_state(&data) {
                        if rec.id != self.spec.id && on_key {
                            self.step = rec.step.saturating_add(1);
                            self.started = true;
                            self.buffer.clear();
                            return Ok(());
                        }
                    }
                }
                Some(other) => self.handle(other)?,
            }
        }
    }
}
