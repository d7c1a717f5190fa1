//! The agent without I/O (docs/protocol.md): one particle's protocol as a state machine, in the shape of
//! quinn-proto or h11. It is fed what arrived (state records, ctl messages, gesture commands, a stop) with the
//! time it is handled, and returns what to do: (un)subscribe a cell, publish a state, declare the alive
//! token, send an event or the final report, sleep until a time (and what should cut the sleep short), exit
//! with a code. It holds no session, no thread and no clock: every time is the caller's `now`, seconds on a
//! monotonic clock. The Zenoh shell (shell.rs) performs the actions; `cargo test` feeds it sequences
//! (tests/vectors/agent_core/, agent/native/tests/all/agent_core.rs).
//!
//! Lockstep: at step m publish the state, wait for the step-m states of the agents expected near it,
//! compute step m+1 with `sph::step_particle`. Async: step on its own clock with the latest neighbour states
//! no older than `max_age`.
//!
//! The parts, one job each (all `impl AgentCore` blocks over the struct defined here):
//! - receive: what each input does to the neighbour table (states, ctl, commands)
//! - wait: the expected set of a lockstep step and the wait for it
//! - step: the lockstep and async steps (pacing, advancing the particle, the state put, the cells heard)
//! - lifecycle: start-up (command, barrier, join), rejoining, the end
//! - report: events and the final report

mod lifecycle;
mod receive;
mod report;
mod step;
mod wait;

use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};
use std::collections::{BTreeMap, BTreeSet};

use crate::event::Event;
use crate::final_report::{Counters, FinalReport};
use crate::route::CommandFollower;
use crate::spec::AgentSpec;
use crate::sph::{self, State};
use crate::wire;

/// A neighbour state further ahead than this is bogus.
const MAX_AHEAD: u32 = 1000;
/// Distinct senders within the support, BEHIND_STEPS or more steps ahead, mean the swarm went on without this
/// (stalled) agent: it rejoins at their step (lifecycle.rs, `rejoin`).
const BEHIND_SENDERS: usize = 2;
const BEHIND_STEPS: u32 = 5;
/// timeouts after a resume (see `AgentCore::resumed_at`) during which neighbours far ahead mean it should rejoin
const REJOIN_WINDOW: f64 = 2.0;
/// A neighbour at most this many steps behind is waited for (a slower group catching up); one further
/// behind has stalled and is not (it catches up from the queued states or rejoins, see `AgentCore::rejoin`).
const LAG_WAIT_STEPS: i64 = 3;
/// Pacing: never more than this many steps ahead of the launcher's clock (the slowest live agent).
pub const CLOCK_LEAD: u64 = 3;

/// Whether an agent about to run `step` waits for a newer clock than `clock`: it is more than CLOCK_LEAD steps
/// ahead of it. One rule for the agent (step.rs) and for the relay that must know whom a tick releases
/// (relay/inboxes.rs `held`).
pub fn paced(step: u64, clock: u64) -> bool {
    step > clock + CLOCK_LEAD
}
/// the least an agent waits for a neighbour in the first steps, s (see wait.rs)
const START_BURST_TIMEOUT: f64 = 15.0;
const START_BURST_STEPS: u32 = 4;
/// The longest sleep of a waiting phase, s: the shell looks at its stop flag at least this often.
const SLICE: f64 = 0.25;

pub const EXIT_OK: i32 = 0;
pub const EXIT_FELL_BEHIND: i32 = 3;
pub const EXIT_STOPPED: i32 = 4;
pub const EXIT_NO_START: i32 = 5;

/// What reached the agent.
#[derive(Clone, Debug, PartialEq)]
pub enum Input {
    /// a state record, and whether it came on exactly the cell key subscribed to (not a wildcard put)
    State { record: Vec<u8>, on_key: bool },
    /// a message on `ctl/*`, its full key
    Ctl { key: String, payload: Vec<u8> },
    /// a gesture command's payload
    Command(Vec<u8>),
    /// SIGTERM/SIGINT, or the shell cannot go on (a declaration failed): report `stopped`, exit 4
    Stop,
}

/// What the shell should wake for before a sleep's end (every input is queued regardless): the step-`step`
/// states of `awaited` (the last of them), any state (a late joiner), a clock tick (a paced agent). Controls,
/// commands and stops always wake it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Wake {
    pub step: u32,
    pub awaited: Vec<u32>,
    pub on_state: bool,
    pub on_clock: bool,
}

/// What the shell must do, in order.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// hear the states on cell `state/<cx>/<cy>`
    Subscribe((i64, i64)),
    Unsubscribe((i64, i64)),
    /// put the state record: on the agent's own state key under per-process rights, else on `cell`'s key
    Publish {
        cell: (i64, i64),
        record: [u8; wire::STATE_SIZE],
    },
    /// declare the `alive/<id>` token (the launcher's start barrier waits for it)
    DeclareAlive,
    Event(Event),
    /// the final report; the shell stamps its process figures on it (RSS, CPU time: the core has no process)
    Report(FinalReport),
    /// nothing to do before `until` (s, the caller's clock) unless something `wake` names arrives
    Sleep {
        until: f64,
        wake: Wake,
    },
    Exit(i32),
}

/// Why the run ends early.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Halt {
    Stop,
    NoStart,
}

/// Where the agent is in its life.
#[derive(Debug)]
enum Phase {
    /// nothing done yet: the first call subscribes the cells
    Setup,
    /// a follower waits for the gesture command before it says it is alive, so all apply it from step 0
    AwaitCommand {
        deadline: f64,
    },
    AwaitStart {
        deadline: f64,
    },
    /// a late joiner waits for the first state it hears
    Joining {
        deadline: f64,
    },
    /// started or joined: the `started` event next
    Begin,
    Lockstep(Lock),
    /// the next async step is due at this time
    Async {
        due: f64,
    },
    Ended,
}

/// Where a lockstep step is.
#[derive(Debug)]
enum Lock {
    /// before the step: the end, a rejoin, the pacing
    Top,
    /// more than CLOCK_LEAD steps ahead of the launcher's clock
    Paced,
    Waiting(Waiting),
}

/// A lockstep step's wait for its expected set.
#[derive(Debug)]
struct Waiting {
    expected: HashSet<u32>,
    began: f64,
    deadline: f64,
    /// the latest a neighbour still heard is waited for (wait.rs: only silent ones are dropped at `deadline`)
    cap: f64,
    /// neighbours dropped at this step (timed out): no longer missing
    given_up: HashSet<u32>,
    resend_at: f64,
    resend_every: f64,
}

pub struct AgentCore {
    spec: AgentSpec,
    params: sph::Params,
    cell: f64,
    r_sub: f64,
    r_keep: f64,
    state: State,
    controller: Option<CommandFollower>,
    phase: Phase,
    halt: Option<Halt>,
    out: Vec<Action>,
    /// the cells subscribed to (sorted: the actions come out in a reproducible order)
    cells: BTreeSet<(i64, i64)>,
    buffer: BTreeMap<u32, BTreeMap<u32, State>>,
    /// step -> id -> state of the last `radio.latency` steps done (and late arrivals for them): a radio with
    /// latency k uses a neighbour's state of k steps back (step.rs, `radio_rows`)
    history: BTreeMap<u32, BTreeMap<u32, State>>,
    /// id -> (step, x, y) of its latest sighting; step -1 with NaN position: a step-0 neighbour from the spec, not yet heard
    latest: HashMap<u32, (i64, f64, f64)>,
    heard_at: HashMap<u32, f64>,
    dead: HashSet<u32>,
    ahead_senders: HashSet<u32>,
    /// set by the receive path when BEHIND_SENDERS neighbours went on without this stalled agent: the step
    /// rejoins at their step before its next step (a flag, not an error: the rest of the batch is still handled)
    behind: bool,
    /// when the agent was last handed anything; a gap longer than the timeout means the process did not run
    /// (SIGSTOP, a host that froze): `resumed_at` is then set, and for REJOIN_WINDOW timeouts after it the agent
    /// counts as stalled (it catches up a step or two from old states before its neighbours' new ones arrive)
    awake_at: f64,
    resumed_at: Option<f64>,
    fresh: HashMap<u32, (f64, State)>,
    clock: Option<u64>,
    /// ctl/end: the launcher saw the formation settle; finish at this step (capped by the spec's steps)
    end: Option<u64>,
    last_step_done: f64,
    step: u32,
    started: bool,
    rng: u64,
    counters: Counters,
    /// the caller's clock reading and the Unix time when the session opened (the reports' times are Unix)
    opened_at: f64,
    session_opened_at: f64,
    t_start: Option<f64>,
    t_end: Option<f64>,
}

impl AgentCore {
    /// `now`: the caller's clock when the session opened; `unix_now`: the Unix time then.
    pub fn new(spec: AgentSpec, controller: Option<CommandFollower>, now: f64, unix_now: f64) -> AgentCore {
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
        AgentCore {
            cell,
            r_sub,
            r_keep: r_sub + 0.5 * cell,
            params,
            state,
            controller,
            phase: Phase::Setup,
            halt: None,
            out: Vec::new(),
            cells: BTreeSet::new(),
            buffer: BTreeMap::new(),
            history: BTreeMap::new(),
            latest: HashMap::default(),
            heard_at: HashMap::default(),
            dead: HashSet::default(),
            ahead_senders: HashSet::default(),
            behind: false,
            awake_at: now,
            resumed_at: None,
            fresh: HashMap::default(),
            clock: None,
            end: None,
            last_step_done: now,
            step: 0,
            started: false,
            rng,
            counters: Counters::default(),
            opened_at: now,
            session_opened_at: unix_now,
            t_start: None,
            t_end: None,
            spec,
        }
    }

    /// Handle what arrived since the last call (in arrival order) at time `now`, then go as far as the
    /// protocol can: the actions to perform, the last a `Sleep` or an `Exit`. A call with nothing is a
    /// clock tick (a sleep ended).
    pub fn handle(&mut self, now: f64, inputs: impl IntoIterator<Item = Input>) -> Vec<Action> {
        // Called at least every SLICE s while the agent runs: a longer gap is a freeze (receive.rs: rejoining)
        if now - self.awake_at > self.spec.timeout {
            self.resumed_at = Some(now);
        }
        self.awake_at = now;
        for input in inputs {
            if self.halt.is_some() || matches!(self.phase, Phase::Ended) {
                break; // what came after a stop is not looked at
            }
            self.receive(input, now);
        }
        self.advance_phase(now);
        std::mem::take(&mut self.out)
    }

    /// The step the agent is at.
    pub fn step(&self) -> u32 {
        self.step
    }

    /// Its particle's state.
    pub fn state(&self) -> &State {
        &self.state
    }

    fn advance_phase(&mut self, now: f64) {
        loop {
            if matches!(self.phase, Phase::Ended) {
                return;
            }
            if let Some(halt) = self.halt {
                self.halt_with(halt);
                return;
            }
            let next = match std::mem::replace(&mut self.phase, Phase::Ended) {
                Phase::Setup => self.setup(now),
                Phase::AwaitCommand { deadline } => self.await_command(now, deadline),
                Phase::AwaitStart { deadline } => self.await_start(now, deadline),
                Phase::Joining { deadline } => self.await_first_state(now, deadline),
                Phase::Begin => self.begin(now),
                Phase::Lockstep(lock) => self.lockstep(now, lock),
                Phase::Async { due } => self.async_step(now, due),
                Phase::Ended => return,
            };
            match next {
                Some(phase) => self.phase = phase,
                None => return, // the phase was set, and a Sleep or an Exit queued
            }
        }
    }

    fn sleep(&mut self, until: f64, wake: Wake) {
        self.out.push(Action::Sleep { until, wake });
    }

    /// The caller's time `now` as a Unix time.
    fn unix(&self, now: f64) -> f64 {
        self.session_opened_at + (now - self.opened_at)
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
