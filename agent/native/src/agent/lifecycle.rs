//! The agent's life: start-up (its cells, the gesture command, the alive token, the start barrier or a late
//! join), rejoining after a freeze, and its end (final state, report, exit code).

use super::{Action, AgentCore, Halt, Lock, Phase, Wake, EXIT_NO_START, EXIT_OK, EXIT_STOPPED, SLICE};
use crate::event::EventKind;
use crate::final_report::Status;
use crate::keys;
use crate::spec::Mode;
use crate::sph::{X, Y};
use crate::wire;

impl AgentCore {
    /// The first call: the cells around the start position, then the command (a follower) or the token.
    pub(super) fn setup(&mut self, now: f64) -> Option<Phase> {
        self.update_cells();
        let deadline = now + self.spec.start_timeout;
        if self.controller.is_some() && !self.spec.join {
            return Some(Phase::AwaitCommand { deadline });
        }
        Some(self.alive(deadline))
    }

    /// Ready only once the gesture command is known, so every agent applies it from step 0.
    pub(super) fn await_command(&mut self, now: f64, deadline: f64) -> Option<Phase> {
        if self.controller.as_ref().is_some_and(|c| c.has_command()) {
            return Some(self.alive(deadline));
        }
        if now > deadline {
            return self.halt_with(Halt::NoStart);
        }
        self.phase = Phase::AwaitCommand { deadline };
        self.sleep(now + SLICE, Wake::default());
        None
    }

    /// The alive token last: the launcher's start barrier waits for it, so when the swarm starts every agent's
    /// state subscriptions are declared and no step-0 state is missed.
    fn alive(&mut self, deadline: f64) -> Phase {
        self.out.push(Action::DeclareAlive);
        if self.spec.join {
            Phase::Joining { deadline }
        } else {
            Phase::AwaitStart { deadline }
        }
    }

    pub(super) fn await_start(&mut self, now: f64, deadline: f64) -> Option<Phase> {
        if self.started {
            self.initial_neighbours();
            return Some(Phase::Begin);
        }
        if now > deadline {
            return self.halt_with(Halt::NoStart);
        }
        self.phase = Phase::AwaitStart { deadline };
        self.sleep(now + SLICE, Wake::default());
        None
    }

    /// A late joiner waits for the first state it hears around it (docs/protocol.md, "Late joiners").
    pub(super) fn await_first_state(&mut self, now: f64, deadline: f64) -> Option<Phase> {
        if self.started {
            return Some(Phase::Begin); // join_on adopted a step
        }
        if now > deadline {
            return self.halt_with(Halt::Stop);
        }
        self.phase = Phase::Joining { deadline };
        self.sleep(now + SLICE, Wake { on_state: true, ..Wake::default() });
        None
    }

    /// A state heard while joining: another agent's, on its cell key, gives the step (that step + 1). Any other
    /// record is passed over; those after it in the same batch are received as usual.
    pub(super) fn join_on(&mut self, record: &[u8], on_key: bool) {
        if let Ok(rec) = wire::decode_state(record) {
            if rec.id != self.spec.id && on_key {
                self.step = rec.step.saturating_add(1);
                self.started = true;
                self.buffer.clear();
                self.phase = Phase::Begin;
            }
        }
    }

    /// Started or joined: say so, and run in the spec's mode.
    pub(super) fn begin(&mut self, now: f64) -> Option<Phase> {
        self.event(EventKind::Started);
        self.t_start = Some(self.unix(now));
        self.last_step_done = now;
        Some(match self.spec.mode {
            Mode::Lockstep => Phase::Lockstep(Lock::Top),
            Mode::Async => Phase::Async { due: now },
        })
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
    /// does (docs/protocol.md, "Rejoining"): with what was queued while it was frozen (the whole batch has been
    /// received), it adopts the step after the newest it heard from those neighbours, forgets its own older
    /// steps' states, and says so (`rejoined`, with the step it was at). Its particle keeps the state it froze
    /// with; at the swarm's last step it is done.
    pub(super) fn rejoin(&mut self, now: f64) {
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
        self.last_step_done = now;
        self.event(EventKind::Rejoined { from_step: from });
    }

    /// The last step reached: the final state (so neighbours still waiting for it are not held up), the report.
    pub(super) fn finish(&mut self, now: f64, status: Status) -> Option<Phase> {
        self.t_end = Some(self.unix(now));
        self.publish();
        self.report(status);
        self.out.push(Action::Exit(EXIT_OK));
        self.phase = Phase::Ended;
        None
    }

    /// A stop reports `stopped` and exits 4; no start (or no command) in time exits 5 without a report.
    pub(super) fn halt_with(&mut self, halt: Halt) -> Option<Phase> {
        match halt {
            Halt::Stop => {
                self.report(Status::Stopped);
                self.out.push(Action::Exit(EXIT_STOPPED));
            }
            Halt::NoStart => self.out.push(Action::Exit(EXIT_NO_START)),
        }
        self.phase = Phase::Ended;
        None
    }
}
