//! The relay's inboxes, without I/O (issue 49, docs/protocol.md "Inboxes"): one message per lockstep step for
//! each agent that watches cells (watch.rs), holding every state the relay passed on from those cells since
//! the last one, instead of one message per neighbour state (~23 at R_sub = 2.5 h) on the cell keys. Each
//! message is a wake-up of the agent's receiving thread, and a wake-up is most of what a lockstep step cost
//! (docs/benchmarks/realtime.md).
//!
//! The relay computes no physics and decides nothing for an agent: it gives an agent exactly the states its
//! cell subscriptions would (those put on its watched cells, its own left out: the agent drops it anyway),
//! only grouped. What it chooses is *when* a group goes out: once every agent whose latest state is in one of
//! the watched cells, and that was not left behind (its latest step at least `next` - 1), has been given its
//! step-`next` state, or `wait` after the group's first state (INBOX_WAIT up, following the swarm's step
//! period). A state older than the step the group
//! waits for (a late one, a republication) goes out at once with whatever is pending. An agent that stopped
//! sending (dead, frozen) is waited for twice (`due`), then no more: its latest step falls behind.
//!
//! The launcher's pacing clock (`ctl/clock`, ~one tick per step) rides in the same messages instead of waking
//! every agent once more: each message carries the latest clock. A complete group that the latest clock would
//! not let its agent use (its next step more than agent::CLOCK_LEAD ahead) waits for the tick that does, and
//! goes out with it: one wake-up, not two (`holds`). The clock goes alone only to an agent held by the clock it
//! was last given (0 if none: ctl/start paces an agent from clock 0) that has no group of its own step to come
//! (it waits for a tick, and its neighbours, held too, send nothing); so does it to every agent still behind
//! at the launcher's once-a-second repetition of the clock (a safety net: a second at worst).
//!
//! An inbox message (v1, little-endian): u8 version = 1, u8 kind = 3, u16 flags (bit 0: the clock is set),
//! u32 reserved (0), u64 clock, then whole 104-byte state records (at most MAX_RECORDS).

use rustc_hash::FxHashMap as HashMap;
use std::time::{Duration, Instant};

type Cell = (i64, i64);

/// The least a group waits for its last state. A group's states spread over the swarm's step as the processes
/// get a core (~30-50 ms at N = 300 on 2 cores, ~350 ms at N = 1000): a group that goes out before its last
/// state came sends each state still missing alone, a wake-up each (17 per agent-step at N = 1000 with a fixed
/// 60 ms). So the wait follows the swarm's step period, WAIT_PERIODS of it, within [INBOX_WAIT,
/// MAX_INBOX_WAIT]. Only a neighbour that stopped costs it: two waits (`due`), once.
pub const INBOX_WAIT: Duration = Duration::from_millis(60);
/// The most a group waits: well inside the agent's own neighbour timeout (2 s; it republishes after a
/// quarter of it), so the relay never holds a state longer than the agent would wait for it.
pub const MAX_INBOX_WAIT: Duration = Duration::from_millis(400);
/// The wait in step periods: a group's spread is at most about one period (each agent steps once a period).
const WAIT_PERIODS: f64 = 1.5;
/// At most this many records in one message (the agent refuses more): a full group goes out.
pub const MAX_RECORDS: usize = 1024;
pub const VERSION: u8 = 1;
pub const KIND_INBOX: u8 = 3;
pub const HEADER: usize = 16;

/// An inbox message's header: the clock if set.
pub fn header(clock: Option<u64>) -> [u8; HEADER] {
    let mut h = [0u8; HEADER];
    h[0] = VERSION;
    h[1] = KIND_INBOX;
    h[2] = u8::from(clock.is_some());
    h[8..].copy_from_slice(&clock.unwrap_or(0).to_le_bytes());
    h
}

/// (the clock if set, the records) of an inbox message from the network, None if it is not one (a wrong
/// header, not whole records, more than MAX_RECORDS). The records are checked one by one by the agent's core.
pub fn parse(data: &[u8]) -> Option<(Option<u64>, &[u8])> {
    let (h, records) = (data.get(..HEADER)?, &data[HEADER..]);
    let flags = u16::from_le_bytes([h[2], h[3]]);
    if h[0] != VERSION || h[1] != KIND_INBOX || flags > 1 || h[4..8] != [0; 4] {
        return None;
    }
    let whole = records.len().is_multiple_of(crate::wire::STATE_SIZE);
    if !whole || records.len() > MAX_RECORDS * crate::wire::STATE_SIZE {
        return None;
    }
    let clock = u64::from_le_bytes(h[8..].try_into().expect("8 bytes"));
    Some(((flags == 1).then_some(clock), records))
}

/// One agent's inbox.
#[derive(Default)]
struct Watcher {
    cells: Vec<Cell>,
    /// the pending group's records, concatenated (whole STATE_SIZE records)
    buf: Vec<u8>,
    /// when the pending group's first state came (or, once overdue, when it went out at its wait)
    since: Option<Instant>,
    /// the group of step `next` went out once at its wait, incomplete (`due`)
    overdue: bool,
    /// since when the pending group, complete, waits for the clock tick that lets its agent step (`holds`)
    held: Option<Instant>,
    /// per sender, the highest step given to this agent (sent or pending)
    given: HashMap<u32, u32>,
    /// the step the pending group waits for (None: the first state sets it)
    next: Option<u32>,
    /// senders given a step >= `next`
    got: usize,
    /// how many agents the last look found the group waiting for
    need: usize,
    /// the clock it has: the last one its messages carried, else 0 (ctl/start paces an agent from clock 0,
    /// agent/receive.rs)
    clock_sent: u64,
}

impl Watcher {
    /// The pending group waits for step `next`: `got` counts the senders already given it.
    fn wait_for(&mut self, next: u32) {
        self.next = Some(next);
        self.got = self.given.values().filter(|&&s| s >= next).count();
    }
}

/// The relay's inboxes of one run.
#[derive(Default)]
pub struct Inboxes {
    watchers: HashMap<u32, Watcher>,
    /// cell -> the agents watching it
    watching: HashMap<Cell, Vec<u32>>,
    /// cell -> the agents whose latest state is in it
    members: HashMap<Cell, Vec<u32>>,
    /// agent -> (cell, step) of its latest state
    latest: HashMap<u32, (Cell, u32)>,
    /// the launcher's latest clock tick
    clock: Option<u64>,
    /// the highest step any state had, and when it first came
    top: Option<(u32, Instant)>,
    /// the swarm's step period: a moving average of the time between the first states of consecutive steps
    period: Option<Duration>,
}

/// Messages to put: (the agent whose inbox, the concatenated records).
pub type Out = Vec<(u32, Vec<u8>)>;

fn remove(list: &mut Vec<u32>, id: u32) {
    if let Some(k) = list.iter().position(|&x| x == id) {
        list.swap_remove(k);
    }
}

impl Inboxes {
    pub fn is_watching(&self, id: u32) -> bool {
        self.watchers.contains_key(&id)
    }

    /// Agent `id` now watches `cells` (its whole set, watch.rs).
    pub fn watch(&mut self, id: u32, cells: Vec<Cell>, now: Instant, out: &mut Out) {
        let w = self.watchers.entry(id).or_default();
        for c in &w.cells {
            if let Some(list) = self.watching.get_mut(c) {
                remove(list, id);
            }
        }
        for &c in &cells {
            self.watching.entry(c).or_default().push(id);
        }
        w.cells = cells;
        self.look(id, now, out);
    }

    /// A state the relay passed on: agent `from`'s step-`step` record, in `cell`.
    pub fn state(&mut self, from: u32, step: u32, cell: Cell, record: &[u8], now: Instant, out: &mut Out) {
        self.time_step(step, now);
        let mut left = None;
        match self.latest.get(&from).copied() {
            Some((_, s)) if step < s => {} // an old state: where the agent was is not where it is
            Some((c, _)) => {
                self.latest.insert(from, (cell, step));
                if c != cell {
                    if let Some(list) = self.members.get_mut(&c) {
                        remove(list, from);
                    }
                    self.members.entry(cell).or_default().push(from);
                    left = Some(c);
                }
            }
            None => {
                self.latest.insert(from, (cell, step));
                self.members.entry(cell).or_default().push(from);
            }
        }
        let to: Vec<u32> =
            self.watching.get(&cell).map(|l| l.iter().copied().filter(|&j| j != from).collect()).unwrap_or_default();
        for j in to {
            self.give(j, from, step, record, now, out);
        }
        if self.held(from) && !self.carries_clock(from) {
            self.send_clock(from, out);
        }
        // It left the cells of those who watch its old cell and not its new one: they no longer wait for it
        if let Some(c) = left {
            let was: Vec<u32> = self.watching.get(&c).cloned().unwrap_or_default();
            for j in was {
                if j != from && !self.watchers.get(&j).is_some_and(|w| w.cells.contains(&cell)) {
                    self.look(j, now, out);
                }
            }
        }
    }

    /// A tick of the launcher's clock: it goes with every message from now on. The groups it held (`holds`)
    /// and now lets step go out with it; alone it goes only to an agent it may hold that has no group to come
    /// (or, at a repetition of the same tick, to each agent still behind it that has none held).
    pub fn clock(&mut self, clock: u64, now: Instant, out: &mut Out) {
        let again = self.clock == Some(clock);
        if self.clock.is_some_and(|c| clock < c) {
            return; // the clock only moves on
        }
        self.clock = Some(clock);
        let ids: Vec<u32> = self.watchers.keys().copied().collect();
        for j in ids {
            let w = &self.watchers[&j];
            if w.held.is_some() {
                if !self.holds(j) {
                    self.watchers.get_mut(&j).expect("listed").held = None;
                    self.look(j, now, out);
                }
                continue;
            }
            let behind = w.clock_sent < clock;
            if ((again && behind) || self.held(j)) && !self.carries_clock(j) {
                self.send_clock(j, out);
            }
        }
    }

    /// Whether the launcher's latest clock keeps agent `j` from its next step (`agent::paced`): its complete
    /// group then waits for the tick that lets it (one wake-up for the group and the tick, not one each: an
    /// agent handed its group while held woke, found itself held, and woke again for the tick alone, ~0.5 of a
    /// wake-up per agent-step at N = 300). Only once a clock came: before the launcher's first tick the agents
    /// are paced from 0 (ctl/start), and a relay that never hears the clock must not hold anything.
    fn holds(&self, j: u32) -> bool {
        let (Some(clock), Some(&(_, step))) = (self.clock, self.latest.get(&j)) else { return false };
        crate::agent::paced(u64::from(step) + 1, clock)
    }

    /// Whether agent `j`'s group of its own latest step is still to go out: the agent waits for it before its
    /// next step, and it will carry the clock.
    fn carries_clock(&self, j: u32) -> bool {
        let w = &self.watchers[&j];
        w.held.is_none() && w.next.is_some() && w.next == self.latest.get(&j).map(|&(_, s)| s)
    }

    /// Whether agent `j` may be waiting for a newer clock than the one it was given: its next step is more than
    /// CLOCK_LEAD ahead of it (`agent::paced`, the agent's own rule), and a newer one is here.
    fn held(&self, j: u32) -> bool {
        let (Some(w), Some(clock)) = (self.watchers.get(&j), self.clock) else { return false };
        let given = w.clock_sent;
        given < clock && self.latest.get(&j).is_some_and(|&(_, step)| crate::agent::paced(u64::from(step) + 1, given))
    }

    fn send_clock(&mut self, j: u32, out: &mut Out) {
        let w = self.watchers.get_mut(&j).expect("a watcher");
        w.clock_sent = self.clock.unwrap_or(0);
        out.push((j, header(self.clock).to_vec()));
    }

    /// The swarm's step period from the first state of each new step (a jump of more than one step, a
    /// rejoin or a late joiner, sets the top without a sample).
    fn time_step(&mut self, step: u32, now: Instant) {
        match self.top {
            Some((top, _)) if step <= top => {}
            Some((top, at)) if step == top + 1 => {
                let sample = now.duration_since(at);
                self.period = Some(self.period.map_or(sample, |p| p.mul_f64(0.8) + sample.mul_f64(0.2)));
                self.top = Some((step, now));
            }
            _ => self.top = Some((step, now)),
        }
    }

    /// How long a group waits for its last state now (INBOX_WAIT's comment): MAX_INBOX_WAIT until a period is
    /// known (the start burst's first steps are the slowest: N = 1000 agents woken at once).
    pub fn wait(&self) -> Duration {
        self.period.map_or(MAX_INBOX_WAIT, |p| p.mul_f64(WAIT_PERIODS).clamp(INBOX_WAIT, MAX_INBOX_WAIT))
    }

    /// The groups that waited their longest (`wait`) go out as they are. The states still missing then come
    /// together once they are all in (a slow neighbour: one more message, not one per state), or at a second
    /// wait, after which the group waits for the step after (a neighbour that stopped: its latest step falls
    /// behind and it is no longer waited for).
    pub fn due(&mut self, now: Instant, out: &mut Out) {
        // A group held for the clock goes out at MAX_INBOX_WAIT without it: the agent, waiting for its
        // neighbours, republishes at a quarter of its 2 s timeout; held by the clock instead it waits without one.
        for j in self.waited(now, MAX_INBOX_WAIT, |w| w.held) {
            self.look_and_send(j, now, out);
        }
        for j in self.waited(now, self.wait(), |w| w.since) {
            let w = self.watchers.get_mut(&j).expect("listed");
            let again = w.overdue;
            flush(j, w, self.clock, out);
            if !again && w.next.is_some() {
                w.overdue = true;
                w.since = Some(now);
            } else if let Some(n) = w.next {
                self.advance(j, n + 1, now, out);
            }
        }
    }

    /// The agents whose group has waited `wait` by `now` since the instant `since` gives.
    fn waited(&self, now: Instant, wait: Duration, since: impl Fn(&Watcher) -> Option<Instant>) -> Vec<u32> {
        let over = |w: &Watcher| since(w).is_some_and(|t| now.duration_since(t) >= wait);
        self.watchers.iter().filter(|(_, w)| over(w)).map(|(&j, _)| j).collect()
    }

    fn give(&mut self, j: u32, from: u32, step: u32, record: &[u8], now: Instant, out: &mut Out) {
        let w = self.watchers.get_mut(&j).expect("a watcher");
        w.buf.extend_from_slice(record);
        let before = w.given.get(&from).copied();
        if before.is_none_or(|b| step > b) {
            w.given.insert(from, step);
        }
        let next = *w.next.get_or_insert(step);
        if w.buf.len() >= MAX_RECORDS * crate::wire::STATE_SIZE {
            flush(j, w, self.clock, out); // a full message
            return;
        }
        if w.held.is_some() {
            return; // it goes with the group, which waits for the clock (its wait is the hold's, not `since`)
        }
        w.since.get_or_insert(now);
        if step < next {
            flush(j, w, self.clock, out); // late (or a republication): the agent waits for it now
            return;
        }
        if before.is_none_or(|b| b < next) {
            w.got += 1;
        }
        if w.got >= w.need {
            self.look(j, now, out);
        }
    }

    /// Whether agent `j`'s group has every state it waits for: then out it goes (or waits for the clock, if
    /// the group is of the agent's latest step and the clock holds it), and the next step's (a neighbour ran
    /// ahead, or `j` was frozen: a loop, not a call per step, however far behind it is).
    fn look(&mut self, j: u32, now: Instant, out: &mut Out) {
        loop {
            let Some(next) = self.watchers.get(&j).and_then(|w| w.next) else { return };
            let (complete, need) = self.complete(j, next);
            let own = self.latest.get(&j).map(|&(_, s)| s);
            let hold = complete && need > 0 && own == Some(next) && self.holds(j);
            let w = self.watchers.get_mut(&j).expect("a watcher");
            w.need = need;
            if hold {
                w.since = None;
                w.held.get_or_insert(now);
                return;
            }
            if !complete {
                if w.since.is_none() && !w.buf.is_empty() {
                    w.since = Some(now); // released by the clock, then a neighbour moved in: it waits anew
                }
                return;
            }
            flush(j, w, self.clock, out);
            if need == 0 {
                // nobody to wait for: the next state sets the step again
                w.next = None;
                w.got = 0;
                return;
            }
            w.wait_for(next + 1);
        }
    }

    /// Agent `j`'s group now waits for step `next`; it may be complete already (a neighbour ran ahead).
    fn advance(&mut self, j: u32, next: u32, now: Instant, out: &mut Out) {
        self.watchers.get_mut(&j).expect("a watcher").wait_for(next);
        // who is waited for changes with the step (an agent left behind no longer is): looked at anew
        self.look(j, now, out);
    }

    /// A held group released without the clock (`due`): out it goes as it is, and the group waits for the
    /// next step.
    fn look_and_send(&mut self, j: u32, now: Instant, out: &mut Out) {
        let w = self.watchers.get_mut(&j).expect("a watcher");
        flush(j, w, self.clock, out);
        if let Some(n) = w.next {
            self.advance(j, n + 1, now, out);
        }
    }

    /// (whether every agent `j` waits for at step `next` was given it, how many it waits for)
    fn complete(&self, j: u32, next: u32) -> (bool, usize) {
        let w = &self.watchers[&j];
        let (mut complete, mut need) = (true, 0);
        for c in &w.cells {
            for &k in self.members.get(c).map(|l| l.as_slice()).unwrap_or_default() {
                let Some(&(_, step)) = self.latest.get(&k) else { continue };
                if k == j || step.saturating_add(1) < next {
                    continue; // itself, or left behind: not waited for
                }
                need += 1;
                complete &= w.given.get(&k).is_some_and(|&s| s >= next);
            }
        }
        (complete, need)
    }
}

fn flush(j: u32, w: &mut Watcher, clock: Option<u64>, out: &mut Out) {
    w.since = None;
    w.overdue = false;
    w.held = None;
    if !w.buf.is_empty() {
        if let Some(c) = clock {
            w.clock_sent = c;
        }
        let mut message = Vec::with_capacity(HEADER + w.buf.len());
        message.extend_from_slice(&header(clock));
        message.append(&mut w.buf);
        out.push((j, message));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(id: u32, step: u32) -> Vec<u8> {
        let mut s = [0.0; crate::sph::NFIELDS];
        s[4] = 1.0;
        crate::wire::encode_state(id, step, &s, 0).to_vec()
    }

    fn ids(out: &Out, to: u32) -> Vec<Vec<(u32, u32)>> {
        out.iter()
            .filter(|(j, _)| *j == to)
            .map(|(_, b)| {
                let (_, records) = parse(b).expect("an inbox message");
                records.chunks(crate::wire::STATE_SIZE).map(|r| crate::wire::peek_id_step(r).unwrap()).collect()
            })
            .collect()
    }

    const CELLS: [(u32, Cell); 3] = [(0, (0, 0)), (1, (1, 0)), (2, (2, 0))];

    /// Agents 0, 1, 2 in cells (0,0), (1,0), (2,0); 0 watches (0,0) and (1,0), 1 all three.
    fn three(t: Instant) -> (Inboxes, Out) {
        let mut ib = Inboxes::default();
        let mut out = Out::new();
        ib.watch(0, vec![(0, 0), (1, 0)], t, &mut out);
        ib.watch(1, vec![(0, 0), (1, 0), (2, 0)], t, &mut out);
        step_all(&mut ib, 0..=0, t, &mut out);
        (ib, out)
    }

    /// Each of the three, in its own cell, publishes every step of `steps`.
    fn step_all(ib: &mut Inboxes, steps: std::ops::RangeInclusive<u32>, t: Instant, out: &mut Out) {
        for s in steps {
            for (k, c) in CELLS {
                ib.state(k, s, c, &rec(k, s), t, out);
            }
        }
    }

    #[test]
    fn a_step_goes_out_in_one_message_once_complete() {
        let t = Instant::now();
        let (mut ib, mut out) = three(t);
        // step 0: nobody was known before, so each state went out as it came; now all are members
        out.clear();
        ib.state(2, 1, (2, 0), &rec(2, 1), t, &mut out);
        assert!(ids(&out, 1).is_empty()); // 1 waits for 0 and 2: 2 is in
        ib.state(0, 1, (0, 0), &rec(0, 1), t, &mut out);
        assert_eq!(ids(&out, 1), vec![vec![(2, 1), (0, 1)]]);
        assert!(ids(&out, 0).is_empty()); // 0 waits for 1
        ib.state(1, 1, (1, 0), &rec(1, 1), t, &mut out);
        assert_eq!(ids(&out, 0), vec![vec![(1, 1)]]);
        assert!(ids(&out, 2).is_empty()); // 2 watches nothing: not an inbox agent
    }

    #[test]
    fn a_silent_agent_is_waited_for_twice_then_no_more_and_a_late_state_goes_at_once() {
        let t = Instant::now();
        let (mut ib, mut out) = three(t);
        step_all(&mut ib, 1..=2, t, &mut out);
        out.clear();
        // 2 falls silent at step 2: agent 1's step-3 group waits INBOX_WAIT, then goes out without it
        ib.state(0, 3, (0, 0), &rec(0, 3), t, &mut out);
        assert!(ids(&out, 1).is_empty());
        ib.due(t + INBOX_WAIT / 2, &mut out);
        assert!(ids(&out, 1).is_empty());
        ib.due(t + INBOX_WAIT, &mut out);
        assert_eq!(ids(&out, 1), vec![vec![(0, 3)]]);
        out.clear();
        // 0 runs on (it does not hear 2): its step 4 waits with the group, which still waits for 2's step 3
        ib.state(0, 4, (0, 0), &rec(0, 4), t + INBOX_WAIT, &mut out);
        ib.due(t + INBOX_WAIT * 3 / 2, &mut out);
        assert!(out.is_empty());
        // a second wait: out it goes, and step 4 no longer waits for 2 (its latest step, 2, is behind)
        ib.due(t + INBOX_WAIT * 2, &mut out);
        assert_eq!(ids(&out, 1), vec![vec![(0, 4)]]);
        out.clear();
        ib.state(0, 5, (0, 0), &rec(0, 5), t + INBOX_WAIT * 2, &mut out);
        assert_eq!(ids(&out, 1), vec![vec![(0, 5)]]);
        out.clear();
        // 2's step-3 state, late: at once
        ib.state(2, 3, (2, 0), &rec(2, 3), t + INBOX_WAIT * 2, &mut out);
        assert_eq!(ids(&out, 1), vec![vec![(2, 3)]]);
    }

    #[test]
    fn what_a_slow_neighbour_still_owes_comes_in_one_message_after_the_wait() {
        let t = Instant::now();
        let (mut ib, mut out) = three(t);
        step_all(&mut ib, 1..=2, t, &mut out);
        out.clear();
        ib.state(0, 3, (0, 0), &rec(0, 3), t, &mut out);
        ib.due(t + INBOX_WAIT, &mut out);
        assert_eq!(ids(&out, 1), vec![vec![(0, 3)]]);
        out.clear();
        // 2 is slow, not silent: 0's step 4 and 2's step 3 go out together once 2's is in (a fixed wait sent
        // each alone: the group moved on to step 4, which no longer waited for 2, and 2's state came late)
        ib.state(0, 4, (0, 0), &rec(0, 4), t + INBOX_WAIT, &mut out);
        assert!(out.is_empty());
        ib.state(2, 3, (2, 0), &rec(2, 3), t + INBOX_WAIT * 5 / 4, &mut out);
        assert_eq!(ids(&out, 1), vec![vec![(0, 4), (2, 3)]]);
        out.clear();
        ib.state(2, 4, (2, 0), &rec(2, 4), t + INBOX_WAIT * 3 / 2, &mut out); // the group of step 4 is complete
        assert_eq!(ids(&out, 1), vec![vec![(2, 4)]]);
    }

    #[test]
    fn the_wait_follows_the_swarms_step_period() {
        let t = Instant::now();
        let (mut ib, mut out) = three(t);
        assert_eq!(ib.wait(), MAX_INBOX_WAIT); // no period yet: the start burst
        let ms = |m: u64| t + Duration::from_millis(m);
        // a slow swarm: a step every 200 ms (N = 1000 on 2 cores)
        for s in 1..=10 {
            for (k, c) in CELLS {
                ib.state(k, s, c, &rec(k, s), ms(200 * u64::from(s)), &mut out);
            }
        }
        assert!((ib.wait().as_millis() as i64 - 300).abs() <= 40, "{:?}", ib.wait());
        out.clear();
        // agent 1's step-11 group: 0's state came, 2's is 150 ms away: not due at 100 ms (the fixed wait was 60)
        ib.state(0, 11, (0, 0), &rec(0, 11), ms(2200), &mut out);
        ib.due(ms(2300), &mut out);
        assert!(ids(&out, 1).is_empty());
        ib.state(2, 11, (2, 0), &rec(2, 11), ms(2350), &mut out);
        assert_eq!(ids(&out, 1), vec![vec![(0, 11), (2, 11)]]); // one message
                                                                // a jump (a rejoin) is no sample; a period never makes the wait longer than MAX_INBOX_WAIT
        ib.state(2, 5_000, (2, 0), &rec(2, 5_000), ms(2400), &mut out);
        assert!(ib.wait() >= INBOX_WAIT && ib.wait() <= MAX_INBOX_WAIT);
        let mut slow = Inboxes::default();
        for s in 0..20 {
            slow.state(0, s, (0, 0), &rec(0, s), t + Duration::from_secs(u64::from(s)), &mut out);
        }
        assert_eq!(slow.wait(), MAX_INBOX_WAIT);
    }

    #[test]
    fn a_neighbour_that_moves_out_is_no_longer_waited_for_and_one_ahead_is_counted() {
        let t = Instant::now();
        let (mut ib, mut out) = three(t);
        out.clear();
        // 1 moves to (5, 0), outside what 0 watches: 0's step-1 group must not wait for it
        ib.state(0, 1, (0, 0), &rec(0, 1), t, &mut out);
        ib.state(2, 1, (2, 0), &rec(2, 1), t, &mut out);
        ib.state(1, 1, (5, 0), &rec(1, 1), t, &mut out);
        // 0 heard nothing of step 1 (1's state is on a cell it does not watch): no message, but no longer waiting
        assert!(ids(&out, 0).is_empty());
        // back, a step ahead: its state of step 2 completes 0's group at once (0 waits for it alone)
        ib.state(1, 2, (1, 0), &rec(1, 2), t, &mut out);
        assert_eq!(ids(&out, 0), vec![vec![(1, 2)]]);
    }

    #[test]
    fn a_group_far_behind_catches_up_in_one_look() {
        let t = Instant::now();
        let (mut ib, mut out) = three(t);
        out.clear();
        // 1 and 2 (agent 1's only other members than 0) ran 100000 steps ahead while the relay waited for 0
        ib.state(2, 100_000, (2, 0), &rec(2, 100_000), t, &mut out);
        ib.state(0, 100_000, (0, 0), &rec(0, 100_000), t, &mut out);
        assert_eq!(ids(&out, 1), vec![vec![(2, 100_000), (0, 100_000)]]);
        out.clear();
        ib.state(0, 100_001, (0, 0), &rec(0, 100_001), t, &mut out); // waits for 2's step 100001 now
        assert!(out.is_empty());
    }

    /// To whom, the clock, the records' (id, step).
    type Sent = (u32, Option<u64>, Vec<(u32, u32)>);

    /// Each message as `Sent`.
    fn sent(out: &Out) -> Vec<Sent> {
        out.iter()
            .map(|(j, m)| {
                let (clock, records) = parse(m).expect("an inbox message");
                let ids = records.chunks(crate::wire::STATE_SIZE).map(|r| crate::wire::peek_id_step(r).unwrap());
                (*j, clock, ids.collect())
            })
            .collect()
    }

    #[test]
    fn a_group_the_clock_holds_goes_out_with_the_tick_that_lets_its_agent_step() {
        let t = Instant::now();
        let (mut ib, mut out) = three(t);
        out.clear();
        ib.clock(0, t, &mut out); // nobody was given a clock: nobody is held by one
        assert!(out.is_empty());
        step_all(&mut ib, 1..=2, t, &mut out); // the groups go out, with the clock
        assert!(sent(&out).iter().all(|(_, c, _)| *c == Some(0)));
        out.clear();
        // step 3: each agent's step 4 is held by clock 0 (4 > 0 + 3), so its complete group waits for a tick
        step_all(&mut ib, 3..=3, t, &mut out);
        assert!(out.is_empty());
        ib.due(t + MAX_INBOX_WAIT / 2, &mut out);
        assert!(out.is_empty());
        ib.clock(1, t, &mut out); // one message each: the tick and the group
        let mut got = sent(&out);
        got.sort();
        assert_eq!(got, [(0, Some(1), vec![(1, 3)]), (1, Some(1), vec![(0, 3), (2, 3)])]);
        out.clear();
        // 0 at 4 is held by 1 (5 > 4): its group of step 4 is still to come, with a later clock
        ib.state(0, 4, (0, 0), &rec(0, 4), t, &mut out);
        ib.clock(2, t, &mut out);
        assert!(out.is_empty()); // nothing alone: 0's group of step 4 will carry clock 2
        ib.state(1, 4, (1, 0), &rec(1, 4), t, &mut out);
        assert_eq!(sent(&out), [(0, Some(2), vec![(1, 4)])]); // clock 2 lets 0 run step 5
        out.clear();
        ib.clock(1, t, &mut out); // an old tick: nothing
        assert!(out.is_empty());
    }

    #[test]
    fn the_clock_goes_alone_only_to_a_held_agent_with_no_group_to_come() {
        let t = Instant::now();
        let mut ib = Inboxes::default();
        let mut out = Out::new();
        ib.watch(3, vec![(9, 9)], t, &mut out); // alone in its cell: no group ever forms
        ib.clock(0, t, &mut out);
        ib.state(3, 0, (9, 9), &rec(3, 0), t, &mut out);
        assert!(out.is_empty()); // given no clock yet (0 from ctl/start) and not held by it
        for s in 1..=3 {
            ib.state(3, s, (9, 9), &rec(3, s), t, &mut out);
        }
        assert!(out.is_empty()); // at 3 its step 4 is held by 0, and a newer clock is not here yet
        ib.clock(1, t, &mut out);
        assert_eq!(sent(&out), [(3, Some(1), vec![])]);
        out.clear();
        ib.clock(1, t, &mut out); // the once-a-second repetition: it has it
        assert!(out.is_empty());
        ib.state(3, 4, (9, 9), &rec(3, 4), t, &mut out); // held by 1 again (5 > 4): clock 2 alone at once
        ib.clock(2, t, &mut out);
        assert_eq!(sent(&out), [(3, Some(2), vec![])]);
    }

    #[test]
    fn a_group_held_for_a_clock_that_does_not_come_goes_out_without_it() {
        let t = Instant::now();
        let (mut ib, mut out) = three(t);
        ib.clock(0, t, &mut out);
        step_all(&mut ib, 1..=3, t, &mut out);
        out.clear();
        ib.due(t + MAX_INBOX_WAIT, &mut out); // the agents republish at 0.5 s: they get their groups at 0.4 s
        let mut got = sent(&out);
        got.sort();
        assert_eq!(got, [(0, Some(0), vec![(1, 3)]), (1, Some(0), vec![(0, 3), (2, 3)])]);
        out.clear();
        ib.clock(1, t, &mut out); // then the tick goes alone: their next groups wait for their own step 4
        let mut to: Vec<u32> = sent(&out)
            .iter()
            .map(|(j, c, r)| {
                assert!(*c == Some(1) && r.is_empty());
                *j
            })
            .collect();
        to.sort();
        assert_eq!(to, [0, 1]);
    }

    #[test]
    fn a_first_clock_after_the_lead_reaches_every_agent_it_holds() {
        // The launcher ticks once it has seen states: its first tick can come when every group of step 3 went
        // out without a clock. ctl/start paced the agents from clock 0, so at step 4 each is held by 0.
        let t = Instant::now();
        let (mut ib, mut out) = three(t);
        step_all(&mut ib, 1..=3, t, &mut out);
        out.clear();
        ib.clock(3, t, &mut out);
        assert!(out.iter().all(|(_, m)| parse(m) == Some((Some(3), &[][..]))));
        let mut to: Vec<u32> = out.iter().map(|(j, _)| *j).collect();
        to.sort();
        assert_eq!(to, [0, 1]); // the watchers (2 watches nobody: `three`)
    }

    #[test]
    fn an_inbox_message_is_parsed_or_refused_whole() {
        let mut m = header(Some(9)).to_vec();
        m.extend(rec(1, 2));
        assert_eq!(parse(&m), Some((Some(9), &rec(1, 2)[..])));
        assert_eq!(parse(&header(None)), Some((None, &[][..])));
        assert_eq!(parse(&m[..m.len() - 1]), None); // not whole records
        assert_eq!(parse(&m[..10]), None);
        for (at, bad) in [(0, 2), (1, 1), (2, 2), (5, 1)] {
            let mut b = m.clone();
            b[at] = bad;
            assert_eq!(parse(&b), None, "byte {at}");
        }
        let mut big = header(None).to_vec();
        big.extend(std::iter::repeat_n(rec(1, 1), MAX_RECORDS + 1).flatten());
        assert_eq!(parse(&big), None);
    }

    #[test]
    fn watching_anew_changes_what_is_waited_for() {
        let t = Instant::now();
        let (mut ib, mut out) = three(t);
        out.clear();
        ib.watch(0, vec![(0, 0)], t, &mut out); // 0 no longer hears 1
        ib.state(1, 1, (1, 0), &rec(1, 1), t, &mut out);
        assert!(ids(&out, 0).is_empty());
        assert!(!ib.is_watching(2) && ib.is_watching(0));
    }
}
