//! One agent of the bare lockstep exchange (docs/benchmarks/realtime.md, "The floor"): the agent's Zenoh
//! traffic without its physics or protocol. scripts/bare_exchange_launch.py starts N of them on a lattice, one per
//! cell of side 1, against the production router at the default access level.
//!
//!     bare_exchange ENDPOINT RUN ID N RADIUS ROUNDS IDKEYS
//!
//! Agent ID of N (lattice of round(sqrt N) columns, at the centre of cell (ID % cols, ID / cols)) subscribes to
//! the cells intersecting the disc of RADIUS around it (keys::covering_cells, the agent's own function), with
//! the same declarations as shell.rs, declares its `alive` token, waits for `ctl/start`, then ROUNDS times:
//! puts a 104-byte state record (shell.rs's put: batched, Block, remote only) on its id key (IDKEYS = 1: the
//! router's relay re-puts it on its cell, as at `acl`) or its cell key (0: as at `none`), and waits, woken
//! once, until every agent of its cells has sent that round's record. Prints one line at the end:
//! `cpu_us=<CPU of the rounds> wall_s=<> received=<records> expected=<per round> switches=<context switches>`.
//!
//! With $BARE_INLINE = 1 the agent steps on zenoh's receiving thread (issue 49 item 1, shell.rs): the cell
//! callback that completes a round puts the next round's record itself, and the main thread only makes the
//! first put and waits for the last round. Run it with $BARE_RUNTIME =
//! `(rx:(worker_threads:1),tx:(handover:rx),app:(handover:rx),net:(handover:rx),acc:(handover:rx))` (the
//! agent's layout since then), so that the put's transmit task runs on the same worker and wakes nobody.
//!
//! With $BARE_INBOX = 1 (and IDKEYS = 1) the agent subscribes to no cell: it puts its cells on its watch key
//! and hears the round on its inbox key, one message per round from the router's relay (issue 49 item 2,
//! relay/inboxes.rs), counting the records inside as if they had come one by one.
//!
//! Extra client settings (batching, queues: docs/benchmarks/realtime.md) come as `path=json5` pairs separated by
//! `;` in $BARE_ZENOH_SET; $BARE_RUNTIME replaces the agent's ZENOH_RUNTIME layout. The credentials come from the environment, as the agent's (session.rs).

use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use fluidswarm_agent::session::{client_config, env_credentials};
use fluidswarm_agent::sph::NFIELDS;
use fluidswarm_agent::{keys, wire};
use zenoh::qos::CongestionControl;
use zenoh::sample::Locality;
use zenoh::Wait;

/// Records received per round (a ring: a neighbour is at most one round ahead in lockstep).
#[derive(Default)]
struct Counts {
    want: u32,
    need: u32,
    per_round: [(u32, u32); 4], // (round, count)
    started: bool,
    total: u64,
}

struct Inbox {
    counts: Mutex<Counts>,
    bell: Condvar,
    /// BARE_INLINE: what the callback needs to put the next round (set before the start)
    inline: std::sync::OnceLock<Putter>,
}

/// The next round's put, made by whichever thread completes a round.
struct Putter {
    session: zenoh::Session,
    key: zenoh::key_expr::KeyExpr<'static>,
    id: u32,
    state: [f64; NFIELDS],
    rounds: u32,
}

impl Putter {
    fn put(&self, round: u32) {
        let record = wire::encode_state(self.id, round, &self.state, 0);
        self.session
            .put(self.key.clone(), record.to_vec())
            .congestion_control(CongestionControl::Block)
            .express(false)
            .allowed_destination(Locality::Remote)
            .wait()
            .expect("put");
    }
}

impl Counts {
    fn complete(&self, round: u32) -> bool {
        let slot = self.per_round[(round % 4) as usize];
        slot.0 == round && slot.1 >= self.need
    }
}

fn cpu_seconds() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes into the timespec we own.
    unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// Context switches of the whole process (every thread), voluntary + involuntary.
fn switches() -> i64 {
    // SAFETY: getrusage writes into the struct we own.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut ru) };
    ru.ru_nvcsw + ru.ru_nivcsw
}

fn cell_of(id: u32, cols: u32) -> (f64, f64) {
    ((id % cols) as f64 + 0.5, (id / cols) as f64 + 0.5)
}

fn main() {
    // The agent's own runtime layout (main.rs choose_runtime), before any thread exists.
    // SAFETY: first thing in main, single-threaded.
    // $BARE_RUNTIME replaces it for the measurements of other layouts.
    let layout = std::env::var("BARE_RUNTIME").unwrap_or_else(|_| {
        "(rx:(worker_threads:1),app:(worker_threads:1),acc:(handover:app),net:(handover:app))".to_string()
    });
    unsafe { std::env::set_var("ZENOH_RUNTIME", layout) };
    let a: Vec<String> = std::env::args().skip(1).collect();
    if a.len() != 7 {
        eprintln!("usage: bare_exchange ENDPOINT RUN ID N RADIUS ROUNDS IDKEYS");
        std::process::exit(2);
    }
    let (endpoint, run) = (a[0].clone(), a[1].clone());
    let parse = |s: &str| s.parse::<f64>().unwrap_or_else(|_| panic!("not a number: {s}"));
    let (id, n, radius, rounds, idkeys) =
        (parse(&a[2]) as u32, parse(&a[3]) as u32, parse(&a[4]), parse(&a[5]) as u32, a[6] == "1");
    let cols = ((n as f64).sqrt().round() as u32).max(1);
    let (x, y) = cell_of(id, cols);
    let cells = keys::covering_cells(x, y, radius, 1.0);
    let by_inbox = idkeys && std::env::var("BARE_INBOX").is_ok_and(|v| v == "1");
    // Expected per round: every agent in a watched cell, ourselves too when the relay puts our state on our
    // cell (an inbox leaves ours out)
    let expected = (0..n)
        .filter(|&j| {
            let (xj, yj) = cell_of(j, cols);
            cells.contains(&keys::cell_of(xj, yj, 1.0)) && ((idkeys && !by_inbox) || j != id)
        })
        .count() as u32;

    let (user, password) = env_credentials();
    let mut conf = client_config(&[endpoint], &user, &password).expect("config");
    for pair in std::env::var("BARE_ZENOH_SET").unwrap_or_default().split(';').filter(|p| !p.is_empty()) {
        let (path, value) = pair.split_once('=').expect("BARE_ZENOH_SET: path=json5;...");
        conf.insert_json5(path, value).unwrap_or_else(|e| panic!("{path}: {e}"));
    }
    let session = zenoh::open(conf).wait().expect("open");
    let inbox = Arc::new(Inbox { counts: Mutex::default(), bell: Condvar::new(), inline: Default::default() });
    let inline = std::env::var("BARE_INLINE").is_ok_and(|v| v == "1");

    let mut held = Vec::new();
    let listen = |key: zenoh::key_expr::KeyExpr<'static>| {
        let ib = Arc::clone(&inbox);
        session
            .declare_subscriber(key)
            .callback(move |s| {
                let data = s.payload().to_bytes();
                // an inbox message has a header (relay/inboxes.rs); a cell's message is one record
                let records = match by_inbox {
                    true => fluidswarm_agent::relay::inboxes::parse(&data).map(|(_, r)| r).unwrap_or_default(),
                    false => &data[..],
                };
                let mut k = ib.counts.lock().unwrap();
                let mut completes = false;
                for record in records.chunks(wire::STATE_SIZE) {
                    let Some((_, step)) = wire::peek_id_step(record) else { return };
                    k.total += 1;
                    let slot = &mut k.per_round[(step % 4) as usize];
                    if slot.0 != step {
                        *slot = (step, 0);
                    }
                    slot.1 += 1;
                    completes |= step == k.want && k.complete(step);
                }
                if !completes {
                    return;
                }
                match ib.inline.get() {
                    // the rounds this callback completes (a neighbour's next round may already be in)
                    Some(p) => {
                        while k.want < p.rounds && k.complete(k.want) {
                            k.want += 1;
                            if k.want < p.rounds {
                                p.put(k.want);
                            }
                        }
                        if k.want == p.rounds {
                            ib.bell.notify_one();
                        }
                    }
                    None => ib.bell.notify_one(),
                }
            })
            .wait()
            .expect("subscriber")
    };
    if by_inbox {
        let key = session.declare_keyexpr(keys::inbox_key(&run, id)).wait().expect("keyexpr");
        held.push((listen(key.clone()), key));
        let watch = fluidswarm_agent::watch::encode_watch(&cells);
        session.put(keys::watch_key(&run, id), watch).congestion_control(CongestionControl::Block).wait().expect("put");
    } else {
        for &c in &cells {
            let key = session.declare_keyexpr(keys::cell_key(&run, c)).wait().expect("keyexpr");
            held.push((listen(key.clone()), key));
        }
    }
    let ib = Arc::clone(&inbox);
    let start = session
        .declare_subscriber(keys::ctl_expr(&run))
        .callback(move |s| {
            if s.key_expr().as_str().ends_with("/ctl/start") {
                ib.counts.lock().unwrap().started = true;
                ib.bell.notify_one();
            }
        })
        .wait()
        .expect("ctl subscriber");
    // Our put key, declared as shell.rs does (under per-process rights a subscriber on it names it to the router)
    let put_key = if idkeys {
        let k = session.declare_keyexpr(keys::state_key(&run, id)).wait().expect("keyexpr");
        held.push((session.declare_subscriber(k.clone()).callback(|_| {}).wait().expect("sub"), k.clone()));
        k
    } else {
        session.declare_keyexpr(keys::cell_key(&run, keys::cell_of(x, y, 1.0))).wait().expect("keyexpr")
    };
    let _token = session.liveliness().declare_token(keys::alive_key(&run, id)).wait().expect("token");

    {
        let mut k = inbox.counts.lock().unwrap();
        while !k.started {
            k = inbox.bell.wait_timeout(k, Duration::from_secs(120)).unwrap().0;
        }
    }
    let mut state = [0.0; NFIELDS];
    state[0] = x;
    state[1] = y;
    state[4] = 1.0;
    if inline {
        inbox.counts.lock().unwrap().need = expected; // before the putter: a round of 0 needed is complete
        let p = Putter { session: session.clone(), key: put_key.clone(), id, state, rounds };
        inbox.inline.set(p).ok().expect("set once");
    }
    let (cpu0, t0, sw0) = (cpu_seconds(), Instant::now(), switches());
    if let (Some(p), true) = (inbox.inline.get(), rounds > 0) {
        p.put(0);
        let mut k = inbox.counts.lock().unwrap();
        while k.want < rounds {
            let (next, timeout) = inbox.bell.wait_timeout(k, Duration::from_secs(30)).unwrap();
            k = next;
            if timeout.timed_out() {
                eprintln!("bare_exchange {id}: round {} not complete after 30 s", k.want);
                std::process::exit(3);
            }
        }
    }
    for round in (0..rounds).filter(|_| !inline) {
        inbox.counts.lock().unwrap().want = round;
        inbox.counts.lock().unwrap().need = expected;
        let record = wire::encode_state(id, round, &state, 0);
        session
            .put(put_key.clone(), record.to_vec())
            .congestion_control(CongestionControl::Block)
            .express(false)
            .allowed_destination(Locality::Remote)
            .wait()
            .expect("put");
        let mut k = inbox.counts.lock().unwrap();
        loop {
            let slot = k.per_round[(round % 4) as usize];
            if slot.0 == round && slot.1 >= expected {
                break;
            }
            let (next, timeout) = inbox.bell.wait_timeout(k, Duration::from_secs(30)).unwrap();
            k = next;
            if timeout.timed_out() {
                eprintln!("bare_exchange {id}: round {round}: {} of {expected} after 30 s", slot.1);
                std::process::exit(3);
            }
        }
    }
    let (cpu, wall, sw) = (cpu_seconds() - cpu0, t0.elapsed().as_secs_f64(), switches() - sw0);
    let total = inbox.counts.lock().unwrap().total;
    println!("cpu_us={:.0} wall_s={wall:.4} received={total} expected={expected} switches={sw}", cpu * 1e6);
    drop(start);
    drop(held);
    // Leave our last state time to go: the neighbours still wait for it (a query to the router travels behind it)
    if let Ok(r) = session.get(keys::final_key(&run, id)).timeout(Duration::from_secs(2)).wait() {
        while r.recv().is_ok() {}
    }
}
