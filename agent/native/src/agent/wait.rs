//! Lockstep's wait: the agents whose step-m state this agent must have before it computes step m+1, and the
//! wait for them (republishing, neighbour timeouts, the start burst).

use std::collections::HashSet;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::{Agent, Halt, LAG_WAIT_STEPS, START_BURST_STEPS, START_BURST_TIMEOUT, STOP};
use crate::event::{EventKind, Sighting};
use crate::keys;
use crate::sph::{X, Y};

impl Agent {
    /// Agents whose step-m state this agent must wait for (docs/protocol.md, "Expected agents").
    ///
    /// A sighting k steps old (k = m - its step >= 1) can have moved k v_max dt since, so it is expected
    /// within 2h + (k + 2) v_max dt: R_expect for k = 1, wider for a lagging neighbour. The Python agent used
    /// R_expect whatever the age, which lost exactness under load (issue 14, defect (a)): a particle up to
    /// CLOCK_LEAD steps ahead of its group judged a neighbour by a sighting 3-4 steps old, did not wait for
    /// it, and the neighbour then reached its support at that step.
    pub(super) fn expected(&mut self) -> HashSet<u32> {
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

    pub(super) fn wait_for(&mut self, expected: &HashSet<u32>) -> Result<(), Halt> {
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
        // A neighbour still heard (it republishes every timeout/4 while it waits itself) is alive but held up
        // by its own silent neighbour: dropping it too cascaded the timeout one hop per step (measured: 30
        // agents, two frozen, 10 agents timed out on agents that were only waiting, the swarm stalled 2.18 s
        // for a 1.5 s timeout under load, and those steps lost exactness). So only a neighbour *silent* for
        // the timeout is dropped at the deadline; a heard one is waited for until `cap`.
        let cap = start + Duration::from_secs_f64(2.0 * timeout);
        let silence = Duration::from_secs_f64(self.spec.timeout);
        let mut given_up: HashSet<u32> = HashSet::new();
        // Republished at the normal pace even in the start burst: a neighbour that lost our state (drop-out)
        // must not wait a quarter of the longer burst timeout.
        let resend_every = Duration::from_secs_f64(self.spec.timeout / 4.0);
        let mut resend_at = start + resend_every;
        loop {
            self.drain(0.0)?;
            if self.behind {
                return Ok(()); // the swarm went on: the step loop rejoins it (no timeout to wait out)
            }
            let step = self.step;
            let have = self.buffer.get(&step);
            let present = |j: &u32| have.is_some_and(|h| h.contains_key(j));
            // A neighbour heard at a later step has moved on: its state of this step was lost (one
            // publisher's messages arrive in order), so waiting for it would only cost the timeout.
            let missing: HashSet<u32> = expected
                .iter()
                .copied()
                .filter(|j| {
                    !present(j)
                        && !self.dead.contains(j)
                        && !given_up.contains(j)
                        && self.latest.get(j).is_none_or(|l| l.0 <= step as i64)
                })
                .collect();
            if missing.is_empty() {
                let lost =
                    expected.iter().filter(|j| !present(j) && !self.dead.contains(j) && !given_up.contains(j)).count();
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
                let silent = |j: &u32| self.heard_at.get(j).is_none_or(|t| now.duration_since(*t) >= silence);
                let mut ids: Vec<u32> = missing.iter().copied().filter(|j| now >= cap || silent(j)).collect();
                ids.sort_unstable();
                // What the agent knew of each: last sighting's step, its distance, whether its cell is watched
                let mut seen = Vec::new();
                for j in &ids {
                    if let Some((s, jx, jy)) = self.latest.remove(j) {
                        let dist = (jx - self.state[X]).hypot(jy - self.state[Y]);
                        let watched = !jx.is_nan() && self.cell_subs.contains_key(&keys::cell_of(jx, jy, self.cell));
                        seen.push(Sighting { agent: *j, step: s, distance: dist.is_finite().then_some(dist), watched });
                    }
                    self.counters.timeouts += 1;
                }
                if !ids.is_empty() {
                    given_up.extend(ids.iter().copied());
                    self.event(EventKind::NeighbourTimeout { neighbours: ids, last_seen: Some(seen) });
                }
                if missing.iter().all(|j| given_up.contains(j)) {
                    return Ok(());
                }
            }
            let missing: HashSet<u32> = missing.into_iter().filter(|j| !given_up.contains(j)).collect();
            // Arm the bell: the receiving thread rings when the last of `missing` has been heard.
            let shared = Arc::clone(&self.shared);
            let mut inbox = shared.inbox.lock().unwrap_or_else(|e| e.into_inner());
            inbox.await_step = step;
            inbox.awaited = missing;
            if !inbox.queue.is_empty() {
                continue;
            }
            // Past the deadline, the heard neighbours are watched until they deliver, fall silent or `cap`.
            let next = if now >= deadline { cap } else { deadline };
            let slice = next.min(resend_at).saturating_duration_since(now).min(Duration::from_millis(250));
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
}
