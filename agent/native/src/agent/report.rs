//! What the agent tells the launcher and the recorder: events (event/<id>) and the final report
//! (final/<id>), as actions; the shell sends them with congestion control Block.

use super::{Action, AgentCore};
use crate::event::{Event, EventKind};
use crate::final_report::{FinalReport, Status};

impl AgentCore {
    pub(super) fn event(&mut self, kind: EventKind) {
        self.out.push(Action::Event(Event { id: self.spec.id, step: self.step, kind }));
    }

    /// The final report; `rss_mb`, `cpu_seconds` and `cpu_seconds_at_start` are the shell's to fill.
    pub(super) fn report(&mut self, status: Status) {
        let report = FinalReport {
            id: self.spec.id,
            status,
            steps: self.step,
            state: self.state.to_vec(),
            counters: self.counters.clone(),
            t_start: self.t_start,
            t_end: self.t_end,
            session_opened_at: self.session_opened_at,
            rss_mb: 0.0,
            pss_mb: 0.0,
            cpu_seconds: 0.0,
            cpu_seconds_at_start: None,
            following: self.controller.as_ref().map(|c| c.report()),
        };
        self.out.push(Action::Report(report));
    }
}
