//! The Zenoh shell around the agent's core (agent.rs): config once and declare once (main.rs, here), and the
//! core run where its input arrives. zenoh calls a subscriber's callback on the receiving thread that read the
//! message, with no zenoh lock held; the callback queues the input (inbox.rs) and, when the core has something
//! to do (what its last `Sleep` said to wake for: the step's last awaited state, a clock tick while paced, a
//! control or command), runs the core right there and puts its state from that thread. With the runtime layout
//! of main.rs (`choose_runtime`: one receiving worker that also runs the transmit task) a lockstep step then
//! costs the agent one wake-up: no hand-over to a stepping thread, no unpark of a transmit thread
//! (docs/benchmarks/realtime.md, "One wake-up per step").
//!
//! The main thread keeps what may block or is rare: the core's timeouts (a `Sleep` that ran out: a
//! republication, a neighbour timeout, an async step), the stop flag, (un)subscribing cells, the alive
//! token, events and the final report, the close. It looks at least every `SLICE`, and sooner when a callback
//! hands it an action or moves the core's sleep earlier than it looks next.

mod inbox;

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use zenoh::key_expr::KeyExpr;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;
use zenoh::qos::CongestionControl;
use zenoh::sample::Locality;
use zenoh::{Session, Wait};

use crate::agent::{Action, AgentCore, Input};
use crate::event::EventKind;
use crate::final_report::FinalReport;
use crate::keys;
use crate::route::CommandFollower;
use crate::spec::AgentSpec;
use crate::wire;
use inbox::Inbox;

/// Set by SIGTERM/SIGINT (main.rs); looked at every wake-up of the main thread (at most `SLICE` apart).
pub static STOP: AtomicBool = AtomicBool::new(false);
/// The longest the main thread sleeps without looking at STOP.
const SLICE: Duration = Duration::from_millis(250);
/// A callback rings the main thread for a sleep it shortened only when the main thread would look this much
/// later, s. The timers a callback sets are a lockstep wait's (its republication and deadline, a fraction of
/// the neighbour timeout away) and a paced agent's slice; the timers that need precision, the async steps,
/// the main thread sets itself.
const RING_SLACK: f64 = 0.1;
/// After a freeze (the core not run for longer than the neighbour timeout: SIGSTOP, a host that stood still)
/// the core is run only this long after the shell noticed it, s: time for the receiving thread to read what
/// queued up in the socket meanwhile. Run at once on the first states read, the oldest, the core caught up
/// through the steps it missed one by one instead of seeing its neighbours' newest states and rejoining the
/// swarm at their step (agent/receive.rs `behind`; tests/test_faults.py, two agents frozen for 3 s).
const RESUME_LISTEN: f64 = 0.05;

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

/// Where the agent's state goes: its own id key under per-process rights, else its cell's key.
struct StateKeys {
    session: Session,
    run: String,
    /// under per-process rights: our state key, declared once
    own: Option<KeyExpr<'static>>,
    /// without per-process rights: our current cell and its declared key
    cell: Option<((i64, i64), KeyExpr<'static>)>,
}

impl StateKeys {
    /// The key for a state of a particle in `cell`. The cell's key (a numeric id on the link) is declared anew
    /// on entering a cell.
    fn key(&mut self, cell: (i64, i64)) -> Option<KeyExpr<'static>> {
        if self.own.is_some() {
            return self.own.clone();
        }
        if self.cell.as_ref().map(|(pc, _)| *pc) != Some(cell) {
            if let Some((_, old)) = self.cell.take() {
                let _ = self.session.undeclare(old).wait();
            }
            if let Ok(key) = self.session.declare_keyexpr(keys::cell_key(&self.run, cell)).wait() {
                self.cell = Some((cell, key));
            }
        }
        self.cell.as_ref().map(|(_, k)| k.clone())
    }
}

/// Put a state record (or our watch record, which travels with them). Batched (`express` off: 3.1x the
/// steps/s of `express` on at N = 100) and remote only: our own cell's subscriber would otherwise get our state
/// back (under per-process rights the relay's copy on our cell still comes back; the core drops it).
/// docs/benchmarks/native.md.
fn put_state(session: &Session, key: KeyExpr<'static>, record: Vec<u8>, cc: CongestionControl) {
    let _ = session.put(key, record).congestion_control(cc).express(false).allowed_destination(Locality::Remote).wait();
}

/// An inbox agent's cells (spec `inbox`): told to the relay on our watch key instead of subscribed to
/// (watch.rs, relay/inboxes.rs).
struct Watched {
    key: KeyExpr<'static>,
    cells: std::collections::BTreeSet<(i64, i64)>,
    /// changed since it was last put
    dirty: bool,
}

/// What the receiving thread and the main thread share, under one mutex.
struct Driven {
    core: AgentCore,
    inbox: Inbox,
    keys: StateKeys,
    /// an inbox agent's cells, None for one that subscribes to them
    watched: Option<Watched>,
    /// when the core's latest sleep ends, s on the shell's clock
    until: f64,
    /// when the main thread looks next while it waits (-inf while it is busy: it looks again anyway)
    looks_at: f64,
    /// the core's actions for the main thread, in order (all but the sleeps, and the state puts but those of
    /// a run that subscribed a cell)
    deferred: Vec<Todo>,
    /// the core said Exit: nothing runs it any more
    ended: bool,
    /// state puts the main thread holds (handed over or its own) and has not yet made: the callbacks' puts
    /// wait behind them
    held_puts: usize,
    /// when the core last ran, s on the shell's clock
    last_run: f64,
    /// after a freeze: the core is not run before this time (RESUME_LISTEN; 0 when not holding)
    hold_until: f64,
    /// a gap between two runs of the core longer than this is a freeze (the spec's neighbour timeout), s
    freeze_gap: f64,
}

impl Driven {
    /// Whether the core may run at `now`: not while holding after a freeze, which this notices.
    fn may_run(&mut self, now: f64) -> bool {
        if self.hold_until == 0.0 && now - self.last_run > self.freeze_gap {
            self.hold_until = now + RESUME_LISTEN;
        }
        now >= self.hold_until
    }

    /// Run the core on what came, at `now`; the actions it returns.
    fn run_core(&mut self, now: f64, stop: bool) -> Vec<Action> {
        // A stop comes first: what came after it is not looked at (agent.rs `handle`)
        let mut inputs = if stop { vec![Input::Stop] } else { Vec::new() };
        inputs.extend(self.inbox.take());
        self.last_run = now;
        self.hold_until = 0.0;
        self.core.handle(now, inputs)
    }

    /// Sort the core's actions: a sleep sets what to wait for, a state put is made at once when `put_here` (the
    /// callbacks' worker, see `Shared::deliver`) and otherwise held for the main thread in order, the rest go to
    /// the main thread. Whether the main thread must look (it holds something new, or the sleep now ends more
    /// than RING_SLACK before it looks).
    fn dispatch(&mut self, actions: Vec<Action>, put_here: bool, out: &mut Vec<Todo>) -> bool {
        let mut ring = false;
        for action in actions {
            // An inbox agent's cells: kept here, and put (below) before anything else goes out. The relay then
            // has them before our state: a neighbour answers our state with its next one, which must find us
            // watching (as a cell subscription must be declared before the state goes out, `deliver`).
            if let (Some(w), Action::Subscribe(c) | Action::Unsubscribe(c)) = (&mut self.watched, &action) {
                let changed = match action {
                    Action::Subscribe(_) => w.cells.insert(*c),
                    _ => w.cells.remove(c),
                };
                w.dirty |= changed;
                continue;
            }
            ring |= self.put_watch(put_here, out);
            match action {
                Action::Publish { cell, record } => {
                    let Some(key) = self.keys.key(cell) else { continue };
                    let record = record.to_vec();
                    if put_here {
                        // Block, as from the main thread: a message's congestion control travels with it, and
                        // a router drops a `Drop` state for any subscriber whose queue is full (measured: the
                        // launcher's pacer at N = 1000 lost states, its clock stood for the agent timeout,
                        // 4.4 -> 0.7 steps/s). This worker also runs the link's transmit task, so a put that
                        // waited for room would wait for itself; it waits only when both of the link's
                        // batches are out, and the transmit task writes one at a time: that takes a whole
                        // unsent 64 kB batch of our states (~500 steps the router did not read us), which a
                        // lockstep agent cannot reach: it steps only on states the same router relays, and a
                        // router that stops reading agents stops relaying them.
                        put_state(&self.keys.session, key, record, CongestionControl::Block);
                    } else {
                        out.push(Todo::Put(key, record));
                        self.held_puts += 1;
                        ring = true;
                    }
                }
                Action::Sleep { until, wake } => {
                    self.inbox.expect(&wake);
                    self.until = until;
                    ring |= until + RING_SLACK < self.looks_at;
                }
                other => {
                    self.ended |= matches!(other, Action::Exit(_));
                    out.push(Todo::Act(other));
                    ring = true;
                }
            }
        }
        ring | self.put_watch(put_here, out)
    }

    /// An inbox agent's changed cells go out (here, or held for the main thread in order with the state puts);
    /// whether the main thread must look.
    fn put_watch(&mut self, put_here: bool, out: &mut Vec<Todo>) -> bool {
        let Some(w) = self.watched.as_mut().filter(|w| w.dirty) else { return false };
        w.dirty = false;
        let cells: Vec<(i64, i64)> = w.cells.iter().copied().collect();
        let record = crate::watch::encode_watch(&cells);
        if put_here {
            put_state(&self.keys.session, w.key.clone(), record, CongestionControl::Block);
            return false;
        }
        out.push(Todo::Put(w.key.clone(), record));
        self.held_puts += 1;
        true
    }
}

struct Shared {
    driven: Mutex<Driven>,
    /// rings the main thread
    bell: Condvar,
    t0: Instant,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Driven> {
        self.driven.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn now(&self) -> f64 {
        self.t0.elapsed().as_secs_f64()
    }

    /// On zenoh's receiving thread: queue an input (`push` says whether the core should run now) and, if so,
    /// run the core and put its state from this thread.
    fn deliver(&self, push: impl FnOnce(&mut Inbox) -> bool) {
        let mut d = self.lock();
        if !push(&mut d.inbox) || d.ended {
            return;
        }
        let now = self.now();
        if !d.may_run(now) {
            self.bell.notify_one(); // the main thread runs it when the hold ends
            return;
        }
        let actions = d.run_core(now, false);
        // A cell entered must be heard before our state goes out: a neighbour answers our state with its next
        // one, which the router sends only to the subscriptions it already has. Declaring waits for room in
        // the link's queue (zenoh never drops a declaration), which this worker must not, so a run of the
        // core that subscribes hands all its actions to the main thread, in order (a few steps in a hundred), as
        // the main thread did before: declare, then put.
        // And our states leave in the order the core made them: while the main thread still holds one (handed
        // over, or made by a timeout), this run's go behind it. Put here before it, a step-m+1 state overtook
        // step m's, and a neighbour still at m took m as lost and stepped without it (inexact: the rogue-states
        // test, 0.012 m).
        let subscribes = d.watched.is_none() && actions.iter().any(|a| matches!(a, Action::Subscribe(_)));
        let hand_off = d.held_puts > 0 || subscribes;
        let mut handed = Vec::new();
        let ring = d.dispatch(actions, !hand_off, &mut handed);
        d.deferred.append(&mut handed);
        if ring {
            self.bell.notify_one();
        }
    }
}

/// What the main thread does outside the lock, in the order the core said.
enum Todo {
    Put(KeyExpr<'static>, Vec<u8>),
    Act(Action),
}

/// What only the main thread holds: the declarations and the process figures of the report.
struct Shell {
    session: Session,
    run: String,
    id: u32,
    /// per watched cell, its subscriber and declared key (undeclared with it)
    cells: HashMap<(i64, i64), (Subscriber<()>, KeyExpr<'static>)>,
    fixed: Vec<Subscriber<()>>,
    token: Option<LivelinessToken>,
    cpu_at_start: Option<f64>,
    /// an inbox agent (spec `inbox`, lockstep)
    inbox: bool,
}

/// Run the agent of `spec` on an open session; its exit code.
pub fn run(spec: AgentSpec, controller: Option<CommandFollower>, session: Session) -> i32 {
    let t0 = Instant::now();
    let (run, id, state_key_ids, timeout) = (spec.run.clone(), spec.id, spec.state_key_ids, spec.timeout);
    let inbox = spec.inbox && spec.mode == crate::spec::Mode::Lockstep;
    let commands = controller.is_some();
    let core = AgentCore::new(spec, controller, 0.0, unix_now());
    let keys = StateKeys { session: session.clone(), run: run.clone(), own: None, cell: None };
    let driven = Driven {
        core,
        inbox: Inbox::default(),
        keys,
        watched: None,
        until: 0.0,
        looks_at: f64::NEG_INFINITY,
        deferred: Vec::new(),
        ended: false,
        held_puts: 0,
        last_run: 0.0,
        hold_until: 0.0,
        freeze_gap: timeout,
    };
    let shared = Arc::new(Shared { driven: Mutex::new(driven), bell: Condvar::new(), t0 });
    let mut shell =
        Shell { session, run, id, cells: HashMap::new(), fixed: Vec::new(), token: None, cpu_at_start: None, inbox };
    let mut stop = false;
    match shell.declare_fixed(&shared, commands, state_key_ids, inbox) {
        Ok((own, watch)) => {
            let mut d = shared.lock();
            d.keys.own = own;
            d.watched = watch.map(|key| Watched { key, cells: Default::default(), dirty: false });
        }
        Err(e) => {
            eprintln!("fluidswarm agent {id}: error: {e}");
            stop = true;
        }
    }
    loop {
        let todo = next_todo(&shared, std::mem::take(&mut stop));
        for t in todo {
            match t {
                Todo::Put(key, record) => {
                    // Block: a dropped state costs a lockstep swarm a republish round (Drop ran 0.5x,
                    // docs/benchmarks/native.md).
                    put_state(&shell.session, key, record, CongestionControl::Block);
                    shared.lock().held_puts -= 1;
                }
                Todo::Act(Action::Exit(code)) => {
                    shell.close();
                    return code;
                }
                Todo::Act(action) => {
                    if let Err(e) = shell.perform(&shared, action) {
                        if shell.cpu_at_start.is_some() {
                            eprintln!("fluidswarm agent {}: subscription failed: {e}", shell.id);
                        } else {
                            // A declaration before the start failed: nothing to run with (report `stopped`)
                            eprintln!("fluidswarm agent {}: error: {e}", shell.id);
                            stop = true;
                        }
                    }
                }
            }
        }
    }
}

/// The main thread's wait: until the callbacks hand it actions, the core's sleep runs out, or a stop (the
/// signal's flag, or `stop`); then the core run if its sleep ran out or it must stop. What to do, in order.
fn next_todo(shared: &Shared, stop: bool) -> Vec<Todo> {
    let mut d = shared.lock();
    loop {
        let now = shared.now();
        let due = now >= d.until && d.may_run(now);
        if stop || STOP.load(Ordering::Relaxed) || !d.deferred.is_empty() || due || d.ended {
            break;
        }
        let looks_at = d.until.max(d.hold_until).min(now + SLICE.as_secs_f64());
        d.looks_at = looks_at;
        d = shared.bell.wait_timeout(d, Duration::from_secs_f64(looks_at - now)).unwrap_or_else(|e| e.into_inner()).0;
    }
    d.looks_at = f64::NEG_INFINITY;
    let mut todo = std::mem::take(&mut d.deferred);
    let now = shared.now();
    let stop = stop || STOP.load(Ordering::Relaxed);
    if !d.ended && (stop || (now >= d.until && d.may_run(now))) {
        let actions = d.run_core(now, stop);
        d.dispatch(actions, false, &mut todo); // the main thread looks again anyway
    }
    todo
}

impl Shell {
    /// The control and command subscribers, and our state key under per-process rights, held for the run; an
    /// inbox agent's inbox subscriber and its watch key.
    fn declare_fixed(
        &mut self,
        shared: &Arc<Shared>,
        commands: bool,
        state_key_ids: bool,
        inbox: bool,
    ) -> Result<(Option<KeyExpr<'static>>, Option<KeyExpr<'static>>), String> {
        // An inbox agent's clock comes in its inbox (relay/inboxes.rs): it hears the other ctl messages on their
        // exact keys, not ctl/* (a tick a step would wake it once more)
        let ctl_keys = match inbox {
            false => vec![keys::ctl_expr(&self.run)],
            true => ["start", "stop", "end", "gone"].map(|w| keys::ctl_key(&self.run, w)).to_vec(),
        };
        for expr in ctl_keys {
            let sh = Arc::clone(shared);
            let ctl = self
                .session
                .declare_subscriber(expr)
                .callback(move |s| {
                    let key = s.key_expr().as_str().to_string();
                    let is_clock = key.ends_with("/clock");
                    let input = Input::Ctl { key, payload: s.payload().to_bytes().into_owned() };
                    sh.deliver(|inbox| inbox.push(input, is_clock))
                })
                .wait()
                .map_err(zerr)?;
            self.fixed.push(ctl);
        }
        if commands {
            let sh = Arc::clone(shared);
            let cmd = self
                .session
                .declare_subscriber(keys::command_key(&self.run))
                .callback(move |s| {
                    let input = Input::Command(s.payload().to_bytes().into_owned());
                    sh.deliver(|inbox| inbox.push(input, false))
                })
                .wait()
                .map_err(zerr)?;
            self.fixed.push(cmd);
        }
        let watch = if inbox { Some(self.declare_inbox(shared)?) } else { None };
        let own = if state_key_ids { Some(self.declare_state_key()?) } else { None };
        Ok((own, watch))
    }

    /// Our inbox (spec `inbox`): one message a step holding the neighbours' states the relay passed on from the
    /// cells we watch (relay/inboxes.rs), each record checked by the core as one from a cell. Our watch key.
    fn declare_inbox(&mut self, shared: &Arc<Shared>) -> Result<KeyExpr<'static>, String> {
        let sh = Arc::clone(shared);
        let exact = keys::inbox_key(&self.run, self.id);
        let clock_key = keys::ctl_key(&self.run, "clock");
        let key = self.session.declare_keyexpr(exact.clone()).wait().map_err(zerr)?;
        let sub = self
            .session
            .declare_subscriber(key)
            .callback(move |sample| {
                // Only the router's relay puts on our exact inbox key (docs/security.md); a put on a wildcard
                // key reaches us too. A message that is not an inbox message (relay/inboxes.rs `parse`) goes to
                // the core as one record, which it refuses and counts (`length`, `version` or `key`), as a bad
                // state on a cell. The launcher's clock rides in it (we hear no ctl/clock of our own).
                let on_key = sample.key_expr().as_str() == exact;
                let data = sample.payload().to_bytes();
                sh.deliver(|inbox| {
                    let Some((clock, records)) = crate::relay::inboxes::parse(&data).filter(|_| on_key) else {
                        return inbox.push_state(data.to_vec(), on_key);
                    };
                    let mut ring = false;
                    if let Some(c) = clock {
                        let payload = crate::ctl::encode(&crate::ctl::Ctl::Clock(c));
                        ring |= inbox.push(Input::Ctl { key: clock_key.clone(), payload }, true);
                    }
                    for record in records.chunks(wire::STATE_SIZE) {
                        ring |= inbox.push_state(record.to_vec(), true);
                    }
                    ring
                })
            })
            .wait()
            .map_err(zerr)?;
        self.fixed.push(sub);
        self.session.declare_keyexpr(keys::watch_key(&self.run, self.id)).wait().map_err(zerr)
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
    fn declare_state_key(&mut self) -> Result<KeyExpr<'static>, String> {
        let key = self.session.declare_keyexpr(keys::state_key(&self.run, self.id)).wait().map_err(zerr)?;
        let sub = self.session.declare_subscriber(key.clone()).callback(|_| {}).wait().map_err(zerr)?;
        self.fixed.push(sub);
        Ok(key)
    }

    fn perform(&mut self, shared: &Arc<Shared>, action: Action) -> Result<(), String> {
        match action {
            Action::Subscribe(c) => self.subscribe(shared, c),
            Action::Unsubscribe(c) => {
                if let Some((sub, key)) = self.cells.remove(&c) {
                    drop(sub); // undeclares the subscription before its key
                    let _ = self.session.undeclare(key).wait();
                }
                Ok(())
            }
            Action::DeclareAlive => {
                // An inbox agent's cells must be the relay's before anyone starts: the token is a declaration,
                // which overtakes a put still queued (declarations travel at a higher priority), and a neighbour's
                // step-0 state that found us not yet watching would never come (measured: 1 run in 6 at N = 30
                // waited the start timeout). The flush makes sure the router has handled our watch record.
                if self.inbox {
                    self.flush();
                }
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
            // the state puts, the sleeps and the exit are next_todo's and run's own
            Action::Publish { .. } | Action::Sleep { .. } | Action::Exit(_) => Ok(()),
        }
    }

    /// Hear cell `c`'s states on its exact key.
    fn subscribe(&mut self, shared: &Arc<Shared>, c: (i64, i64)) -> Result<(), String> {
        let sh = Arc::clone(shared);
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
                let record = sample.payload().to_bytes().into_owned();
                sh.deliver(|inbox| inbox.push_state(record, on_key))
            })
            .wait()
            .map_err(zerr)?;
        self.cells.insert(c, (sub, key));
        Ok(())
    }

    /// Events and the final report: Block, not the default Drop: they are few and must not be lost under load
    /// (the recorder's MCAP and the launcher's tally depend on them). From the main thread only (see `deliver`).
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
        self.flush();
    }

    /// Wait until the router has what we put so far (see `close`).
    fn flush(&self) {
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
