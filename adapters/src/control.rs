//! Command state shared by every adapter's device loop: latest-wins slot, resolution through
//! the table against measured state, safe states, and re-seeding after the link comes back
//! (a stale setpoint is never replayed).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use crate::device::DeviceStats;
use crate::mapping::{DeviceTable, MappingError};
use crate::model::{CommandBody, HandCommand, JointCommand, JointState, SafeAction};

/// What the loop should send this cycle.
#[derive(Debug, Clone, PartialEq)]
pub enum Active {
    /// Nothing commanded yet: send nothing (or the device's idle frame).
    Idle,
    /// Targets from a client command.
    Command(Vec<JointCommand>),
    /// Targets of a safe state.
    Safe(SafeAction, Vec<JointCommand>),
}

#[derive(Debug)]
struct Inner {
    pending: Option<HandCommand>,
    pending_safe: Option<SafeAction>,
    active: Active,
    last_seq: u64,
    last_tag: u32,
}

/// Latest-command slot plus the targets currently in force.
#[derive(Debug, Clone)]
pub struct CommandState {
    table: Arc<DeviceTable>,
    inner: Arc<Mutex<Inner>>,
    pub counters: Arc<Counters>,
}

/// Lock-free counters (read by status without touching the device loop).
#[derive(Debug, Default)]
pub struct Counters {
    pub commands: AtomicU64,
    pub rejected: AtomicU64,
    pub sent: AtomicU64,
    pub state_samples: AtomicU64,
    pub crc_errors: AtomicU64,
    pub reconnects: AtomicU64,
    pub missed_cycles: AtomicU64,
    pub reseeds: AtomicU64,
    pub link_up: AtomicU64,
}

impl Counters {
    pub fn inc(c: &AtomicU64) {
        c.fetch_add(1, Ordering::Relaxed);
    }
    pub fn snapshot(&self) -> DeviceStats {
        let g = |c: &AtomicU64| c.load(Ordering::Relaxed);
        DeviceStats {
            commands: g(&self.commands),
            rejected: g(&self.rejected),
            sent: g(&self.sent),
            state_samples: g(&self.state_samples),
            crc_errors: g(&self.crc_errors),
            reconnects: g(&self.reconnects),
            missed_cycles: g(&self.missed_cycles),
            reseeds: g(&self.reseeds),
            link_up: g(&self.link_up) != 0,
        }
    }
}

impl CommandState {
    pub fn new(table: Arc<DeviceTable>) -> Self {
        Self {
            table,
            inner: Arc::new(Mutex::new(Inner {
                pending: None,
                pending_safe: None,
                active: Active::Idle,
                last_seq: 0,
                last_tag: 0,
            })),
            counters: Arc::new(Counters::default()),
        }
    }

    pub fn table(&self) -> &Arc<DeviceTable> {
        &self.table
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Accepts a client command (latest wins). It is checked now against the table
    /// ([`DeviceTable::check`]) so a bad command is refused immediately and nothing changes;
    /// it is resolved once, against the measured state, in [`Self::step`].
    pub fn submit(&self, cmd: HandCommand) -> Result<(), MappingError> {
        if let Err(e) = self.table.check(&cmd.body) {
            Counters::inc(&self.counters.rejected);
            return Err(e);
        }
        Counters::inc(&self.counters.commands);
        let mut g = self.lock();
        if let CommandBody::Safe(a) = cmd.body {
            g.pending_safe = Some(a);
            g.pending = None;
        } else {
            g.pending = Some(cmd);
            g.pending_safe = None;
        }
        Ok(())
    }

    /// Requests a safe state (watchdog, shutdown).
    pub fn request_safe(&self, action: SafeAction) {
        let mut g = self.lock();
        g.pending = None;
        g.pending_safe = Some(action);
    }

    /// Called when the link to the device comes back: whatever was in force is replaced by a
    /// hold at the first measured state; the client must command again to move.
    pub fn reseed(&self, measured: &[JointState]) {
        let mut g = self.lock();
        g.pending = None;
        if matches!(g.active, Active::Idle) {
            // Nothing was commanded: nothing to replay, nothing to hold.
            return;
        }
        Counters::inc(&self.counters.reseeds);
        g.active = Active::Safe(SafeAction::Hold, self.table.hold_measured(measured));
    }

    /// One device-loop step: folds in the pending command or safe request, resolved against
    /// `measured`, and returns the targets in force.
    pub fn step(&self, measured: &[JointState]) -> Active {
        let mut g = self.lock();
        if let Some(a) = g.pending_safe.take() {
            g.active = Active::Safe(a, self.table.safe_targets(a, measured));
        }
        if let Some(cmd) = g.pending.take() {
            let prev = match &g.active {
                Active::Command(t) | Active::Safe(_, t) => Some(t.clone()),
                Active::Idle => None,
            };
            match self.table.resolve(&cmd.body, prev.as_deref(), measured) {
                Ok(t) => {
                    g.active = Active::Command(t);
                    g.last_seq = cmd.seq;
                    g.last_tag = cmd.tag;
                }
                Err(_) => Counters::inc(&self.counters.rejected),
            }
        }
        g.active.clone()
    }

    /// seq and tag of the last applied client command.
    pub fn applied(&self) -> (u64, u32) {
        let g = self.lock();
        (g.last_seq, g.last_tag)
    }

    /// Whether a safe state is in force.
    pub fn is_safe(&self) -> bool {
        matches!(self.lock().active, Active::Safe(..))
    }
}
