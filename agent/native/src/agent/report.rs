//! What the agent tells the launcher and the recorder: events (event/<id>) and the final report
//! (final/<id>), sent with congestion control Block, and the flush that makes sure the report has left.

use std::time::Duration;

use zenoh::qos::CongestionControl;
use zenoh::Wait;

use super::Agent;
use crate::event::{Event, EventKind};
use crate::final_report::{FinalReport, Status};
use crate::keys;

/// This process's CPU time in seconds (user + system).
pub(super) fn cpu_seconds() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes into the timespec we own.
    unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// Peak resident memory (VmHWM) of this process in MB: its own, not the forking parent's (profile.md).
pub fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines().find(|l| l.starts_with("VmHWM:")).and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map(|kb| kb / 1024.0)
        .unwrap_or(0.0)
}

impl Agent {
    pub(super) fn event(&self, kind: EventKind) {
        let event = Event { id: self.spec.id, step: self.step, kind };
        // Block, not the default Drop: events and the final report are few and must not be lost under load
        // (the recorder's MCAP and the launcher's tally depend on them).
        let _ = self
            .session
            .put(keys::event_key(&self.spec.run, self.spec.id), event.encode())
            .congestion_control(CongestionControl::Block)
            .wait();
    }

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
            rss_mb: peak_rss_mb(),
            cpu_seconds: cpu_seconds(),
            cpu_seconds_at_start: self.cpu_at_start,
            following: self.controller.as_ref().map(|c| c.report()),
        };
        let _ = self
            .session
            .put(keys::final_key(&self.spec.run, self.spec.id), report.encode())
            .congestion_control(CongestionControl::Block)
            .wait();
    }

    /// Make sure the final report has left: a query to the router travels behind it on the same link,
    /// so its answer means the router has the report (the session's close does not wait for the queue).
    /// A plain query on our own final key: no queryable serves it, so the router answers at once (a liveliness
    /// query would walk every token of the swarm in the router, N times at the end of a run).
    pub(super) fn flush(&self) {
        if let Ok(replies) =
            self.session.get(keys::final_key(&self.spec.run, self.spec.id)).timeout(Duration::from_secs(1)).wait()
        {
            while replies.recv().is_ok() {}
        }
    }
}
