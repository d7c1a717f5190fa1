//! Lockstep's wait: the agents whose step-m state this agent must have before it computes step m+1, and the
//! wait for them (republishing, neighbour timeouts, the start burst).

use rustc_hash::FxHashSet as HashSet;

use super::{AgentCore, Lock, Phase, Waiting, Wake, LAG_WAIT_STEPS, SLICE, START_BURST_STEPS, START_BURST_TIMEOUT};
use crate::event::{EventKind, Sighting};
use crate::keys;
use crate::sph::{X, Y};

impl AgentCore {
    /// Agents whose step-m state this agent must wait for (docs/protocol.md, "Expected agents").
    ///
    /// A sighting k steps old (k = m - its step >= 1) can have moved k v_max dt since, so it is expected
    /// within 2h + (k + 2) v_max dt: R_expect for k = 1, wider for a lagging neighbour. R_expect whatever the
    /// age (the retired Python agent's rule) lost exactness under load (issue 14, defect (a)): a particle up to
    /// CLOCK_LEAD steps ahead of its group judged a neighbour by a sighting 3-4 steps old, did not wait for
    /// it, and the neighbour then reached its support at that step.
    pub(super) fn expected(&mut self, now: f64) -> HashSet<u32> {
        let (x, y) = (self.state[X], self.state[Y]);
        let d = self.params.max_step_displacement();
        let base = self.params.support();
        let recent = self.step as i64 - 1;
        let mut out = HashSet::default();
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
                let lately = self.heard_at.get(&j).is_some_and(|t| now - t < self.spec.timeout);
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

    /// The wait of a step that begins now, for `expected`.
    pub(super) fn begin_wait(&self, now: f64, expected: HashSet<u32>) -> Waiting {
        // The first steps follow the start barrier: every expected agent is up (or reported gone by ctl/gone),
        // only the start burst (N agents woken at once, their first routes computed) delays them — beyond the
        // 2 s timeout at N = 1000 (hundreds of neighbour timeouts at steps 0-2, none later).
        let burst = self.step < START_BURST_STEPS && !self.spec.join;
        let timeout = if burst { self.spec.timeout.max(START_BURST_TIMEOUT) } else { self.spec.timeout };
        // Republished at the normal pace even in the start burst: a neighbour that lost our state (drop-out)
        // must not wait a quarter of the longer burst timeout.
        let resend_every = self.spec.timeout / 4.0;
        // A neighbour still heard (it republishes every timeout/4 while it waits itself) is alive but held up
        // by its own silent neighbour: dropping it too cascaded the timeout one hop per step (measured: 30
        // agents, two frozen, 10 agents timed out on agents that were only waiting, and those steps lost
        // exactness). So only a neighbour *silent* for the timeout is dropped at the deadline; a heard one is
        // waited for until `cap`.
        Waiting {
            expected,
            began: now,
            deadline: now + timeout,
            cap: now + 2.0 * timeout,
            given_up: HashSet::default(),
            resend_at: now + resend_every,
            resend_every,
        }
    }

    /// One look at the wait: Some(next phase) when it is over (the step computed, or a rejoin due), else a
    /// Sleep queued until the next republication, the deadline or the last missing state.
    pub(super) fn wait(&mut self, now: f64, mut w: Waiting) -> Option<Phase> {
        if self.behind {
            return Some(Phase::Lockstep(Lock::Top)); // the swarm went on: rejoin it (no timeout to wait out)
        }
        let step = self.step;
        let have = self.buffer.get(&step);
        let present = |j: &u32| have.is_some_and(|h| h.contains_key(j));
        // A neighbour heard at a later step has moved on: its state of this step was lost (one publisher's
        // messages arrive in order), so waiting for it would only cost the timeout.
        let mut missing: HashSet<u32> = w
            .expected
            .iter()
            .copied()
            .filter(|j| {
                !present(j)
                    && !self.dead.contains(j)
                    && !w.given_up.contains(j)
                    && self.latest.get(j).is_none_or(|l| l.0 <= step as i64)
            })
            .collect();
        if missing.is_empty() {
            let lost =
                w.expected.iter().filter(|j| !present(j) && !self.dead.contains(j) && !w.given_up.contains(j)).count();
            self.counters.lost += lost as u64;
            self.finish_step(now);
            return Some(Phase::Lockstep(Lock::Top));
        }
        if now >= w.resend_at {
            // Lossy links: say it again while waiting (a neighbour that missed our state waits too).
            self.publish();
            w.resend_at = now + w.resend_every;
        }
        if now >= w.deadline {
            // Silent: not heard since the wait began, or not for the timeout (it froze while we waited).
            let (began, silence) = (w.began, self.spec.timeout);
            let silent = |j: &u32| self.heard_at.get(j).is_none_or(|&t| t <= began || now - t >= silence);
            let mut ids: Vec<u32> = missing.iter().copied().filter(|j| now >= w.cap || silent(j)).collect();
            ids.sort_unstable();
            // What the agent knew of each: last sighting's step, its distance, whether its cell is watched
            let mut seen = Vec::new();
            for j in &ids {
                if let Some((s, jx, jy)) = self.latest.remove(j) {
                    let dist = (jx - self.state[X]).hypot(jy - self.state[Y]);
                    let watched = !jx.is_nan() && self.cells.contains(&keys::cell_of(jx, jy, self.cell));
                    seen.push(Sighting { agent: *j, step: s, distance: dist.is_finite().then_some(dist), watched });
                }
                self.counters.timeouts += 1;
            }
            if !ids.is_empty() {
                missing.retain(|j| !ids.contains(j));
                w.given_up.extend(ids.iter().copied());
                self.event(EventKind::NeighbourTimeout { neighbours: ids, last_seen: Some(seen) });
            }
            if missing.is_empty() {
                self.finish_step(now);
                return Some(Phase::Lockstep(Lock::Top));
            }
        }
        // Past the deadline, the heard neighbours are watched until they deliver, fall silent or `cap`.
        let next = if now >= w.deadline { w.cap } else { w.deadline };
        let until = next.min(w.resend_at).min(now + SLICE);
        let mut awaited: Vec<u32> = missing.into_iter().collect();
        awaited.sort_unstable();
        self.phase = Phase::Lockstep(Lock::Waiting(w));
        self.sleep(until, Wake { step, awaited, ..Wake::default() });
        None
    }
}
