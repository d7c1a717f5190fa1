//! The state relay under per-process rights, on the router's own session (the `fluidswarm-router` program):
//! a launcher's embedded router relays its run (asked over the router's stdin), a host's router (`fluidswarm
//! router`, multi-host) the agents each of its host's launchers registers, for any run (asked over Zenoh:
//! `HostRelays`).
//!
//! At access level `acl` an agent puts its state on its own id key, `state/<id>`, which the router's access
//! control lets no other process use, and hears states on the cell keys, `state/<cx>/<cy>`, which no agent
//! may put. The relay takes each state from its sender's id key, checks that the record names that sender and
//! holds a finite position, and puts it again on the cell key of that position (docs/protocol.md).
//! Running inside the router, its puts are routed in-process, with no hop and no Python (the Python relay on
//! the launcher's session cost ~3 s of launcher CPU per 200 steps at N = 300: docs/benchmarks/security.md).

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
#[cfg(feature = "net")]
use std::sync::Mutex;
use std::sync::RwLock;
use std::time::{Duration, Instant};

#[cfg(feature = "net")]
use zenoh::{
    key_expr::KeyExpr,
    qos::CongestionControl,
    sample::{Locality, Sample},
    Session, Wait,
};

use crate::keys;
use crate::wire;

pub mod inboxes;
use inboxes::Inboxes;

/// Reasons a state is not relayed, in the order the counters are reported: the record's own faults (as
/// wire::decode_state names them), a record naming another agent than its key (`id`: the key's owner forged
/// it), a put on a wildcard key (`key`: it names no agent; the router's deny rules cannot name every wildcard).
pub const REJECT_ID: &str = "id";
pub const REJECT_KEY: &str = "key";
pub const REASONS: [&str; 5] = [wire::REJECT_LENGTH, wire::REJECT_VERSION, wire::REJECT_VALUE, REJECT_ID, REJECT_KEY];

/// Which agents are relayed and on which cells: filled by the launcher (`add`) before each agent starts, read
/// by the relay for every state.
pub struct RelayTable {
    run: String,
    ids: RwLock<rustc_hash::FxHashMap<String, u32>>, // exact id key -> the agent id it belongs to
    cell: RwLock<Option<f64>>,                       // the cell side (m = h), one for the whole run
    rejected: [AtomicU64; REASONS.len()],
}

impl RelayTable {
    pub fn new(run: &str) -> RelayTable {
        RelayTable {
            run: run.to_string(),
            ids: RwLock::default(),
            cell: RwLock::default(),
            rejected: Default::default(),
        }
    }

    /// Relay agent `id`'s states from now on, on cells of side `cell` (the run's smoothing length).
    pub fn add(&self, id: u32, cell: f64) -> Result<(), String> {
        if id >= keys::MAX_AGENTS {
            return Err(format!("agent id {id}: ids 0..{} only", keys::MAX_AGENTS - 1));
        }
        if !(cell.is_finite() && cell > 0.0) {
            return Err(format!("agent {id}: smoothing length {cell} is not a positive number"));
        }
        let mut known = self.cell.write().expect("cell lock");
        match *known {
            None => *known = Some(cell),
            Some(c) if c != cell => {
                return Err(format!("agent {id}: smoothing length {cell} differs from the run's {c} (agents hear each other on cells of one size)"))
            }
            Some(_) => {}
        }
        self.ids.write().expect("ids lock").insert(keys::state_key(&self.run, id), id);
        Ok(())
    }

    /// The sender and the cell a state on `key` goes to, None if it is not relayed (the reason counted, or
    /// another launcher's agent: its own launcher relays it).
    pub fn route(&self, key: &str, data: &[u8]) -> Option<(u32, (i64, i64))> {
        let Some(&id) = self.ids.read().expect("ids lock").get(key) else {
            if key.contains('*') {
                self.reject(REJECT_KEY);
            }
            return None;
        };
        match wire::peek_id_position(data) {
            Err(reason) => {
                self.reject(reason);
                None
            }
            Ok((named, _, _)) if named != id => {
                self.reject(REJECT_ID);
                None
            }
            Ok((_, x, y)) => {
                let cell = self.cell.read().expect("cell lock").expect("a relayed agent set the cell");
                Some((id, keys::cell_of(x, y, cell)))
            }
        }
    }

    /// The cells agent `id` (of the exact key `key`) watches, from its watch record (watch.rs); None if the key
    /// is not an added agent's own watch key or the record is refused (the reason counted, as for states).
    pub fn watched(&self, key: &str, data: &[u8]) -> Option<(u32, Vec<(i64, i64)>)> {
        let id = keys::id_from_key(key).filter(|&id| keys::watch_key(&self.run, id) == key);
        let Some(id) =
            id.filter(|&id| self.ids.read().expect("ids lock").contains_key(&keys::state_key(&self.run, id)))
        else {
            if key.contains('*') {
                self.reject(REJECT_KEY);
            }
            return None;
        };
        match crate::watch::decode_watch(data) {
            Ok(cells) => Some((id, cells)),
            Err(reason) => {
                self.reject(reason);
                None
            }
        }
    }

    /// How many agents this relay passes on (a batch for the observers is full at this many states).
    pub fn len(&self) -> usize {
        self.ids.read().expect("ids lock").len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn reject(&self, reason: &str) {
        if let Some(k) = REASONS.iter().position(|r| *r == reason) {
            self.rejected[k].fetch_add(1, Ordering::Relaxed);
        }
    }

    /// `length=<n> version=<n> value=<n> id=<n> key=<n>`
    pub fn rejected_line(&self) -> String {
        REASONS
            .iter()
            .zip(&self.rejected)
            .map(|(r, n)| format!("{r}={}", n.load(Ordering::Relaxed)))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// The answer to one request line of the relay's protocol (docs/protocol.md, router_program.rs), for the run of
/// `table`: `add <id> <h>` → `ok` | `error <why>`; `rejected` → `rejected length=<n> …`.
pub fn answer(table: &RelayTable, line: &str) -> String {
    match line.split_whitespace().collect::<Vec<_>>().as_slice() {
        ["add", id, h] => match (id.parse::<u32>(), h.parse::<f64>()) {
            (Ok(id), Ok(h)) => table.add(id, h).map(|_| "ok".to_string()).unwrap_or_else(|e| format!("error {e}")),
            _ => format!("error add: expected an agent id (0..{}) and a smoothing length", keys::MAX_AGENTS - 1),
        },
        ["rejected"] => format!("rejected {}", table.rejected_line()),
        _ => format!("error unknown request {line:?} (add <id> <h> | rejected)"),
    }
}

/// A batch waits at most this long for more states (the observers see a state this much later at worst).
pub const BATCH_WAIT: Duration = Duration::from_millis(10);

/// The states a relay passed on, gathered into one message for the run's passive observers (the recorder,
/// docs/protocol.md "State batches"): a concatenation of whole state records (each versioned itself), sent
/// once it holds one state per relayed agent (a lockstep step) or its oldest state waited BATCH_WAIT. One
/// delivery per batch instead of one per state is what the recorder's CPU went on (45 µs per agent-step at
/// N = 50, its zenoh-python callback and hand-over per state; issue 32).
#[derive(Default)]
pub struct StateBatch {
    buf: Vec<u8>,
    count: usize,
    since: Option<Instant>,
}

impl StateBatch {
    /// Add one (already routed, so well-formed) record; the batch to send if it now holds `full` states.
    pub fn push(&mut self, record: &[u8], full: usize, now: Instant) -> Option<Vec<u8>> {
        if self.count == 0 {
            self.since = Some(now);
        }
        self.buf.extend_from_slice(record);
        self.count += 1;
        (self.count >= full).then(|| self.take())
    }

    /// The batch to send if its oldest state has waited `wait` by `now`.
    pub fn take_if_older(&mut self, now: Instant, wait: Duration) -> Option<Vec<u8>> {
        match self.since {
            Some(t) if self.count > 0 && now.duration_since(t) >= wait => Some(self.take()),
            _ => None,
        }
    }

    fn take(&mut self) -> Vec<u8> {
        self.count = 0;
        self.since = None;
        std::mem::take(&mut self.buf)
    }
}

/// Runs one host's router relays at once, at most (a table and a subscriber each, kept until the router
/// closes: a run's agents may be added until its last late joiner).
pub const MAX_RUNS: usize = 256;

/// The key of a host router's relay requests: `fluidswarm/<run>/relay/<the router's zid>`. The zid makes a
/// launcher's request reach its own host's router only (a launcher is a client of exactly one router).
pub fn host_relay_key(run: &str, zid: &str) -> String {
    format!("{}/{run}/relay/{zid}", keys::PREFIX)
}

/// The run a host relay request's key names, if it is exactly `fluidswarm/<run>/relay/<zid>` with a valid
/// run name (the key comes from the network: a wildcard or a malformed run names none).
pub fn host_relay_run<'a>(key: &'a str, zid: &str) -> Option<&'a str> {
    let rest = key.strip_prefix(keys::PREFIX)?.strip_prefix('/')?;
    let (run, tail) = rest.split_once('/')?;
    (tail.strip_prefix("relay/") == Some(zid) && keys::valid_run_name(run)).then_some(run)
}

/// The cell keys a relay has declared, shared by its subscribers.
#[cfg(feature = "net")]
type Cells = std::sync::Arc<Mutex<HashMap<(i64, i64), KeyExpr<'static>>>>;

#[cfg(feature = "net")]
fn put_batch(session: &Session, key: &KeyExpr<'static>, batch: Vec<u8>) {
    // BLOCK, as for the states themselves: a slow recorder delays, never loses, a step of its file.
    let _ = session
        .put(key, batch)
        .congestion_control(CongestionControl::Block)
        .allowed_destination(Locality::Remote)
        .wait();
}

/// A relay's batch for the observers and the thread that sends it on `batch/<zid>` every BATCH_WAIT; the
/// thread ends within BATCH_WAIT of the Batcher's drop.
#[cfg(feature = "net")]
struct Batcher {
    batch: std::sync::Arc<Mutex<StateBatch>>,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
}

#[cfg(feature = "net")]
impl Batcher {
    /// With `inboxes`, the same thread sends the inbox groups that waited their longest (inboxes.rs `due`).
    fn start(session: &Session, run: &str, inboxes: Option<std::sync::Arc<InboxRelay>>) -> zenoh::Result<Batcher> {
        let key = session.declare_keyexpr(keys::batch_key(run, &session.zid().to_string())).wait()?;
        let batch: std::sync::Arc<Mutex<StateBatch>> = Default::default();
        let stop: std::sync::Arc<std::sync::atomic::AtomicBool> = Default::default();
        let (b, halt, out) = (batch.clone(), stop.clone(), session.clone());
        std::thread::Builder::new().name("batch-timer".into()).spawn(move || {
            while !halt.load(Ordering::Relaxed) {
                std::thread::sleep(BATCH_WAIT / 2);
                let due = b.lock().expect("batch lock").take_if_older(Instant::now(), BATCH_WAIT);
                if let Some(due) = due {
                    put_batch(&out, &key, due);
                }
                if let Some(inboxes) = &inboxes {
                    inboxes.due(&out, Instant::now());
                }
            }
        })?;
        Ok(Batcher { batch, stop })
    }
}

/// The inboxes of a launcher's embedded router (inboxes.rs) and their declared keys, under one lock that is
/// also held while their messages are put: an agent's messages leave in the order they were made (a step's
/// group never overtakes the one before; an agent takes a step-m state that comes after m + 1's as lost).
#[cfg(feature = "net")]
struct InboxRelay {
    run: String,
    inner: Mutex<(Inboxes, rustc_hash::FxHashMap<u32, KeyExpr<'static>>)>,
}

#[cfg(feature = "net")]
impl InboxRelay {
    fn put_all(
        session: &Session,
        run: &str,
        keys_of: &mut rustc_hash::FxHashMap<u32, KeyExpr<'static>>,
        out: inboxes::Out,
    ) {
        for (to, records) in out {
            let key = match keys_of.get(&to) {
                Some(k) => k.clone(),
                None => match session.declare_keyexpr(keys::inbox_key(run, to)).wait() {
                    Ok(k) => keys_of.entry(to).or_insert(k).clone(),
                    Err(_) => return, // the session is closing
                },
            };
            // BLOCK and REMOTE, as the cell puts below
            let _ = session
                .put(key, records)
                .congestion_control(CongestionControl::Block)
                .allowed_destination(Locality::Remote)
                .wait();
        }
    }

    /// Run `f` on the inboxes and put what it made, under the one lock.
    fn with(&self, session: &Session, f: impl FnOnce(&mut Inboxes, &mut inboxes::Out)) {
        let mut guard = self.inner.lock().expect("inbox lock");
        let (inboxes, keys_of) = &mut *guard;
        let mut out = inboxes::Out::new();
        f(inboxes, &mut out);
        Self::put_all(session, &self.run, keys_of, out);
    }

    fn clock(&self, session: &Session, clock: u64) {
        self.with(session, |ib, out| ib.clock(clock, Instant::now(), out));
    }

    fn due(&self, session: &Session, now: Instant) {
        self.with(session, |ib, out| ib.due(now, out));
    }
}

#[cfg(feature = "net")]
impl Drop for Batcher {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

/// A subscriber on `expr` (id keys of `table`'s run) whose callback routes and puts each state on zenoh's
/// receiving thread (no hand-over: the put is routed right there, as the router forwards any message), and
/// appends it to `batch` for the observers (StateBatch).
#[cfg(feature = "net")]
fn relay_subscriber(
    session: &Session,
    table: std::sync::Arc<RelayTable>,
    cells: Cells,
    batch: std::sync::Arc<Mutex<StateBatch>>,
    inboxes: Option<std::sync::Arc<InboxRelay>>,
    expr: String,
) -> zenoh::Result<zenoh::pubsub::Subscriber<()>> {
    let out = session.clone();
    session
        .declare_subscriber(expr)
        .callback(move |sample: Sample| {
            let record = sample.payload().to_bytes();
            let Some((from, c)) = table.route(sample.key_expr().as_str(), &record) else {
                return;
            };
            if let (Some(inboxes), Some((_, step))) = (&inboxes, wire::peek_id_step(&record)) {
                inboxes.with(&out, |ib, put| ib.state(from, step, c, &record, Instant::now(), put));
            }
            let key = {
                let mut cells = cells.lock().expect("cells lock");
                match cells.get(&c) {
                    Some(k) => k.clone(),
                    None => match out.declare_keyexpr(keys::cell_key(&table.run, c)).wait() {
                        Ok(k) => cells.entry(c).or_insert(k).clone(),
                        Err(_) => return, // the session is closing
                    },
                }
            };
            let payload = sample.payload().clone();
            // usize::MAX: never full here; the Batcher's thread sends every batch, so that this thread, which
            // every state of the run goes through, never waits on a batch's put (measured: sending full
            // batches here cost the router 10-20 µs more per agent-step at N = 300)
            batch.lock().expect("batch lock").push(&record, usize::MAX, Instant::now());
            // REMOTE: nobody on the router's own session listens to cells. BLOCK, as the agents put their
            // states: a neighbour's full queue delays a state, never drops it.
            let _ = out
                .put(key, payload)
                .congestion_control(CongestionControl::Block)
                .allowed_destination(Locality::Remote)
                .wait();
        })
        .wait()
}

/// The relay of a launcher's embedded router on `session`: one subscriber on every id key of the run (one
/// host: every agent of the run is this router's), and its batches for the observers.
#[cfg(feature = "net")]
pub struct StateRelay {
    _sub: zenoh::pubsub::Subscriber<()>,
    _watch: zenoh::pubsub::Subscriber<()>,
    _clock: zenoh::pubsub::Subscriber<()>,
    _batcher: Batcher,
}

#[cfg(feature = "net")]
impl StateRelay {
    /// Also the inboxes of the agents that send their watched cells (`watch/<id>`, watch.rs): one message a
    /// step on `inbox/<id>` for each (inboxes.rs).
    pub fn start(session: &Session, table: std::sync::Arc<RelayTable>) -> zenoh::Result<StateRelay> {
        let expr = format!("{}/{}/state/*", keys::PREFIX, table.run);
        let inboxes = std::sync::Arc::new(InboxRelay { run: table.run.clone(), inner: Default::default() });
        let batcher = Batcher::start(session, &table.run, Some(inboxes.clone()))?;
        let (ib, t, own) = (inboxes.clone(), table.clone(), session.clone());
        let watch = session
            .declare_subscriber(format!("{}/{}/watch/*", keys::PREFIX, table.run))
            .callback(move |sample: Sample| {
                if let Some((id, cells)) = t.watched(sample.key_expr().as_str(), &sample.payload().to_bytes()) {
                    ib.with(&own, |inboxes, out| inboxes.watch(id, cells, Instant::now(), out));
                }
            })
            .wait()?;
        // The launcher's clock ticks, to ride in the inboxes (inboxes.rs): its exact key only (only the
        // launcher may put ctl, docs/security.md; a wildcard put names no ctl message)
        let (ib, own, exact) = (inboxes.clone(), session.clone(), keys::ctl_key(&table.run, "clock"));
        let clock = session
            .declare_subscriber(exact.clone())
            .callback(move |sample: Sample| {
                let what = (sample.key_expr().as_str() == exact).then_some("clock");
                if let Some(crate::ctl::Ctl::Clock(c)) = crate::ctl::decode(what, &sample.payload().to_bytes()) {
                    ib.clock(&own, c);
                }
            })
            .wait()?;
        let sub = relay_subscriber(session, table, Cells::default(), batcher.batch.clone(), Some(inboxes), expr)?;
        Ok(StateRelay { _sub: sub, _watch: watch, _clock: clock, _batcher: batcher })
    }
}

/// A host router's relay of one run: a subscriber on each added agent's own id key, not on the run's `state/*`:
/// a router's subscription reaches the routers it is linked to, so a wildcard one pulled every state of every
/// other host across the router-to-router links, only to drop it (not its agent; docs/multi-host.md).
#[cfg(feature = "net")]
struct HostRelay {
    table: std::sync::Arc<RelayTable>,
    cells: Cells,
    batcher: Batcher,
    subs: HashMap<u32, zenoh::pubsub::Subscriber<()>>,
}

#[cfg(feature = "net")]
impl HostRelay {
    /// Answer `line` (`answer`); after a successful `add <id> …` follow that agent's id key (once).
    fn request(&mut self, session: &Session, line: &str) -> Result<String, String> {
        let text = answer(&self.table, line);
        if let (true, ["add", id, _]) = (text == "ok", line.split_whitespace().collect::<Vec<_>>().as_slice()) {
            let id: u32 = id.parse().map_err(|_| "add: bad id".to_string())?;
            if let std::collections::hash_map::Entry::Vacant(e) = self.subs.entry(id) {
                let expr = keys::state_key(&self.table.run, id);
                let (table, cells, batch) = (self.table.clone(), self.cells.clone(), self.batcher.batch.clone());
                let sub =
                    relay_subscriber(session, table, cells, batch, None, expr).map_err(|e| format!("relay: {e}"))?;
                e.insert(sub);
            }
        }
        Ok(text)
    }
}

/// A host's router relays (`fluidswarm-router --host`): a queryable on `fluidswarm/*/relay/<zid>` takes the
/// requests of `answer` from this host's launchers, and the first `add` of a run starts that run's relay.
#[cfg(feature = "net")]
pub struct HostRelays {
    _queryable: zenoh::query::Queryable<()>,
}

#[cfg(feature = "net")]
impl HostRelays {
    pub fn start(session: &Session) -> zenoh::Result<HostRelays> {
        type Runs = HashMap<String, HostRelay>;
        let zid = session.zid().to_string();
        let runs: Mutex<Runs> = Mutex::default();
        let own = session.clone();
        let expr = format!("{}/*/relay/{zid}", keys::PREFIX);
        let queryable = session
            .declare_queryable(expr)
            .callback(move |query: zenoh::query::Query| {
                let key = query.key_expr().clone();
                let line = query.payload().and_then(|p| p.try_to_string().ok().map(|s| s.to_string()));
                let reply = match (host_relay_run(key.as_str(), &zid), line) {
                    (None, _) => Err(format!("{key}: not a relay key of this router")),
                    (Some(_), None) => Err("a request is one line of UTF-8".to_string()),
                    (Some(run), Some(line)) => {
                        let mut runs = runs.lock().expect("runs lock");
                        if !runs.contains_key(run) && runs.len() >= MAX_RUNS {
                            Err(format!("this router already relays {MAX_RUNS} runs"))
                        } else if !runs.contains_key(run) && !line.starts_with("add ") {
                            Err(format!("run {run}: no agent of it is relayed here"))
                        } else {
                            if !runs.contains_key(run) {
                                match Batcher::start(&own, run, None) {
                                    Ok(batcher) => {
                                        let relay = HostRelay {
                                            table: std::sync::Arc::new(RelayTable::new(run)),
                                            cells: Cells::default(),
                                            batcher,
                                            subs: HashMap::new(),
                                        };
                                        runs.insert(run.to_string(), relay);
                                    }
                                    Err(e) => return drop(query.reply_err(format!("error relay: {e}")).wait()),
                                }
                            }
                            runs.get_mut(run).expect("inserted above").request(&own, &line)
                        }
                    }
                };
                let _ = match reply {
                    Ok(text) => query.reply(key, text).wait(),
                    Err(why) => query.reply_err(format!("error {why}")).wait(),
                };
            })
            .wait()?;
        Ok(HostRelays { _queryable: queryable })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_are_answered_in_one_line() {
        let t = RelayTable::new("r");
        assert_eq!(answer(&t, "add 3 0.5"), "ok");
        assert!(answer(&t, "add 3 0.25").starts_with("error agent 3: smoothing length 0.25 differs"));
        assert!(answer(&t, "add x 0.5").starts_with("error add: expected"));
        assert!(answer(&t, "add 9000 0.5").starts_with("error agent id 9000"));
        assert_eq!(answer(&t, "rejected"), "rejected length=0 version=0 value=0 id=0 key=0");
        assert!(answer(&t, "delete 3").starts_with("error unknown request"));
    }

    #[test]
    fn a_host_relay_key_names_one_valid_run_of_this_router() {
        let key = host_relay_key("run-1", "abc");
        assert_eq!(key, "fluidswarm/run-1/relay/abc");
        assert_eq!(host_relay_run(&key, "abc"), Some("run-1"));
        assert_eq!(host_relay_run(&key, "abd"), None); // another router's
        assert_eq!(host_relay_run("fluidswarm/*/relay/abc", "abc"), None);
        assert_eq!(host_relay_run("fluidswarm/**/relay/abc", "abc"), None);
        assert_eq!(host_relay_run("fluidswarm/r/relay/abc/x", "abc"), None);
        assert_eq!(host_relay_run("other/r/relay/abc", "abc"), None);
    }

    fn record(id: u32, x: f64, y: f64) -> Vec<u8> {
        let mut s = [0.0; crate::sph::NFIELDS];
        s[0] = x;
        s[1] = y;
        s[4] = 1.0;
        wire::encode_state(id, 3, &s, 0).to_vec()
    }

    #[test]
    fn a_batch_goes_out_full_or_after_its_wait() {
        let t0 = Instant::now();
        let mut b = StateBatch::default();
        assert_eq!(b.push(&record(1, 0.0, 0.0), 3, t0), None);
        assert_eq!(b.take_if_older(t0 + BATCH_WAIT / 2, BATCH_WAIT), None);
        assert_eq!(b.push(&record(2, 0.0, 0.0), 3, t0 + BATCH_WAIT / 2), None);
        let full = b.push(&record(3, 0.0, 0.0), 3, t0 + BATCH_WAIT / 2).expect("three of three");
        assert_eq!(full, [record(1, 0.0, 0.0), record(2, 0.0, 0.0), record(3, 0.0, 0.0)].concat());
        assert_eq!(b.take_if_older(t0 + 10 * BATCH_WAIT, BATCH_WAIT), None); // nothing left
        assert_eq!(b.push(&record(4, 0.0, 0.0), 3, t0 + 10 * BATCH_WAIT), None);
        // its wait runs from its oldest state, not from the previous batch
        assert_eq!(b.take_if_older(t0 + 10 * BATCH_WAIT + BATCH_WAIT / 2, BATCH_WAIT), None);
        assert_eq!(b.take_if_older(t0 + 11 * BATCH_WAIT, BATCH_WAIT), Some(record(4, 0.0, 0.0)));
    }

    #[test]
    fn routes_an_added_agents_record_to_its_cell_and_counts_the_rest() {
        let t = RelayTable::new("r");
        t.add(5, 0.5).unwrap();
        let k5 = keys::state_key("r", 5);
        assert_eq!(t.route(&k5, &record(5, 1.2, -0.1)), Some((5, (2, -1))));
        assert_eq!(t.route(&k5, &record(6, 1.2, -0.1)), None); // names another agent
        assert_eq!(t.route(&k5, &record(5, f64::NAN, 0.0)), None);
        assert_eq!(t.route(&k5, &record(5, 0.0, 0.0)[..40]), None);
        assert_eq!(t.route("fluidswarm/r/state/*", &record(5, 0.0, 0.0)), None);
        assert_eq!(t.route(&keys::state_key("r", 6), &record(6, 0.0, 0.0)), None); // not ours: not counted
        assert_eq!(t.rejected_line(), "length=1 version=0 value=1 id=1 key=1");
        assert!(t.add(6, 0.4).is_err()); // one cell size per run
        assert!(t.add(6, f64::NAN).is_err());
    }
}
