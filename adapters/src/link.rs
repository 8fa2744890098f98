//! What every device loop repeats, whatever its transport (DDS client, Dex3 USB frames,
//! EZGripper bus): following the link so that a target in force before it went down is never
//! replayed when it comes back (re-seeding: a hold at the first new measurement), never
//! "holding" a position that was never measured, and stamping each state with the command it
//! reflects and the safe-state fault.

use std::sync::atomic::Ordering;
use std::time::{Instant, SystemTime};

use crate::control::{Active, CommandState, Counters};
use crate::model::{faults, Freshness, HandState, JointState, SafeAction};

/// The link as the device loop sees it, one measurement at a time.
#[derive(Debug, Default)]
pub struct LinkTracker {
    ever_up: bool,
    up: bool,
}

impl LinkTracker {
    /// A fresh measurement (`up`) or its absence. When the link comes back after being down,
    /// whatever target was in force is replaced by a hold at `measured` (counted as a
    /// reconnect) and `true` is returned: the client must command again to move. The first
    /// measurement gives a hold requested before it its position
    /// ([`CommandState::first_measurement`]).
    pub fn observe(&mut self, up: bool, measured: &[JointState], cmd: &CommandState) -> bool {
        let back = up && !self.up && self.ever_up;
        if back {
            Counters::inc(&cmd.counters.reconnects);
            cmd.reseed(measured);
        }
        if up && !self.ever_up {
            cmd.first_measurement(measured);
        }
        if up {
            cmd.mark_measured();
        }
        self.ever_up |= up;
        self.up = up;
        cmd.counters.link_up.store(up as u64, Ordering::Relaxed);
        back
    }

    /// Whether the link is up now.
    pub fn is_up(&self) -> bool {
        self.up
    }

    /// Whether anything was ever measured.
    pub fn ever_measured(&self) -> bool {
        self.ever_up
    }
}

/// Never "hold" a position that was never measured: whether `active` is such a hold.
pub fn blind_hold(ever_measured: bool, active: &Active) -> bool {
    !ever_measured && matches!(active, Active::Safe(SafeAction::Hold, _))
}

/// Never "hold" a position that was never measured: whether a safe `action` requested of a
/// device whose state is `st` would be such a hold.
pub fn blind_hold_request(st: &HandState, action: SafeAction) -> bool {
    st.measured_at.is_none() && action == SafeAction::Hold
}

/// Stamps `st` with the seq and tag of the last applied command, the safe-state fault and,
/// when `wall` is set, the wall-clock time of its measurement. Every device loop calls it on
/// each state it publishes, so it also counts the fresh → stale transitions
/// (`Counters::stale_events`) and judges whether the device follows its targets
/// ([`CommandState::observe_motion`]).
pub fn stamp(st: &mut HandState, cmd: &CommandState, safe: bool, wall: bool) {
    let fresh = st.freshness == Freshness::Fresh;
    let was_fresh = cmd.counters.published_fresh.swap(fresh, Ordering::Relaxed);
    if was_fresh && st.freshness == Freshness::Stale {
        Counters::inc(&cmd.counters.stale_events);
    }
    (st.cmd_seq, st.cmd_tag) = cmd.applied();
    if wall {
        st.measured_wall = st
            .measured_at
            .map(|t| SystemTime::now() - Instant::now().saturating_duration_since(t));
    }
    if safe {
        st.faults |= faults::SAFE_STATE;
    } else {
        st.faults &= !faults::SAFE_STATE;
    }
    cmd.observe_motion(st);
}

/// A device whose loop runs on a thread of its own kind (a bus shared by several devices, a
/// serial link): it keeps the command in force in a [`CommandState`], publishes its state on a
/// watch channel with [`crate::device::StateTaps`], and hands each command to its loop in
/// [`BusDevice::apply`]. The one [`crate::device::HandDevice`] implementation for them all
/// (EZGripper, Robotiq, LEAP Hand, Inspire RH56, the kit's register-mapped hands).
pub trait BusDevice: Send + Sync {
    fn info(&self) -> &crate::device::DeviceInfo;
    /// The command in force.
    fn commands(&self) -> &CommandState;
    fn state_rx(&self) -> &tokio::sync::watch::Receiver<HandState>;
    fn taps(&self) -> &crate::device::StateTaps;
    /// Hands the command in force to the device's loop; a loop that reads the command state
    /// each cycle needs nothing (the default).
    fn apply(&self) -> Result<(), crate::device::DeviceError> {
        Ok(())
    }
    /// The link's counters on top of the command state's: (reconnects, CRC / checksum errors).
    fn link_counters(&self) -> (u64, u64) {
        (0, 0)
    }
    /// [`crate::device::HandDevice::calibration`].
    fn calibration(&self) -> Option<&dyn crate::device::Calibrate> {
        None
    }
}

#[async_trait::async_trait]
impl<T: BusDevice> crate::device::HandDevice for T {
    fn info(&self) -> &crate::device::DeviceInfo {
        BusDevice::info(self)
    }

    fn command(&self, cmd: crate::model::HandCommand) -> Result<(), crate::device::DeviceError> {
        self.commands().submit(cmd)?;
        self.apply()
    }

    fn command_checked(
        &self,
        seq: u64,
        body: crate::mapping::CheckedBody,
        tag: u32,
    ) -> Result<(), crate::device::DeviceError> {
        self.commands().submit_checked(seq, body, tag);
        self.apply()
    }

    fn state(&self) -> tokio::sync::watch::Receiver<HandState> {
        self.state_rx().clone()
    }

    fn state_taps(&self) -> Option<&crate::device::StateTaps> {
        Some(self.taps())
    }

    fn commanded(&self) -> Option<Vec<f32>> {
        self.commands().targets()
    }

    async fn safe_state(&self, action: SafeAction) -> Result<(), crate::device::DeviceError> {
        if blind_hold_request(&self.state_rx().borrow(), action) {
            return Ok(());
        }
        self.commands().request_safe(action);
        self.apply()
    }

    fn stats(&self) -> crate::device::DeviceStats {
        let mut s = self.commands().counters.snapshot();
        let (reconnects, crc) = self.link_counters();
        s.reconnects = s.reconnects.max(reconnects);
        s.crc_errors = s.crc_errors.max(crc);
        s
    }

    fn calibration(&self) -> Option<&dyn crate::device::Calibrate> {
        BusDevice::calibration(self)
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::model::{DeviceKind, Side};

    /// Only a fresh state followed by a stale one counts: the stale states before the first
    /// measurement, a stale spell's further states and a device without feedback do not.
    #[test]
    fn stale_events_count_fresh_to_stale_transitions_only() {
        let table = Arc::new(DeviceKind::Dex1.table(Side::Left, &Default::default()).unwrap());
        let cmd = CommandState::new(table);
        let publish = |f: Freshness| {
            let mut st = HandState::empty(1);
            st.freshness = f;
            stamp(&mut st, &cmd, false, false);
            cmd.counters.stale_events.load(Ordering::Relaxed)
        };
        use Freshness::{CommandedOnly, Fresh, Stale};
        assert_eq!(publish(Stale), 0, "never measured yet");
        assert_eq!(publish(Stale), 0);
        assert_eq!(publish(Fresh), 0);
        assert_eq!(publish(Fresh), 0);
        assert_eq!(publish(Stale), 1, "fresh -> stale");
        assert_eq!(publish(Stale), 1, "the same stale spell");
        assert_eq!(publish(Fresh), 1);
        assert_eq!(publish(Stale), 2, "a second spell");
        assert_eq!(publish(CommandedOnly), 2);
        assert_eq!(publish(Stale), 2, "commanded-only is not fresh");
        assert_eq!(cmd.counters.snapshot().stale_events, 2);
    }
}
