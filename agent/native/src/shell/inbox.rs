//! The shell's channel: Zenoh's receiving threads queue what arrives here and ring the main thread only when
//! the core has something to do (what its last `Sleep` said to wake for); the main thread takes the whole
//! queue at once: one wake-up per lockstep step, not one per message.

use std::collections::{HashSet, VecDeque};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

use crate::agent::{Input, Wake};
use crate::wire;

#[derive(Default)]
struct Queue {
    inputs: VecDeque<Input>,
    /// ids whose `await_step` state the core waits for; the callback rings when it empties
    awaited: HashSet<u32>,
    await_step: u32,
    wake_on_state: bool,
    wake_on_clock: bool,
    rung: bool,
}

#[derive(Default)]
pub struct Inbox {
    queue: Mutex<Queue>,
    bell: Condvar,
}

impl Inbox {
    fn lock(&self) -> std::sync::MutexGuard<'_, Queue> {
        self.queue.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Queue a control or command message. Clock ticks come at 50 Hz: they wake the main thread only while
    /// it is paced; everything else always wakes it.
    pub fn push(&self, input: Input, is_clock: bool) {
        let mut q = self.lock();
        q.inputs.push_back(input);
        if !is_clock || q.wake_on_clock {
            q.rung = true;
            self.bell.notify_one();
        }
    }

    pub fn push_state(&self, record: Vec<u8>, on_key: bool) {
        let mut q = self.lock();
        let mut ring = q.wake_on_state;
        if !q.awaited.is_empty() {
            // A hint only: the core validates the record itself.
            if let Some((j, step)) = wire::peek_id_step(&record) {
                if step >= q.await_step && q.awaited.remove(&j) && q.awaited.is_empty() {
                    ring = true;
                }
            }
        }
        q.inputs.push_back(Input::State { record, on_key });
        if ring {
            q.rung = true;
            self.bell.notify_one();
        }
    }

    /// Everything queued: at once if anything is, else after sleeping until `until` (at most `slice`), a
    /// ring for what `wake` names, or `stop` set. A stop comes first in the batch.
    pub fn take(&self, until: Instant, wake: &Wake, slice: Duration, stop: &AtomicBool) -> Vec<Input> {
        let mut q = self.lock();
        q.awaited = wake.awaited.iter().copied().collect();
        q.await_step = wake.step;
        q.wake_on_state = wake.on_state;
        q.wake_on_clock = wake.on_clock;
        if q.inputs.is_empty() {
            let until = until.min(Instant::now() + slice);
            while !q.rung {
                let left = until.saturating_duration_since(Instant::now());
                if left.is_zero() || stop.load(Ordering::Relaxed) {
                    break;
                }
                q = self.bell.wait_timeout(q, left).unwrap_or_else(|e| e.into_inner()).0;
            }
        }
        q.rung = false;
        q.awaited.clear();
        q.wake_on_state = false;
        q.wake_on_clock = false;
        let mut batch: Vec<Input> = q.inputs.drain(..).collect();
        if stop.load(Ordering::Relaxed) {
            batch.insert(0, Input::Stop);
        }
        batch
    }
}
