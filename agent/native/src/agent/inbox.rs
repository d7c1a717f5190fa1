//! The agent's inbox: Zenoh's receiving threads queue raw messages here and ring the main thread only when
//! it has something to do; the main thread drains the queue. Also the fixed (ctl, command) subscribers.

use std::collections::{HashSet, VecDeque};
use std::sync::atomic::Ordering;
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use zenoh::Wait;

use super::{zerr, Agent, Halt, STOP};
use crate::keys;
use crate::wire;

pub(super) enum Msg {
    /// a state record, and whether it came on exactly the cell key we subscribed to (not a wildcard put)
    State(Vec<u8>, bool),
    Gone(u32),
    Ctl(String, Vec<u8>),
    Command(Vec<u8>),
}

#[derive(Default)]
pub(super) struct Inbox {
    pub(super) queue: VecDeque<Msg>,
    /// ids whose `await_step` state the main thread waits for; the callback rings when it empties
    pub(super) awaited: HashSet<u32>,
    pub(super) await_step: u32,
    pub(super) wake_on_state: bool,
    /// pacing: the main thread waits for the launcher's clock to move on
    pub(super) wake_on_clock: bool,
    pub(super) rung: bool,
}

#[derive(Default)]
pub(super) struct Shared {
    pub(super) inbox: Mutex<Inbox>,
    pub(super) bell: Condvar,
}

impl Shared {
    /// Queue a control, liveliness or command message. Clock ticks come at 50 Hz: they wake the main thread
    /// only while it waits for the clock (`wake_on_clock`); everything else always wakes it.
    pub(super) fn push(&self, msg: Msg, is_clock: bool) {
        let mut inbox = self.inbox.lock().unwrap_or_else(|e| e.into_inner());
        inbox.queue.push_back(msg);
        if !is_clock || inbox.wake_on_clock {
            inbox.rung = true;
            self.bell.notify_one();
        }
    }

    pub(super) fn push_state(&self, data: Vec<u8>, on_key: bool) {
        let mut inbox = self.inbox.lock().unwrap_or_else(|e| e.into_inner());
        let mut ring = inbox.wake_on_state;
        if !inbox.awaited.is_empty() {
            // A hint only: the main thread validates the record itself.
            if let Some((j, step)) = wire::peek_id_step(&data) {
                if step >= inbox.await_step && inbox.awaited.remove(&j) && inbox.awaited.is_empty() {
                    ring = true;
                }
            }
        }
        inbox.queue.push_back(Msg::State(data, on_key));
        if ring {
            inbox.rung = true;
            self.bell.notify_one();
        }
    }
}

impl Agent {
    /// Handle queued messages; with none queued, sleep up to `timeout` or until a callback rings.
    pub(super) fn drain(&mut self, timeout: f64) -> Result<bool, Halt> {
        if STOP.load(Ordering::Relaxed) {
            return Err(Halt::Stop);
        }
        // Called at least every 0.25 s while the agent runs: a longer gap is a freeze (receive.rs: rejoining)
        let now = Instant::now();
        if now.saturating_duration_since(self.awake_at).as_secs_f64() > self.spec.timeout {
            self.resumed_at = Some(now);
        }
        self.awake_at = now;
        let shared = Arc::clone(&self.shared);
        let batch = {
            let mut inbox = shared.inbox.lock().unwrap_or_else(|e| e.into_inner());
            if inbox.queue.is_empty() && timeout > 0.0 {
                let deadline = Instant::now() + Duration::from_secs_f64(timeout);
                while !inbox.rung && inbox.queue.is_empty() {
                    let left = deadline.saturating_duration_since(Instant::now());
                    if left.is_zero() {
                        break;
                    }
                    inbox = shared.bell.wait_timeout(inbox, left).unwrap_or_else(|e| e.into_inner()).0;
                }
            }
            inbox.rung = false;
            std::mem::take(&mut inbox.queue)
        };
        if STOP.load(Ordering::Relaxed) {
            return Err(Halt::Stop);
        }
        let any = !batch.is_empty();
        for msg in batch {
            self.handle(msg)?;
        }
        Ok(any)
    }

    pub(super) fn declare_fixed(&mut self) -> Result<(), String> {
        let run = self.spec.run.clone();
        let shared = Arc::clone(&self.shared);
        let ctl = self
            .session
            .declare_subscriber(keys::ctl_expr(&run))
            .callback(move |s| {
                let key = s.key_expr().as_str().to_string();
                let is_clock = key.ends_with("/clock");
                shared.push(Msg::Ctl(key, s.payload().to_bytes().into_owned()), is_clock)
            })
            .wait()
            .map_err(zerr)?;
        self._fixed.push(ctl);
        if self.controller.is_some() {
            let shared = Arc::clone(&self.shared);
            let cmd = self
                .session
                .declare_subscriber(keys::command_key(&run))
                .callback(move |s| shared.push(Msg::Command(s.payload().to_bytes().into_owned()), false))
                .wait()
                .map_err(zerr)?;
            self._fixed.push(cmd);
        }
        Ok(())
    }
}
