//! The state keys on the bus: the cell subscribers an agent watches, the neighbours' sender keys it declares,
//! the key of its own cell and the put of its state (docs/protocol.md, docs/security.md).

use std::collections::HashSet;
use std::sync::Arc;

use zenoh::qos::CongestionControl;
use zenoh::sample::Locality;
use zenoh::Wait;

use super::{zerr, Agent};
use crate::keys;
use crate::sph::{X, Y};
use crate::wire;

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

impl Agent {
    /// The id a state key of agent `id` carries: Some(id) with ids in the state keys, None with cell keys.
    pub(super) fn key_id_of(&self, id: u32) -> Option<u32> {
        self.spec.state_key_ids.then_some(id)
    }


    pub(super) fn update_subscriptions(&mut self) -> Result<(), String> {
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
    pub(super) fn note_sender(&mut self, j: u32, x: f64, y: f64) {
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

    pub(super) fn publish(&mut self) {
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
    pub(super) fn declare_publisher(&mut self) {
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
}
