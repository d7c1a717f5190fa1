//! What the shell keeps between two runs of the core: the inputs that arrived, and what the core's last
//! `Sleep` said should cut it short (`Wake`). No lock and no thread here: the shell (shell.rs) holds it under
//! its one mutex. `push` says whether the core should run now; zenoh's receiving thread then runs it itself
//! (one wake-up per lockstep step, not one per message and none handed to another thread).

use rustc_hash::FxHashSet as HashSet;
use std::collections::VecDeque;

use crate::agent::{Input, Wake};
use crate::wire;

#[derive(Default)]
pub struct Inbox {
    inputs: VecDeque<Input>,
    /// ids whose `await_step` state the core waits for; the core runs when it empties
    awaited: HashSet<u32>,
    await_step: u32,
    wake_on_state: bool,
    wake_on_clock: bool,
}

impl Inbox {
    /// Queue a control or command message; true if the core should run now. Clock ticks come at 50 Hz: they
    /// run the core only while it is paced; everything else always does.
    pub fn push(&mut self, input: Input, is_clock: bool) -> bool {
        self.inputs.push_back(input);
        !is_clock || self.wake_on_clock
    }

    /// Queue a state record; true if the core should run now (the last awaited state, or any while it asked
    /// for any).
    pub fn push_state(&mut self, record: Vec<u8>, on_key: bool) -> bool {
        let mut ring = self.wake_on_state;
        if !self.awaited.is_empty() {
            // A hint only: the core validates the record itself.
            if let Some((j, step)) = wire::peek_id_step(&record) {
                if step >= self.await_step && self.awaited.remove(&j) && self.awaited.is_empty() {
                    ring = true;
                }
            }
        }
        self.inputs.push_back(Input::State { record, on_key });
        ring
    }

    /// What the core's latest `Sleep` waits for.
    pub fn expect(&mut self, wake: &Wake) {
        self.awaited = wake.awaited.iter().copied().collect();
        self.await_step = wake.step;
        self.wake_on_state = wake.on_state;
        self.wake_on_clock = wake.on_clock;
    }

    /// Everything queued, for a run of the core (which then says anew what to wait for).
    pub fn take(&mut self) -> Vec<Input> {
        self.awaited.clear();
        self.wake_on_state = false;
        self.wake_on_clock = false;
        self.inputs.drain(..).collect()
    }
}
