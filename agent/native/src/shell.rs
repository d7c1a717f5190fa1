//! The Zenoh shell around the agent's core (agent.rs): config once and declare once (main.rs, here), tiny
//! callbacks that queue what arrives (inbox.rs), and one loop: take what came, hand it to the core with the
//! time, perform the actions it returns.

mod inbox;

use std::collections::HashMap;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use zenoh::key_expr::KeyExpr;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;
use zenoh::qos::CongestionControl;
use zenoh::sample::Locality;
use zenoh::{Session, Wait};

use crate::agent::{Action, AgentCore, Input, Wake};
use crate::event::EventKind;
use crate::final_report::FinalReport;
use crate::keys;
use crate::route::CommandFollower;
use crate::spec::AgentSpec;
use inbox::Inbox;

/// Set by SIGTERM/SIGINT (main.rs); looked at every wake-up (at most `SLICE` apart).
pub static STOP: AtomicBool = AtomicBool::new(false);
/// The longest the shell sleeps without looking at STOP.
const SLICE: Duration = Duration::from_millis(250);

fn unix_now() -> f64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_secs_f64()).unwrap_or(0.0)
}

/// This process's CPU time in seconds (user + system).
fn cpu_seconds() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes into the timespec we own.
    unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// The `field` line of a /proc file of ours (`VmHWM:     9244 kB`) in MB; 0 if absent.
fn proc_mb(file: &str, field: &str) -> f64 {
    std::fs::read_to_string(file)
        .ok()
        .and_then(|s| {
            s.lines().find(|l| l.starts_with(field)).and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map(|kb| kb / 1024.0)
        .unwrap_or(0.0)
}

/// Peak resident memory (VmHWM) of this process in MB: its own, not the forking parent's (profile.md).
fn peak_rss_mb() -> f64 {
    proc_mb("/proc/self/status", "VmHWM:")
}

/// This process's proportional set size (Pss of /proc/self/smaps_rollup) in MB: its private pages plus its share
/// of those it maps with others. RSS counts the agent program's text whole in every agent (~10 of its ~12 MB),
/// so N agents' RSS adds up to far more than they take (docs/benchmarks/profile.md).
fn pss_mb() -> f64 {
    proc_mb("/proc/self/smaps_rollup", "Pss:")
}

/// What the shell holds for the run: the session, its declarations, the process figures of the report.
struct Shell {
    session: Session,
    run: String,
    id: u32,
    inbox: Arc<Inbox>,
    /// per watched cell, its subscriber and declared key (undeclared with it)
    cells: HashMap<(i64, i64), (Subscriber<()>, KeyExpr<'static>)>,
    /// without per-process rights: our current cell and its declared key
    cell_key: Option<((i64, i64), KeyExpr<'static>)>,
    /// under per-process rights: our state key, declared once (states are put on it)
    state_key: Option<KeyExpr<'static>>,
    fixed: Vec<Subscriber<()>>,
    token: Option<LivelinessToken>,
    cpu_at_start: Option<f64>,
}

/// Run the agent of `spec` on an open session; its exit code.
pub fn run(spec: AgentSpec, controller: Option<CommandFollower>, session: Session) -> i32 {
    let t0 = Instant::now();
    let mut shell = Shell {
        session,
        run: spec.run.clone(),
        id: spec.id,
        inbox: Arc::new(Inbox::default()),
        cells: HashMap::new(),
        cell_key: None,
        state_key: None,
        fixed: Vec::new(),
        token: None,
        cpu_at_start: None,
    };
    let mut batch = Vec::new();
    if let Err(e) = shell.declare_fixed(controller.is_some(), spec.state_key_ids) {
        eprintln!("fluidswarm agent {}: error: {e}", spec.id);
        batch.push(Input::Stop);
    }
    let mut core = AgentCore::new(spec, controller, 0.0, unix_now());
    loop {
        let now = t0.elapsed().as_secs_f64();
        let mut sleep = (now, Wake::default());
        for action in core.handle(now, std::mem::take(&mut batch)) {
            match action {
                Action::Sleep { until, wake } => sleep = (until, wake),
                Action::Exit(code) => {
                    shell.close();
                    return code;
                }
                other => {
                    if let Err(e) = shell.perform(other) {
                        if shell.cpu_at_start.is_some() {
                            eprintln!("fluidswarm agent {}: subscription failed: {e}", shell.id);
                        } else {
                            // A declaration before the start failed: nothing to run with (report `stopped`)
                            eprintln!("fluidswarm agent {}: error: {e}", shell.id);
                            batch.push(Input::Stop);
                        }
                    }
                }
            }
        }
        if batch.is_empty() {
            let until = t0 + Duration::from_secs_f64(sleep.0.max(0.0));
            batch = shell.inbox.take(until, &sleep.1, SLICE, &STOP);
        }
    }
}

impl Shell {
    /// The control and command subscribers and our state key, held for the run.
    fn declare_fixed(&mut self, commands: bool, state_key_ids: bool) -> Result<(), String> {
        let inbox = Arc::clone(&self.inbox);
        let ctl = self
            .session
            .declare_subscriber(keys::ctl_expr(&self.run))
            .callback(move |s| {
                let key = s.key_expr().as_str().to_string();
                let is_clock = key.ends_with("/clock");
                inbox.push(Input::Ctl { key, payload: s.payload().to_bytes().into_owned() }, is_clock)
            })
            .wait()
            .map_err(zerr)?;
        self.fixed.push(ctl);
        if commands {
            let inbox = Arc::clone(&self.inbox);
            let cmd = self
                .session
                .declare_subscriber(keys::command_key(&self.run))
                .callback(move |s| inbox.push(Input::Command(s.payload().to_bytes().into_owned()), false))
                .wait()
                .map_err(zerr)?;
            self.fixed.push(cmd);
        }
        if state_key_ids {
            self.declare_state_key()?;
        }
        Ok(())
    }

    /// Our state key, declared once. States go out with `session.put`, not a declared Publisher: a
    /// publisher's subscriber interest, once finalized, makes the client drop puts for which it has not yet
    /// heard of a matching subscriber (zenoh's write-side filtering), so a neighbour that had just subscribed
    /// could miss a state. A plain put on a key without interest always goes to the router.
    ///
    /// `declare_keyexpr` gives the key a numeric id between this session and its own runtime only; the
    /// runtime names the key to the router once something is declared on it there. Without that every state
    /// reaches the router as a key string, which it resolves chunk by chunk and, having no cached decision
    /// for a string, runs through its access-control rules again: at N = 300 the run was 15-26 % slower side
    /// by side (docs/benchmarks/security.md, "Our own key, declared to the router"). A subscriber on our own
    /// key declares it; it receives nothing (our puts are for remote subscribers only, and the router sends
    /// nobody its own messages back). The cell layout needs none: we subscribe to our own cell anyway.
    fn declare_state_key(&mut self) -> Result<(), String> {
        let key = self.session.declare_keyexpr(keys::state_key(&self.run, self.id)).wait().map_err(zerr)?;
        let sub = self.session.declare_subscriber(key.clone()).callback(|_| {}).wait().map_err(zerr)?;
        self.fixed.push(sub);
        self.state_key = Some(key);
        Ok(())
    }

    fn perform(&mut self, action: Action) -> Result<(), String> {
        match action {
            Action::Subscribe(c) => self.subscribe(c),
            Action::Unsubscribe(c) => {
                if let Some((sub, key)) = self.cells.remove(&c) {
                    drop(sub); // undeclares the subscription before its key
                    let _ = self.session.undeclare(key).wait();
                }
                Ok(())
            }
            Action::Publish { cell, record } => {
                let key = if self.state_key.is_some() { self.state_key.clone() } else { self.cell_key(cell) };
                if let Some(key) = key {
                    // Batched (`express` off: 3.1x the steps/s of `express` on at N = 100) and Block (a dropped
                    // state costs a lockstep swarm a republish round; Drop ran 0.5x): docs/benchmarks/native.md.
                    // Remote only: our own cell's subscriber would otherwise get our state back (under
                    // per-process rights the relay's copy on our cell still comes back; the core drops it).
                    let _ = self
                        .session
                        .put(key, record.to_vec())
                        .congestion_control(CongestionControl::Block)
                        .express(false)
                        .allowed_destination(Locality::Remote)
                        .wait();
                }
                Ok(())
            }
            Action::DeclareAlive => {
                let token = self.session.liveliness().declare_token(keys::alive_key(&self.run, self.id)).wait();
                self.token = Some(token.map_err(zerr)?);
                Ok(())
            }
            Action::Event(event) => {
                if event.kind == EventKind::Started {
                    self.cpu_at_start = Some(cpu_seconds());
                }
                self.put_block(keys::event_key(&self.run, self.id), event.encode());
                Ok(())
            }
            Action::Report(report) => {
                let report = FinalReport {
                    rss_mb: peak_rss_mb(),
                    pss_mb: pss_mb(),
                    cpu_seconds: cpu_seconds(),
                    cpu_seconds_at_start: self.cpu_at_start,
                    ..report
                };
                self.put_block(keys::final_key(&self.run, self.id), report.encode());
                Ok(())
            }
            Action::Sleep { .. } | Action::Exit(_) => Ok(()), // the loop's own
        }
    }

    /// Hear cell `c`'s states on its exact key.
    fn subscribe(&mut self, c: (i64, i64)) -> Result<(), String> {
        let inbox = Arc::clone(&self.inbox);
        let exact = keys::cell_key(&self.run, c);
        // Declared first: the router then sends the cell's states with our numeric id for the key.
        let key = self.session.declare_keyexpr(exact.clone()).wait().map_err(zerr)?;
        let sub = self
            .session
            .declare_subscriber(key.clone())
            .callback(move |sample| {
                // A put on a wildcard key (`…/state/**`) reaches this subscriber too, and the router's deny rules
                // cannot name every wildcard (docs/security.md): only the exact key vouches.
                let on_key = sample.key_expr().as_str() == exact;
                inbox.push_state(sample.payload().to_bytes().into_owned(), on_key)
            })
            .wait()
            .map_err(zerr)?;
        self.cells.insert(c, (sub, key));
        Ok(())
    }

    /// The declared key of cell `c` (a numeric id on the link), re-declared on entering a cell: where we put
    /// our state without per-process rights.
    fn cell_key(&mut self, c: (i64, i64)) -> Option<KeyExpr<'static>> {
        if self.cell_key.as_ref().map(|(pc, _)| *pc) != Some(c) {
            if let Some((_, old)) = self.cell_key.take() {
                let _ = self.session.undeclare(old).wait();
            }
            if let Ok(key) = self.session.declare_keyexpr(keys::cell_key(&self.run, c)).wait() {
                self.cell_key = Some((c, key));
            }
        }
        self.cell_key.as_ref().map(|(_, k)| k.clone())
    }

    /// Events and the final report: Block, not the default Drop: they are few and must not be lost under load
    /// (the recorder's MCAP and the launcher's tally depend on them).
    fn put_block(&self, key: String, payload: String) {
        let _ = self.session.put(key, payload).congestion_control(CongestionControl::Block).wait();
    }

    /// The end: every subscription undeclared, then the flush that makes sure the report has left. A query to
    /// the router travels behind it on the same link, so its answer means the router has the report (the
    /// session's close does not wait for the queue). A plain query on our own final key: no queryable serves
    /// it, so the router answers at once (a liveliness query would walk every token of the swarm in the
    /// router, N times at the end of a run).
    fn close(&mut self) {
        self.cells.clear();
        self.fixed.clear();
        if let Ok(replies) =
            self.session.get(keys::final_key(&self.run, self.id)).timeout(Duration::from_secs(1)).wait()
        {
            while replies.recv().is_ok() {}
        }
    }
}

fn zerr(e: impl std::fmt::Display) -> String {
    e.to_string()
}
