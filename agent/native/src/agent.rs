//! The agent process: one particle, its neighbours over Zenoh, the per-particle SPH step (docs/protocol.md).
//!
//! Lockstep: at step m publish the state in its cell, wait for the step-m states of the agents expected
//! near it, compute step m+1 with `sph::step_particle`. Async: step on its own clock with the latest
//! neighbour states no older than `max_age`. The same protocol, message for message, as the Python agent it
//! replaced; its decisions (expected set, republishing, fell-behind, pacing) are ported line by line.
//!
//! Threads: Zenoh's receiving threads run the callbacks, which only queue the raw message and ring the
//! main thread when it has something to do (a control/liveliness/command message, or the last state it
//! waits for in this step): one wake-up per step, not one per message.

use std::collections::{BTreeMap, HashMap, HashSet, VecDeque};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use serde_json::{json, Map, Value};
use zenoh::pubsub::Subscriber;
use zenoh::qos::CongestionControl;
use zenoh::sample::Locality;
use zenoh::key_expr::KeyExpr;
use zenoh::{Session, Wait};

use crate::keys;
use crate::route::CommandFollower;
use crate::spec::{AgentSpec, Mode};
use crate::sph::{self, State, X, Y};
use crate::wire;

/// A neighbour state further ahead than this is bogus (agent/process.py: MAX_AHEAD).
const MAX_AHEAD: u32 = 1000;
/// Distinct senders within the support, BEHIND_STEPS or more steps ahead, mean the swarm dropped this agent.
const BEHIND_SENDERS: usize = 2;
const BEHIND_STEPS: u32 = 5;
/// A neighbour at most this many steps behind is waited for (a slower group catching up); one further
/// behind has stalled and is not (it catches up from the queued states or leaves, see FellBehind).
const LAG_WAIT_STEPS: i64 = 3;
/// Pacing: never more than this many steps ahead of the launcher's clock (the slowest live agent).
const CLOCK_LEAD: u64 = 3;
/// the least an agent waits for a neighbour in the first steps, s (see wait_for_states)
const START_BURST_TIMEOUT: f64 = 15.0;
const START_BURST_STEPS: u32 = 4;

pub const EXIT_OK: i32 = 0;
pub const EXIT_FELL_BEHIND: i32 = 3;
pub const EXIT_STOPPED: i32 = 4;
pub const EXIT_NO_START: i32 = 5;

/// Set by SIGTERM/SIGINT (main.rs); checked at every wake-up (at most 0.25 s apart).
pub static STOP: AtomicBool = AtomicBool::new(false);

/// Why the run loop ends early.
#[derive(Debug)]
pub enum Halt {
    Stop,
    FellBehind,
    NoStart,
}

enum Msg {
    /// a state record and the agent id in its key (None: not a decimal id), which must be the record's
    State(Vec<u8>, Option<u32>),
    Gone(u32),
    Ctl(String, Vec<u8>),
    Command(Vec<u8>),
}

#[derive(Default)]
struct Inbox {
    queue: VecDeque<Msg>,
    /// ids whose `await_step` state the main thread waits for; the callback rings when it empties
    awaited: HashSet<u32>,
    await_step: u32,
    wake_on_state: bool,
    /// pacing: the main thread waits for the launcher's clock to move on
    wake_on_clock: bool,
    rung: bool,
}

#[derive(Default)]
struct Shared {
    inbox: Mutex<Inbox>,
    bell: Condvar,
}

impl Shared {
    /// Queue a control, liveliness or command message. Clock ticks come at 50 Hz: they wake the main thread
    /// only while it waits for the clock (`wake_on_clock`); everything else always wakes it.
    fn push(&self, msg: Msg, is_clock: bool) {
        let mut inbox = self.inbox.lock().unwrap_or_else(|e| e.into_inner());
        inbox.queue.push_back(msg);
        if !is_clock || inbox.wake_on_clock {
            inbox.rung = true;
            self.bell.notify_one();
        }
    }

    fn push_state(&self, data: Vec<u8>, key_id: Option<u32>) {
        let mut inbox = self.inbox.lock().unwrap_or_else(|e| e.into_inner());
        let mut ring = inbox.wake_on_state;
        if !inbox.awaited.is_empty() {
            // A hint only: the main thread validates the record itself.
            if let Some((j, step)) = wire::peek_id_step(&data) {
                if step >= inbox.await_step && inbox.awaited.remove(&j) && inbox.awaited.is_empty() {
                    ring = true;
                }
            }
        }
        inbox.queue.push_back(Msg::State(data, key_id));
        if ring {
            inbox.rung = true;
            self.bell.notify_one();
        }
    }
}

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

#[derive(Default)]
struct Counters {
    msgs_received: u64,
    neighbours: u64,
    rejected: BTreeMap<String, u64>,
    timeouts: u64,
    deaths_seen: u64,
    stale: u64,
    dropped_out: u64,
    lost: u64,
}

/// Zenoh settings of the state publisher, measured side by side by `fluidswarm bench` (docs/benchmarks).
#[derive(Clone, Copy, Debug)]
pub struct Tuning {
    pub express: bool,
    pub congestion: CongestionControl,
}

impl Tuning {
    /// Defaults, overridable for measurements: FLUIDSWARM_EXPRESS=0|1, FLUIDSWARM_CONGESTION=block|drop.
    pub fn from_env() -> Tuning {
        let express = std::env::var("FLUIDSWARM_EXPRESS").map(|v| v == "1").unwrap_or(false);
        let congestion = match std::env::var("FLUIDSWARM_CONGESTION").as_deref() {
            Ok("drop") => CongestionControl::Drop,
            _ => CongestionControl::Block,
        };
        Tuning { express, congestion }
    }
}

pub struct Agent {
    tuning: Tuning,
    spec: AgentSpec,
    params: sph::Params,
    cell: f64,
    r_sub: f64,
    r_keep: f64,
    state: State,
    controller: Option<CommandFollower>,
    shared: Arc<Shared>,
    session: Session,
    /// per watched cell: its subscriber and the declared key (a numeric id on the link, undeclared with it)
    subscribers: HashMap<(i64, i64), (Subscriber<()>, KeyExpr<'static>)>,
    /// (cell, sender) -> the sender's state key in that watched cell, declared once heard (see note_sender)
    sender_keys: HashMap<((i64, i64), u32), KeyExpr<'static>>,
    /// our current cell and its declared key (states are put on it, see declare_publisher)
    publisher: Option<((i64, i64), KeyExpr<'static>)>,
    _fixed: Vec<Subscriber<()>>,
    _tokens: Vec<zenoh::liveliness::LivelinessToken>,
    buffer: BTreeMap<u32, BTreeMap<u32, State>>,
    /// id -> (step, x, y) of its latest sighting; step -1 with NaN position: known from its born token
    latest: HashMap<u32, (i64, f64, f64)>,
    heard_at: HashMap<u32, Instant>,
    dead: HashSet<u32>,
    ahead_senders: HashSet<u32>,
    fresh: HashMap<u32, (Instant, State)>,
    clock: Option<u64>,
    /// ctl/end: the launcher saw the formation settle; finish at this step (capped by the spec's steps)
    end: Option<u64>,
    last_step_done: Instant,
    step: u32,
    started: bool,
    rng: u64,
    counters: Counters,
    session_opened_at: f64,
    t_start: Option<f64>,
    t_end: Option<f64>,
    cpu_at_start: Option<f64>,
}

fn zerr(e: impl std::fmt::Display) -> String {
    e.to_string()
}

impl Agent {
    pub fn new(spec: AgentSpec, controller: Option<CommandFollower>, session: Session) -> Agent {
        let params = spec.params.clone();
        let d = params.max_step_displacement();
        let cell = params.h;
        // 2h + 10 v_max dt: a sighting up to 4 steps old is expected within 2h + 6 v_max dt, and every cell
        // the neighbour can have moved to since must be watched (docs/protocol.md, "Expected agents")
        let r_sub = params.support() + 10.0 * d;
        let [x, y, vx, vy] = spec.initial;
        let state = sph::initial_state(x, y, vx, vy, &params);
        // splitmix64 seeded by the id: the drop-out failure injection is reproducible per agent.
        let rng = (spec.id as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
        Agent {
            tuning: Tuning::from_env(),
            cell,
            r_sub,
            r_keep: r_sub + 0.5 * cell,
            params,
            state,
            controller,
            shared: Arc::new(Shared::default()),
            session,
            subscribers: HashMap::new(),
            sender_keys: HashMap::new(),
            publisher: None,
            _fixed: Vec::new(),
            _tokens: Vec::new(),
            buffer: BTreeMap::new(),
            latest: HashMap::new(),
            heard_at: HashMap::new(),
            dead: HashSet::new(),
            ahead_senders: HashSet::new(),
            fresh: HashMap::new(),
            clock: None,
            end: None,
            last_step_done: Instant::now(),
            step: 0,
            started: false,
            rng,
            counters: Counters::default(),
            session_opened_at: unix_now(),
            t_start: None,
            t_end: None,
            cpu_at_start: None,
            spec,
        }
    }

    fn random(&mut self) -> f64 {
        self.rng = self.rng.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.rng;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }

    /// The step after which the agent stops: the spec's, or an earlier one the launcher announced (ctl/end).
    fn last_step(&self) -> u32 {
        match self.end {
            Some(e) if e < self.spec.steps as u64 => e as u32,
            _ => self.spec.steps,
        }
    }

    // ---- message handling --------------------------------------------------------------------------
    fn handle(&mut self, msg: Msg) -> Result<(), Halt> {
        match msg {
            Msg::State(data, key_id) => self.handle_state(&data, key_id),
            Msg::Gone(j) => {
                if j != self.spec.id && self.dead.insert(j) {
                    self.latest.remove(&j);
                    self.fresh.remove(&j);
                    self.counters.deaths_seen += 1;
                }
                Ok(())
            }
            Msg::Ctl(key, payload) => {
                if key.ends_with("/start") {
                    self.started = true;
                    // Paced from the first step: until the launcher's first tick (it ticks once it has seen
                    // states) an agent with few expected neighbours would race CLOCK_LEAD+ steps ahead and
                    // make its slower neighbours conclude they fell behind.
                    self.clock.get_or_insert(0);
                } else if key.ends_with("/stop") {
                    return Err(Halt::Stop);
                } else if key.ends_with("/clock") && payload.len() == 8 {
                    let mut b = [0u8; 8];
                    b.copy_from_slice(&payload);
                    self.clock = Some(u64::from_le_bytes(b));
                } else if key.ends_with("/gone") && payload.len() == 4 {
                    // The launcher relays an agent's lost liveliness (docs/protocol.md: ctl/gone): one
                    // subscriber per agent on every other agent's token was O(N²) messages at start-up.
                    let mut b = [0u8; 4];
                    b.copy_from_slice(&payload);
                    let j = u32::from_le_bytes(b);
                    if j < (1u32 << 31) {
                        return self.handle(Msg::Gone(j));
                    }
                } else if key.ends_with("/end") && payload.len() == 8 {
                    let mut b = [0u8; 8];
                    b.copy_from_slice(&payload);
                    self.end = Some(u64::from_le_bytes(b));
                }
                Ok(())
            }
            Msg::Command(payload) => {
                let Some(ctl) = self.controller.as_mut() else { return Ok(()) };
                let first = !ctl.has_command();
                match ctl.offer(&payload, unix_now()) {
                    Some(reason) => *self.counters.rejected.entry(format!("command_{reason}")).or_insert(0) += 1,
                    None => {
                        if first && ctl.has_command() {
                            let since = unix_now() - self.session_opened_at;
                            self.event("command_received", json!({"seconds_since_session_open": since}));
                        }
                    }
                }
                Ok(())
            }
        }
    }

    fn reject(&mut self, reason: &str) {
        *self.counters.rejected.entry(reason.to_string()).or_insert(0) += 1;
    }

    /// The id a state key of agent `id` carries: Some(id) with ids in the state keys, None with cell keys.
    fn key_id_of(&self, id: u32) -> Option<u32> {
        self.spec.state_key_ids.then_some(id)
    }

    fn handle_state(&mut self, data: &[u8], key_id: Option<u32>) -> Result<(), Halt> {
        let rec = match wire::decode_state(data) {
            Ok(r) => r,
            Err(reason) => {
                self.reject(reason);
                return Ok(());
            }
        };
        // With ids in the state keys the router lets an agent publish only under its own id (docs/security.md):
        // a record naming another id is a forgery by the key's owner. Cell keys carry no id.
        if key_id != self.key_id_of(rec.id) {
            self.reject("key");
            return Ok(());
        }
        let (j, step, values) = (rec.id, rec.step, rec.values);
        if j == self.spec.id {
            return Ok(());
        }
        self.note_sender(j, values[X], values[Y]);
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
            return Ok(());
        }
        if step as u64 > self.step as u64 + MAX_AHEAD as u64 {
            self.reject("step");
            return Ok(());
        }
        self.counters.msgs_received += 1;
        let newer = self.latest.get(&j).map_or(true, |last| step as i64 >= last.0);
        if newer {
            let now = Instant::now();
            self.latest.insert(j, (step as i64, values[X], values[Y]));
            self.heard_at.insert(j, now);
            if self.spec.mode == Mode::Async {
                self.fresh.insert(j, (now, values));
            }
        }
        if self.spec.mode == Mode::Async {
            return Ok(());
        }
        if step < self.step {
            self.counters.stale += 1;
            return Ok(());
        }
        self.buffer.entry(step).or_default().insert(j, values);
        if self.started && step >= self.step + BEHIND_STEPS {
            // A particle within the support this far ahead is no longer waiting for us; only an agent
            // that itself stalled (SIGSTOP) concludes it was dropped, a slower group is waited for.
            let dx = values[X] - self.state[X];
            let dy = values[Y] - self.state[Y];
            let stalled = self.last_step_done.elapsed().as_secs_f64() > self.spec.timeout;
            let support = self.params.support();
            if stalled && dx * dx + dy * dy <= support * support {
                self.ahead_senders.insert(j);
                if self.ahead_senders.len() >= BEHIND_SENDERS {
                    return Err(Halt::FellBehind);
                }
            }
        }
        Ok(())
    }

    /// Handle queued messages; with none queued, sleep up to `timeout` or until a callback rings.
    fn drain(&mut self, timeout: f64) -> Result<bool, Halt> {
        if STOP.load(Ordering::Relaxed) {
            return Err(Halt::Stop);
        }
        let shared = Arc::clone(&self.shared);
        let batch = {
            let mut inbox = shared.inbox.lock().unwrap_or_else(|e| e.into_inner());
            if inbox.queue.is_empty() && timeout > 0.0 {
                let deadline = Instant::now() + Duration::from_secs_f64(timeout);
                while !inbox.rung && inbox.queue.is_empty() {
                    let left = deadline.saturating_duration_since(Instant::now());
                    if left.is_zero() {
                        break;
                    }
                    inbox = shared.bell.wait_timeout(inbox, left).unwrap_or_else(|e| e.into_inner()).0;
                }
            }
            inbox.rung = false;
            std::mem::take(&mut inbox.queue)
        };
        if STOP.load(Ordering::Relaxed) {
            return Err(Halt::Stop);
        }
        let any = !batch.is_empty();
        for msg in batch {
            self.handle(msg)?;
        }
        Ok(any)
    }

    // ---- subscriptions -----------------------------------------------------------------------------
    fn update_subscriptions(&mut self) -> Result<(), String> {
        let (x, y) = (self.state[X], self.state[Y]);
        let keep: HashSet<(i64, i64)> = keys::covering_cells(x, y, self.r_keep, self.cell).into_iter().collect();
        let gone: Vec<(i64, i64)> = self.subscribers.keys().filter(|c| !keep.contains(c)).copied().collect();
        for c in gone {
            self.sender_keys.retain(|(sc, _), key| {
                if *sc == c {
                    let _ = self.session.undeclare(key.clone()).wait();
                }
                *sc != c
            });
            if let Some((sub, key)) = self.subscribers.remove(&c) {
                drop(sub); // undeclares the subscription before its key
                let _ = self.session.undeclare(key).wait();
            }
        }
        for c in keys::covering_cells(x, y, self.r_sub, self.cell) {
            if !self.subscribers.contains_key(&c) {
                let shared = Arc::clone(&self.shared);
                let key = self.session.declare_keyexpr(keys::cell_expr(&self.spec.run, c, self.spec.state_key_ids)).wait().map_err(zerr)?;
                let sub = self
                    .session
                    .declare_subscriber(key.clone())
                    .callback(move |sample| {
                        let key_id = keys::state_sender(sample.key_expr().as_str());
                        shared.push_state(sample.payload().to_bytes().into_owned(), key_id)
                    })
                    .wait()
                    .map_err(zerr)?;
                self.subscribers.insert(c, (sub, key));
            }
        }
        Ok(())
    }

    /// Declare the key a neighbour publishes on in a watched cell, once: the router then sends its states
    /// with our numeric id for that key, and zenoh dispatches them by a table look-up. Undeclared, each state
    /// arrives with its key in full and is matched against every cell subscription (~35): 40 % of the
    /// agents' CPU at N = 300 (docs/benchmarks/native.md). The key's cell is the record's position's cell.
    fn note_sender(&mut self, j: u32, x: f64, y: f64) {
        if !self.spec.state_key_ids {
            return; // one exact key per cell: already dispatched by its declared id
        }
        let c = keys::cell_of(x, y, self.cell);
        if self.sender_keys.contains_key(&(c, j)) || !self.subscribers.contains_key(&c) {
            return;
        }
        if let Ok(key) = self.session.declare_keyexpr(keys::state_key(&self.spec.run, c, Some(j))).wait() {
            self.sender_keys.insert((c, j), key);
        }
    }

    // ---- publishing --------------------------------------------------------------------------------
    fn event(&self, what: &str, fields: Value) {
        let mut msg = Map::new();
        msg.insert("id".into(), json!(self.spec.id));
        msg.insert("step".into(), json!(self.step));
        msg.insert("event".into(), json!(what));
        if let Value::Object(extra) = fields {
            msg.extend(extra);
        }
        // Block, not the default Drop: events and the final report are few and must not be lost under load
        // (the recorder's MCAP and the launcher's tally depend on them).
        let _ = self
            .session
            .put(keys::event_key(&self.spec.run, self.spec.id), Value::Object(msg).to_string())
            .congestion_control(CongestionControl::Block)
            .wait();
    }

    fn publish(&mut self) {
        if self.spec.drop_out > 0.0 && self.random() < self.spec.drop_out {
            self.counters.dropped_out += 1;
            return;
        }
        self.declare_publisher();
        let class = self.controller.as_ref().map_or(0, |c| c.particle_class());
        let record = wire::encode_state(self.spec.id, self.step, &self.state, class);
        if let Some((_, key)) = &self.publisher {
            let _ = self
                .session
                .put(key.clone(), record.to_vec())
                .congestion_control(self.tuning.congestion)
                .express(self.tuning.express)
                // Our own cell's subscriber would otherwise get our state back (a local match per put)
                .allowed_destination(Locality::Remote)
                .wait();
        }
    }

    /// The declared key of our current cell (a numeric id on the link). States go out with `session.put`,
    /// not a declared Publisher: a publisher's subscriber interest, once finalized, makes the client drop
    /// puts for which it has not yet heard of a matching subscriber (zenoh's write-side filtering), and a
    /// publisher re-declared on entering a cell could lose its first state that way — a neighbour then
    /// waited for it until the timeout. A plain put on a key without interest always goes to the router.
    fn declare_publisher(&mut self) {
        let c = keys::cell_of(self.state[X], self.state[Y], self.cell);
        if self.publisher.as_ref().map(|(pc, _)| *pc) != Some(c) {
            if let Some((_, old)) = self.publisher.take() {
                let _ = self.session.undeclare(old).wait();
            }
            if let Ok(key) = self.session.declare_keyexpr(keys::state_key(&self.spec.run, c, self.key_id_of(self.spec.id))).wait() {
                self.publisher = Some((c, key));
            }
        }
    }

    // ---- the expected set and the wait -------------------------------------------------------------
    /// Agents whose step-m state this agent must wait for (docs/protocol.md, "Expected agents").
    ///
    /// A sighting k steps old (k = m - its step >= 1) can have moved k v_max dt since, so it is expected
    /// within 2h + (k + 2) v_max dt: R_expect for k = 1, wider for a lagging neighbour. The Python agent used
    /// R_expect whatever the age, which lost exactness under load (issue 14, defect (a)): a particle up to
    /// CLOCK_LEAD steps ahead of its group judged a neighbour by a sighting 3-4 steps old, did not wait for
    /// it, and the neighbour then reached its support at that step.
    fn expected(&mut self) -> HashSet<u32> {
        let (x, y) = (self.state[X], self.state[Y]);
        let d = self.params.max_step_displacement();
        let base = self.params.support();
        let recent = self.step as i64 - 1;
        let mut out = HashSet::new();
        let mut stale = Vec::new();
        for (&j, &(s, jx, jy)) in &self.latest {
            if jx.is_nan() {
                out.insert(j);
            } else if s < recent - LAG_WAIT_STEPS {
                stale.push(j); // never expected again unless heard again
            } else if (jx - x) * (jx - x) + (jy - y) * (jy - y) <= {
                let r = base + ((self.step as i64 - s).max(1) + 2) as f64 * d;
                r * r
            } {
                // Heard at the previous step: in step. Heard lately at an older step: a lagging group we
                // let catch up. Otherwise the sighting is stale (it moved away).
                let lately = self.heard_at.get(&j).is_some_and(|t| t.elapsed().as_secs_f64() < self.spec.timeout);
                if s >= recent || lately {
                    out.insert(j);
                }
            }
        }
        for j in stale {
            self.latest.remove(&j);
            self.heard_at.remove(&j);
        }
        out.remove(&self.spec.id);
        out
    }

    fn wait_for(&mut self, expected: &HashSet<u32>) -> Result<(), Halt> {
        let result = self.wait_for_states(expected);
        let mut inbox = self.shared.inbox.lock().unwrap_or_else(|e| e.into_inner());
        inbox.awaited.clear();
        result
    }

    fn wait_for_states(&mut self, expected: &HashSet<u32>) -> Result<(), Halt> {
        // The first steps follow the start barrier: every expected agent is up (or reported gone by ctl/gone),
        // only the start burst (N agents woken at once, their first routes computed) delays them — beyond the
        // 2 s timeout at N = 1000 (hundreds of neighbour timeouts at steps 0-2, none later).
        let burst = self.step < START_BURST_STEPS && !self.spec.join;
        let timeout = if burst { self.spec.timeout.max(START_BURST_TIMEOUT) } else { self.spec.timeout };
        let start = Instant::now();
        let deadline = start + Duration::from_secs_f64(timeout);
        // Republished at the normal pace even in the start burst: a neighbour that lost our state (drop-out)
        // must not wait a quarter of the longer burst timeout.
        let resend_every = Duration::from_secs_f64(self.spec.timeout / 4.0);
        let mut resend_at = start + resend_every;
        loop {
            self.drain(0.0)?;
            let step = self.step;
            let have = self.buffer.get(&step);
            let present = |j: &u32| have.is_some_and(|h| h.contains_key(j));
            // A neighbour heard at a later step has moved on: its state of this step was lost (one
            // publisher's messages arrive in order), so waiting for it would only cost the timeout.
            let missing: HashSet<u32> = expected
                .iter()
                .copied()
                .filter(|j| {
                    !present(j) && !self.dead.contains(j) && !self.latest.get(j).is_some_and(|l| l.0 > step as i64)
                })
                .collect();
            if missing.is_empty() {
                let lost = expected.iter().filter(|j| !present(j) && !self.dead.contains(j)).count();
                self.counters.lost += lost as u64;
                return Ok(());
            }
            let now = Instant::now();
            if now >= resend_at {
                // Lossy links: say it again while waiting (a neighbour that missed our state waits too).
                self.publish();
                resend_at = now + resend_every;
            }
            if now >= deadline {
                let mut ids: Vec<u32> = missing.iter().copied().collect();
                ids.sort_unstable();
                // What the agent knew of each: last sighting's step, its distance, whether its cell is watched
                let mut seen = Vec::new();
                for j in &ids {
                    if let Some((s, jx, jy)) = self.latest.remove(j) {
                        let dist = (jx - self.state[X]).hypot(jy - self.state[Y]);
                        let watched = !jx.is_nan() && self.subscribers.contains_key(&keys::cell_of(jx, jy, self.cell));
                        seen.push(json!([j, s, if dist.is_finite() { json!(dist) } else { Value::Null }, watched]));
                    }
                    self.counters.timeouts += 1;
                }
                self.event("neighbour_timeout", json!({"neighbours": ids, "last_seen": seen}));
                return Ok(());
            }
            // Arm the bell: the receiving thread rings when the last of `missing` has been heard.
            let shared = Arc::clone(&self.shared);
            let mut inbox = shared.inbox.lock().unwrap_or_else(|e| e.into_inner());
            inbox.await_step = step;
            inbox.awaited = missing;
            if !inbox.queue.is_empty() {
                continue;
            }
            let slice = deadline.min(resend_at).saturating_duration_since(now).min(Duration::from_millis(250));
            let wait_until = now + slice;
            // States that do not complete the awaited set are queued without ringing: sleep through them.
            while !inbox.rung {
                let left = wait_until.saturating_duration_since(Instant::now());
                if left.is_zero() || STOP.load(Ordering::Relaxed) {
                    break;
                }
                inbox = shared.bell.wait_timeout(inbox, left).unwrap_or_else(|e| e.into_inner()).0;
            }
            inbox.rung = false;
        }
    }

    // ---- the run -----------------------------------------------------------------------------------
    pub fn run(&mut self) -> i32 {
        let code = match self.run_inner() {
            Ok(()) => {
                self.t_end = Some(unix_now());
                self.publish(); // the final state, so neighbours still waiting for it are not held up
                self.report("done");
                EXIT_OK
            }
            Err(Halt::FellBehind) => {
                self.event("fell_behind", json!({}));
                self.report("fell_behind");
                EXIT_FELL_BEHIND
            }
            Err(Halt::Stop) => {
                self.report("stopped");
                EXIT_STOPPED
            }
            Err(Halt::NoStart) => EXIT_NO_START,
        };
        self.subscribers.clear();
        self._fixed.clear();
        self.flush();
        code
    }

    /// Make sure the final report has left: a query to the router travels behind it on the same link,
    /// so its answer means the router has the report (the session's close does not wait for the queue).
    /// A plain query on our own final key: no queryable serves it, so the router answers at once (a liveliness
    /// query would walk every token of the swarm in the router, N times at the end of a run).
    fn flush(&self) {
        if let Ok(replies) = self
            .session
            .get(keys::final_key(&self.spec.run, self.spec.id))
            .timeout(Duration::from_secs(1))
            .wait()
        {
            while replies.recv().is_ok() {}
        }
    }

    fn declare_fixed(&mut self) -> Result<(), String> {
        let run = self.spec.run.clone();
        let shared = Arc::clone(&self.shared);
        let ctl = self
            .session
            .declare_subscriber(keys::ctl_expr(&run))
            .callback(move |s| {
                let key = s.key_expr().as_str().to_string();
                let is_clock = key.ends_with("/clock");
                shared.push(Msg::Ctl(key, s.payload().to_bytes().into_owned()), is_clock)
            })
            .wait()
            .map_err(zerr)?;
        self._fixed.push(ctl);
        if self.controller.is_some() {
            let shared = Arc::clone(&self.shared);
            let cmd = self
                .session
                .declare_subscriber(keys::command_key(&run))
                .callback(move |s| shared.push(Msg::Command(s.payload().to_bytes().into_owned()), false))
                .wait()
                .map_err(zerr)?;
            self._fixed.push(cmd);
        }
        Ok(())
    }

    fn run_inner(&mut self) -> Result<(), Halt> {
        if let Err(e) = self.declare_fixed().and_then(|_| self.update_subscriptions()) {
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
        // agent's cell subscribers are declared and no step-0 state is missed. The state publisher too: 1000
        // publisher declarations in the start burst delayed step-0 states past the neighbour timeout.
        self.declare_publisher();
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
        self.event("started", json!({}));
        self.t_start = Some(unix_now());
        self.cpu_at_start = Some(cpu_seconds());
        self.last_step_done = Instant::now();
        match self.spec.mode {
            Mode::Lockstep => self.run_lockstep(),
            Mode::Async => self.run_async(),
        }
    }

    /// Step-0 neighbours: of the agents the launcher placed nearby (the spec's `neighbours`), those whose
    /// initial cell we watch — the set a query for born tokens in our cells returned before, without N × 25
    /// liveliness queries that each walk every token in the router (docs/benchmarks/native.md, N = 1000).
    fn initial_neighbours(&mut self) {
        let cells: HashSet<(i64, i64)> =
            keys::covering_cells(self.state[X], self.state[Y], self.r_sub, self.cell).into_iter().collect();
        for &(j, x, y) in &self.spec.neighbours {
            if j != self.spec.id && cells.contains(&keys::cell_of(x, y, self.cell)) && !self.latest.contains_key(&j) {
                self.latest.insert(j, (-1, f64::NAN, f64::NAN));
            }
        }
    }

    fn advance(&mut self, neighbours: &[State]) {
        let control = match self.controller.as_mut() {
            Some(c) => c.control(&self.state),
            None => self.spec.control,
        };
        self.counters.neighbours += sph::interacting(&self.state, neighbours, &self.params).count() as u64;
        self.state = sph::step_particle(&self.state, neighbours, &control, &self.params);
        self.step += 1;
        self.last_step_done = Instant::now();
        if let Err(e) = self.update_subscriptions() {
            eprintln!("fluidswarm agent {}: subscription failed: {e}", self.spec.id);
        }
    }

    fn run_lockstep(&mut self) -> Result<(), Halt> {
        let mut rows: Vec<State> = Vec::with_capacity(32);
        while self.step < self.last_step() {
            // An isolated particle must not run ahead of the swarm (the launcher's clock).
            if self.clock.is_some_and(|c| self.step as u64 > c + CLOCK_LEAD) {
                self.shared.inbox.lock().unwrap_or_else(|e| e.into_inner()).wake_on_clock = true;
                while self.clock.is_some_and(|c| self.step as u64 > c + CLOCK_LEAD) {
                    if let Err(h) = self.drain(0.05) {
                        return Err(h);
                    }
                }
                self.shared.inbox.lock().unwrap_or_else(|e| e.into_inner()).wake_on_clock = false;
            }
            self.publish();
            let expected = self.expected();
            self.wait_for(&expected)?;
            self.drain(0.0)?;
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
            self.event("neighbour_timeout", json!({"neighbours": expired}));
        }
        rows
    }

    fn run_async(&mut self) -> Result<(), Halt> {
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
                    inbox = shared.bell.wait_timeout(inbox, Duration::from_millis(250)).unwrap_or_else(|e| e.into_inner()).0;
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
                Some(Msg::State(data, key_id)) => {
                    if let Ok(rec) = wire::decode_state(&data) {
                        if rec.id != self.spec.id && key_id == self.key_id_of(rec.id) {
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

    fn report(&mut self, status: &str) {
        let c = &self.counters;
        let mut msg = Map::new();
        msg.insert("v".into(), json!(1));
        msg.insert("id".into(), json!(self.spec.id));
        msg.insert("status".into(), json!(status));
        msg.insert("steps".into(), json!(self.step));
        msg.insert("state".into(), json!(self.state.to_vec()));
        msg.insert("msgs_received".into(), json!(c.msgs_received));
        msg.insert("neighbours".into(), json!(c.neighbours));
        msg.insert("rejected".into(), json!(c.rejected));
        msg.insert("timeouts".into(), json!(c.timeouts));
        msg.insert("deaths_seen".into(), json!(c.deaths_seen));
        msg.insert("stale".into(), json!(c.stale));
        msg.insert("dropped_out".into(), json!(c.dropped_out));
        msg.insert("lost".into(), json!(c.lost));
        msg.insert("t_start".into(), json!(self.t_start));
        msg.insert("t_end".into(), json!(self.t_end));
        msg.insert("session_opened_at".into(), json!(self.session_opened_at));
        msg.insert("rss_mb".into(), json!(peak_rss_mb()));
        msg.insert("cpu_seconds".into(), json!(cpu_seconds()));
        msg.insert("cpu_seconds_at_start".into(), json!(self.cpu_at_start));
        msg.insert("agent".into(), json!("native"));
        if let Some(ctl) = &self.controller {
            msg.extend(ctl.report());
        }
        let _ = self
            .session
            .put(keys::final_key(&self.spec.run, self.spec.id), Value::Object(msg).to_string())
            .congestion_control(CongestionControl::Block)
            .wait();
    }
}
