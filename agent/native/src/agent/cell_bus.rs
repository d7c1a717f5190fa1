//! The cells an agent hears states on (docs/protocol.md): one exact key per cell, `state/<cx>/<cy>`, the id
//! only in the record. An agent subscribes to every cell within R_sub. Cheapest for zenoh 1.10: one cached
//! route per cell, and nothing to learn about who is near (the cells are where they are). Who may put on a
//! cell key: every agent at access levels without per-process rights; only the launcher's relay under them
//! (state_bus.rs).

use std::sync::Arc;

use zenoh::Wait;

use super::{zerr, Agent};
use crate::keys;
use crate::sph::{X, Y};

impl Agent {
    /// Subscribe to the cells within R_sub, drop those beyond R_keep (hysteresis).
    pub(super) fn update_cell_subscriptions(&mut self) -> Result<(), String> {
        let (x, y) = (self.state[X], self.state[Y]);
        // covering_cells' own test, without building the set on every step
        let (keep, cell) = (self.r_keep, self.cell);
        let gone: Vec<(i64, i64)> =
            self.cell_subs.keys().filter(|c| keys::cell_distance2(x, y, **c, cell) > keep * keep).copied().collect();
        for c in gone {
            if let Some((sub, key)) = self.cell_subs.remove(&c) {
                drop(sub); // undeclares the subscription before its key
                let _ = self.session.undeclare(key).wait();
            }
        }
        for c in keys::covering_cells(x, y, self.r_sub, self.cell) {
            if !self.cell_subs.contains_key(&c) {
                let shared = Arc::clone(&self.shared);
                let exact = keys::cell_key(&self.spec.run, c);
                // Declared first: the router then sends the cell's states with our numeric id for the key.
                let key = self.session.declare_keyexpr(exact.clone()).wait().map_err(zerr)?;
                let sub = self
                    .session
                    .declare_subscriber(key.clone())
                    .callback(move |sample| {
                        // A put on a wildcard key (`…/state/**`) reaches this subscriber too, and the router's
                        // deny rules cannot name every wildcard (docs/security.md): only the exact key vouches.
                        let on_key = sample.key_expr().as_str() == exact;
                        shared.push_state(sample.payload().to_bytes().into_owned(), on_key)
                    })
                    .wait()
                    .map_err(zerr)?;
                self.cell_subs.insert(c, (sub, key));
            }
        }
        Ok(())
    }

    /// The declared key of our current cell (a numeric id on the link), re-declared on entering a cell: where
    /// we put our state without per-process rights.
    pub(super) fn cell_publish_key(&mut self) -> Option<zenoh::key_expr::KeyExpr<'static>> {
        let c = keys::cell_of(self.state[X], self.state[Y], self.cell);
        if self.cell_publisher.as_ref().map(|(pc, _)| *pc) != Some(c) {
            if let Some((_, old)) = self.cell_publisher.take() {
                let _ = self.session.undeclare(old).wait();
            }
            if let Ok(key) = self.session.declare_keyexpr(keys::cell_key(&self.spec.run, c)).wait() {
                self.cell_publisher = Some((c, key));
            }
        }
        self.cell_publisher.as_ref().map(|(_, k)| k.clone())
    }
}
