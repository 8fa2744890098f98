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
