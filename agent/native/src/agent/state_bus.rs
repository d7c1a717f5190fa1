//! The state bus (docs/protocol.md, "Key expressions"): where an agent puts its state and where it hears its
//! neighbours'. It always hears them on exact cell keys (cell_bus.rs). Under per-process rights (the spec's
//! `state_key_ids`, access level `acl`) it puts its state on its own id key, which the router's access control
//! lets no one else use, and the launcher's relay (agent/relay.py), having checked the record's id against the
//! key's, puts it on the cell key of its position (agents may not put cell keys there). Otherwise it puts its
//! state on its cell's key itself.

use zenoh::qos::CongestionControl;
use zenoh::sample::Locality;
use zenoh::Wait;

use super::{zerr, Agent};
use crate::keys;
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
    /// Undeclare every state subscription (the end of the run).
    pub(super) fn close_state_bus(&mut self) {
        self.cell_subs.clear();
    }

    /// After every step (before the next state goes out): the cells within R_sub.
    pub(super) fn update_subscriptions(&mut self) -> Result<(), String> {
        self.update_cell_subscriptions()
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
                // Our own cell's subscriber would otherwise get our state back (under per-process rights the
                // relay's copy on our cell still comes back; receive.rs drops our own id)
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
