//! The state bus (docs/protocol.md, "Key expressions"). Under per-process rights (the spec's
//! `state_key_ids`, access level `acl`) the id layout, here: the agent's own state key and `where` token, the
//! blocks of `where` tokens it watches, and the neighbours' state keys it subscribes to. Otherwise the cell
//! layout (cell_bus.rs).
//!
//! In the id layout every key an agent publishes carries its id (the router's access control then lets it
//! publish only its own, docs/security.md), and every key it receives on is exact and declared: zenoh routes
//! each state by a cached route and dispatches it by a table look-up. Who is near is learnt from liveliness
//! tokens, which change only when an agent changes cells, not from the states themselves.

use std::collections::HashSet;
use std::sync::Arc;

use zenoh::key_expr::KeyExpr;
use zenoh::pubsub::Subscriber;
use zenoh::qos::CongestionControl;
use zenoh::sample::{Locality, SampleKind};
use zenoh::{Session, Wait};

use super::inbox::Msg;
use super::{zerr, Agent};
use crate::keys;
use crate::sph::{X, Y};
use crate::wire;

/// A neighbour that no longer qualifies keeps its state subscription this many steps: an agent that
/// finishes has its tokens' deletion delivered before its last states (declarations travel first), and
/// neighbours a few steps behind need those states.
const UNSUBSCRIBE_AFTER: u32 = 8;
/// An agent's `where` token stays in its cell until it is this far (in cells) outside it: a particle
/// jittering on a cell edge would otherwise move its token every few steps, and every token change is
/// matched against every watcher's interest in the router. Receivers widen their radii by as much.
pub(super) const WHERE_SLACK: f64 = 0.25;

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

/// A neighbour's state subscription: the subscriber, its declared key, the last step it qualified.
pub(super) struct StateSub {
    sub: Option<Subscriber<()>>,
    key: Option<KeyExpr<'static>>,
    since: u32,
}

impl StateSub {
    /// The subscriber before its key (zenoh undeclares a key only once nothing uses it).
    fn close(&mut self, session: &Session) {
        drop(self.sub.take());
        if let Some(key) = self.key.take() {
            let _ = session.undeclare(key).wait();
        }
    }
}

impl Agent {
    /// The id a state key of agent `id` carries: Some(id) in the id layout, None with cell keys.
    pub(super) fn key_id_of(&self, id: u32) -> Option<u32> {
        self.spec.state_key_ids.then_some(id)
    }

    /// Undeclare every state subscription and watched block (the end of the run).
    pub(super) fn close_state_bus(&mut self) {
        self.cell_subs.clear();
        for sub in self.state_subs.values_mut() {
            sub.close(&self.session);
        }
        self.state_subs.clear();
        self.blocks.clear();
    }

    /// After every step (before the next state goes out): move the `where` token, watch the blocks around,
    /// subscribe to the states of the agents whose cell is within R_sub, drop the far ones.
    pub(super) fn update_subscriptions(&mut self) -> Result<(), String> {
        if !self.spec.state_key_ids {
            return self.update_cell_subscriptions();
        }
        self.move_where_token()?;
        self.watch_blocks()?;
        self.follow_residents()
    }

    /// The new cell's token is declared before the old one goes, so watchers never lose sight of us; it is
    /// declared before any state from the new cell is put (one session's messages stay in order).
    fn move_where_token(&mut self) -> Result<(), String> {
        let (x, y) = (self.state[X], self.state[Y]);
        if self.where_token.as_ref().is_some_and(|(wc, _)| keys::cell_distance(x, y, *wc, self.cell) <= WHERE_SLACK * self.cell) {
            return Ok(());
        }
        let c = keys::cell_of(x, y, self.cell);
        let key = keys::where_key(&self.spec.run, c, self.spec.id);
        let token = self.session.liveliness().declare_token(key).wait().map_err(zerr)?;
        if let Some((_, old)) = self.where_token.replace((c, token)) {
            let _ = old.undeclare().wait();
        }
        Ok(())
    }

    /// Liveliness subscribers, with history, on the blocks within R_watch (dropped beyond R_watch + h/2).
    fn watch_blocks(&mut self) -> Result<(), String> {
        let (x, y) = (self.state[X], self.state[Y]);
        let span = self.cell * keys::BLOCK as f64;
        let keep = self.r_watch + 0.5 * self.cell;
        let before = self.blocks.len();
        // covering_cells' own test, without building the set on every step
        self.blocks.retain(|b, _| keys::cell_distance2(x, y, *b, span) <= keep * keep);
        let mut changed = self.blocks.len() != before;
        for b in keys::covering_cells(x, y, self.r_watch, span) {
            if self.blocks.contains_key(&b) {
                continue;
            }
            let (shared, run) = (Arc::clone(&self.shared), self.spec.run.clone());
            let sub = self
                .session
                .liveliness()
                .declare_subscriber(keys::where_expr(&run, b))
                .history(true)
                .callback(move |sample| {
                    // Exact keys only: a token on a wildcard key reaches this subscriber too.
                    if let Some((c, j)) = keys::where_of(&run, sample.key_expr().as_str()) {
                        shared.push_quiet(Msg::Where(c, j, sample.kind() == SampleKind::Put));
                    }
                })
                .wait()
                .map_err(zerr)?;
            self.blocks.insert(b, sub);
            changed = true;
        }
        if !changed {
            return Ok(());
        }
        // Tokens of blocks no longer watched are no longer heard of (nor are the spec's seeds outside them).
        let blocks = &self.blocks;
        self.residents.retain(|_, cells| {
            cells.retain(|c| blocks.contains_key(&keys::block_of(*c)));
            !cells.is_empty()
        });
        Ok(())
    }

    /// A `where` token appeared or went: agent `j` is (no longer) in cell `c`.
    pub(super) fn note_where(&mut self, c: (i64, i64), j: u32, present: bool) {
        if j == self.spec.id || !self.blocks.contains_key(&keys::block_of(c)) {
            return; // a late event of a block no longer watched
        }
        let cells = self.residents.entry(j).or_default();
        if present {
            if !cells.contains(&c) {
                cells.push(c);
            }
        } else {
            cells.retain(|k| *k != c);
        }
        if cells.is_empty() {
            self.residents.remove(&j);
        } else if present && !self.state_subs.contains_key(&j) && !self.dead.contains(&j) && self.within(c, self.r_sub_cell) {
            // Now, not after the step: the sooner the router knows, the fewer of its states are missed.
            if let Err(e) = self.subscribe_state(j) {
                eprintln!("fluidswarm agent {}: subscription failed: {e}", self.spec.id);
            }
        }
    }

    fn within(&self, c: (i64, i64), radius: f64) -> bool {
        keys::cell_distance2(self.state[X], self.state[Y], c, self.cell) <= radius * radius
    }

    /// Subscribed: every agent with a token in a cell within R_sub (+ WHERE_SLACK: the token's cell is where
    /// the agent was, give or take the slack). Kept while its cell or its latest sighting is within R_keep,
    /// then UNSUBSCRIBE_AFTER steps more.
    fn follow_residents(&mut self) -> Result<(), String> {
        let mut near = Vec::new();
        let mut kept = HashSet::new();
        for (&j, cells) in &self.residents {
            if self.dead.contains(&j) {
                continue;
            }
            if cells.iter().any(|&c| self.within(c, self.r_sub_cell)) {
                near.push(j);
            } else if cells.iter().any(|&c| self.within(c, self.r_keep_cell)) {
                kept.insert(j);
            }
        }
        for j in near {
            if !self.state_subs.contains_key(&j) {
                self.subscribe_state(j)?;
            }
            kept.insert(j);
        }
        let (x, y, step, r_keep) = (self.state[X], self.state[Y], self.step, self.r_keep);
        let (latest, dead, session) = (&self.latest, &self.dead, &self.session);
        self.state_subs.retain(|j, sub| {
            let seen = latest.get(j).is_some_and(|&(_, jx, jy)| (jx - x) * (jx - x) + (jy - y) * (jy - y) <= r_keep * r_keep);
            if (kept.contains(j) || seen) && !dead.contains(j) {
                sub.since = step;
            }
            let keep = step.saturating_sub(sub.since) < UNSUBSCRIBE_AFTER;
            if !keep {
                sub.close(session);
            }
            keep
        });
        Ok(())
    }

    /// Subscribe to agent `j`'s state key, declared first so the router sends its states with our numeric id.
    pub(super) fn subscribe_state(&mut self, j: u32) -> Result<(), String> {
        let key = keys::state_key(&self.spec.run, j);
        let key_decl = self.session.declare_keyexpr(key.clone()).wait().map_err(zerr)?;
        let shared = Arc::clone(&self.shared);
        let sub = self
            .session
            .declare_subscriber(key_decl.clone())
            .callback(move |sample| {
                // A put on a wildcard key (`…/state/*`) reaches this subscriber too: it names no sender. A
                // comparison with our exact key, not a parse of it: this runs for every state received.
                let key_id = (sample.key_expr().as_str() == key).then_some(j);
                shared.push_state(sample.payload().to_bytes().into_owned(), key_id)
            })
            .wait()
            .map_err(zerr)?;
        self.state_subs.insert(j, StateSub { sub: Some(sub), key: Some(key_decl), since: self.step });
        Ok(())
    }

    pub(super) fn publish(&mut self) {
        if self.spec.drop_out > 0.0 && self.random() < self.spec.drop_out {
            self.counters.dropped_out += 1;
            return;
        }
        let class = self.controller.as_ref().map_or(0, |c| c.particle_class());
        let record = wire::encode_state(self.spec.id, self.step, &self.state, class);
        let key = if self.spec.state_key_ids { self.state_key.clone() } else { self.cell_publish_key() };
        if let Some(key) = key {
            let _ = self
                .session
                .put(key, record.to_vec())
                .congestion_control(self.tuning.congestion)
                .express(self.tuning.express)
                // In the cell layout our own cell's subscriber would otherwise get our state back
                .allowed_destination(Locality::Remote)
                .wait();
        }
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
    pub(super) fn declare_state_key(&mut self) -> Result<(), String> {
        if !self.spec.state_key_ids {
            return Ok(()); // the cell layout declares a key per cell as it goes (cell_publish_key)
        }
        let key = self.session.declare_keyexpr(keys::state_key(&self.spec.run, self.spec.id)).wait().map_err(zerr)?;
        let sub = self.session.declare_subscriber(key.clone()).callback(|_| {}).wait().map_err(zerr)?;
        self._fixed.push(sub); // held for the run, like the ctl and command subscribers
        self.state_key = Some(key);
        Ok(())
    }
}
