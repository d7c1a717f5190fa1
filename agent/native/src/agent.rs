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
//!
//! The parts, one job each (all `impl Agent` blocks over the struct defined here):
//! - inbox: the queue the Zenoh callbacks fill, the bell that wakes the main thread, ctl/command subscribers
//! - receive: what each queued message does to the neighbour table (states, ctl, commands)
//! - state_bus: where the state goes (our id key or our cell's key) and the state put
//! - cell_bus: the cells we hear states on
//! - wait: the expected set of a lockstep step and the wait for it
//! - step: the lockstep and async step loops (pacing, advancing the particle)
//! - lifecycle: start-up (barrier, join), the run, its end
//! - report: events and the final report

mod cell_bus;
mod inbox;
mod lifecycle;
mod receive;
mod report;
mod state_bus;
mod step;
mod wait;

use std::collections::{BTreeMap, HashMap, HashSet};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use zenoh::key_expr::KeyExpr;
use zenoh::pubsub::Subscriber;
use zenoh::Session;

use crate::final_report::Counters;
use crate::route::CommandFollower;
use crate::spec::AgentSpec;
use crate::sph::{self, State};

use inbox::Shared;
pub use report::peak_rss_mb;
pub use state_bus::Tuning;

/// A neighbour state further ahead than this is bogus (agent/process.py: MAX_AHEAD).
const MAX_AHEAD: u32 = 1000;
/// Distinct senders within the support, BEHIND_STEPS or more steps ahead, mean the swarm went on without this
/// (stalled) agent: it rejoins at their step (lifecycle.rs, `rejoin`).
const BEHIND_SENDERS: usize = 2;
const BEHIND_STEPS: u32 = 5;
/// timeouts after a resume (see `Agent::resumed_at`) during which neighbours far ahead mean it should rejoin
const REJOIN_WINDOW: f64 = 2.0;
/// A neighbour at most this many steps behind is waited for (a slower group catching up); one further
/// behind has stalled and is not (it catches up from the queued states or rejoins, see `Agent::rejoin`).
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
    NoStart,
}

fn unix_now() -> f64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_secs_f64()).unwrap_or(0.0)
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
    /// per watched cell, its subscriber and declared key (undeclared with it)
    cell_subs: HashMap<(i64, i64), (Subscriber<()>, KeyExpr<'static>)>,
    /// without per-process rights: our current cell and its declared key
    cell_publisher: Option<((i64, i64), KeyExpr<'static>)>,
    /// under per-process rights: our state key, declared once (states are put on it)
    state_key: Option<KeyExpr<'static>>,
    _fixed: Vec<Subscriber<()>>,
    _tokens: Vec<zenoh::liveliness::LivelinessToken>,
    buffer: BTreeMap<u32, BTreeMap<u32, State>>,
    /// id -> (step, x, y) of its latest sighting; step -1 with NaN position: a step-0 neighbour from the spec, not yet heard
    latest: HashMap<u32, (i64, f64, f64)>,
    heard_at: HashMap<u32, Instant>,
    dead: HashSet<u32>,
    ahead_senders: HashSet<u32>,
    /// set by the receive path when BEHIND_SENDERS neighbours went on without this stalled agent: the step loop
    /// rejoins at their step before its next step (a flag, not an error: the rest of the batch is still handled)
    behind: bool,
    /// when the main thread last looked at its inbox; a gap longer than the timeout means the process did not run
    /// (SIGSTOP, a host that froze): `resumed_at` is then set, and for REJOIN_WINDOW timeouts after it the agent
    /// counts as stalled (it catches up a step or two from old states before its neighbours' new ones arrive)
    awake_at: Instant,
    resumed_at: Option<Instant>,
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
        let state = sph::initial_state(x, y, vx, vy, &params, &spec.robot);
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
            cell_subs: HashMap::new(),
            cell_publisher: None,
            state_key: None,
            _fixed: Vec::new(),
            _tokens: Vec::new(),
            buffer: BTreeMap::new(),
            latest: HashMap::new(),
            heard_at: HashMap::new(),
            dead: HashSet::new(),
            ahead_senders: HashSet::new(),
            behind: false,
            awake_at: Instant::now(),
            resumed_at: None,
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

    fn reject(&mut self, reason: &str) {
        *self.counters.rejected.entry(reason.to_string()).or_insert(0) += 1;
    }
}
