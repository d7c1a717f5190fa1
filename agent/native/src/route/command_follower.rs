//! The agent's controller: accepts signed gesture commands (replays and forgeries refused and named), and
//! follows the newest from the agent's next step (coordinator/control/route.py: CommandFollower).

use std::collections::HashSet;

use super::{class_of, Follower};
use crate::command::{self, GestureCommand};
use crate::final_report::Following;
use crate::sph::{Control, State, X, Y};

/// Authentic but old commands remembered as replays, at most this many.
const MAX_REPLAYS: usize = 64;

/// The agent's controller: accepts signed commands, follows the command's shape or its class' route.
pub struct CommandFollower {
    secret: Vec<u8>,
    agent_id: u32,
    static_control: Control,
    command: Option<GestureCommand>,
    pending: Option<GestureCommand>,
    current_payload: Option<Vec<u8>>,
    replays: HashSet<Vec<u8>>,
    follower: Option<Follower>,
    particle_class: u16,
    accepted: u64,
    first_command_at: Option<f64>,
}

impl CommandFollower {
    pub fn new(secret: Vec<u8>, agent_id: u32, static_control: Control) -> Self {
        CommandFollower {
            secret,
            agent_id,
            static_control,
            command: None,
            pending: None,
            current_payload: None,
            replays: HashSet::new(),
            follower: None,
            particle_class: 0,
            accepted: 0,
            first_command_at: None,
        }
    }

    /// None: accepted, or a harmless republication; else the reason it was refused
    /// ("malformed" | "version" | "signature" | "replay").
    pub fn offer(&mut self, payload: &[u8], now_unix: f64) -> Option<&'static str> {
        // The coordinator republishes the current command every 0.2 s, and a captured old command replayed
        // is the same bytes again: both are settled without decoding (a flood must not starve the agent).
        // The one encoder writes a command as one string of bytes, so only those bytes are a republication.
        if self.current_payload.as_deref() == Some(payload) {
            return None;
        }
        if self.replays.contains(payload) {
            return Some("replay");
        }
        let cmd = match command::decode(payload, &self.secret) {
            Ok(cmd) => cmd,
            Err(reason) => return Some(reason),
        };
        if let Some(newest) = self.pending.as_ref().or(self.command.as_ref()) {
            if cmd.seq <= newest.seq {
                // Other bytes than the newest's (checked above): not a republication.
                if self.replays.len() < MAX_REPLAYS {
                    self.replays.insert(payload.to_vec()); // authentic but old: it stays a replay (seq only grows)
                }
                return Some("replay");
            }
        }
        self.current_payload = Some(payload.to_vec());
        self.pending = Some(cmd);
        self.accepted += 1;
        self.first_command_at.get_or_insert(now_unix);
        None
    }

    pub fn has_command(&self) -> bool {
        self.pending.is_some() || self.command.is_some()
    }

    pub fn control(&mut self, state: &State) -> Control {
        if let Some(cmd) = self.pending.take() {
            // A new gesture takes effect at the agent's next step.
            let shares: Vec<f64> = cmd.classes.iter().map(|c| c.share).collect();
            let k = class_of(u64::from(self.agent_id), cmd.n_agents, &shares);
            // At most 64 classes (command::MAX_CLASSES), so the class fits the record's u16.
            self.particle_class = k as u16;
            self.follower = Some(Follower::for_command(&cmd, k));
            self.command = Some(cmd);
        }
        match self.follower.as_mut() {
            Some(f) => f.control(state[X], state[Y]),
            None => self.static_control,
        }
    }

    pub fn particle_class(&self) -> u16 {
        self.particle_class
    }

    /// The controller's part of the agent's final report (coordinator/control/route.py: CommandFollower.report).
    pub fn report(&self) -> Following {
        Following {
            commands_accepted: self.accepted,
            particle_class: self.particle_class,
            waypoint_index: self.follower.as_ref().map_or(-1, |f| f.index() as i64),
            command_seq: self.command.as_ref().map_or(-1, |c| c.seq as i64),
            first_command_at: self.first_command_at,
        }
    }
}
