//! Inspire DFX over DDS, as a client of `DFX_inspire_service` (docs/sources.md §7 "Inspire
//! DFX"): unitree_go `MotorCmds_` on `rt/inspire/cmd`, `MotorStates_` on `rt/inspire/state`,
//! always 12 entries, 0–5 the right hand, 6–11 the left, only `q` meaningful (1 = open).
//!
//! One message carries both hands, and each hand is its own handgate device. So a device
//! never disturbs the other hand's six entries: when the other hand is driven by handgate too
//! (a left and a right device on one service: they share [`SharedTargets`]), every message
//! carries that hand's own latest target, so both devices send the same picture of both
//! hands and neither can starve the other (the service applies the latest message per loop);
//! when it is not, a hold of the other hand where it was **measured when the hold began**
//! (the first message that carries it, after a silence or a reconnect), kept until that
//! hand's own device sends targets: never re-taken from each new measurement, which would
//! integrate the hand's sag under a load (docs/adapters.md, "Holds"). Nothing at all is sent
//! until that hand has been measured once (the pattern of the Dex1 `actuator` variant).
//!
//! State: `q` per entry (the hand's ANGLE_ACT / 1000); `lost` counts failed serial reads per
//! entry: a hand whose `lost` grew since the previous sample was not read this cycle
//! (fault `HARDWARE` on that sample; **inference**, the service keeps the last value).

use handgate_idl::unitree_go;

use super::{ENTRIES, HAND_ENTRIES};
use crate::control::{Active, MeasuredHold};
use crate::dds_device::DdsCodec;
use crate::mapping::DeviceTable;
use crate::model::{faults, HandState, SafeAction, Side};

/// The latest wire q each handgate device on one command topic sent for its own six entries
/// (`None`: that hand's device has sent nothing yet, or there is none).
pub type SharedTargets = std::sync::Arc<std::sync::Mutex<[Option<f32>; ENTRIES]>>;

/// The DDS-client codec of one hand.
#[derive(Debug, Clone)]
pub struct DfxCodec {
    /// This hand's element: 0 right, 1 left.
    element: usize,
    /// The other hand's measured wire q (entries in its order), and the hold of it our
    /// messages carry while no device of ours drives it: where it was when the hold began.
    other: MeasuredHold<[f32; HAND_ENTRIES]>,
    /// This hand's `lost` counters in the previous sample.
    last_lost: Option<[u32; HAND_ENTRIES]>,
    /// Targets of the devices sharing this command topic.
    shared: SharedTargets,
}

impl DfxCodec {
    /// The codec of `side`'s hand (`None` for a center side: the message has no such hand).
    pub fn new(side: Side) -> Option<Self> {
        Self::with_shared(side, SharedTargets::default())
    }

    /// The codec of `side`'s hand, sharing `shared` with the other hand's device on the same
    /// command topic.
    pub fn with_shared(side: Side, shared: SharedTargets) -> Option<Self> {
        Some(Self {
            element: super::element(side)?,
            other: MeasuredHold::default(),
            last_lost: None,
            shared,
        })
    }

    /// Entries of this hand in the 12-entry message.
    pub fn own_range(&self) -> std::ops::Range<usize> {
        self.element * HAND_ENTRIES..(self.element + 1) * HAND_ENTRIES
    }

    fn other_range(&self) -> std::ops::Range<usize> {
        (1 - self.element) * HAND_ENTRIES..(2 - self.element) * HAND_ENTRIES
    }

    /// The other hand's last measured wire q, if it was measured.
    pub fn other_q(&self) -> Option<[f32; HAND_ENTRIES]> {
        self.other.measured()
    }
}

/// A command entry as the service reads it: `q` only, every other field zero (as
/// xr_teleoperate sends it).
fn entry(q: f32) -> unitree_go::MotorCmd_ {
    unitree_go::MotorCmd_ {
        q,
        ..Default::default()
    }
}

impl DdsCodec for DfxCodec {
    type Cmd = unitree_go::MotorCmds_;
    type State = unitree_go::MotorStates_;

    fn encode_into(&mut self, active: &Active, table: &DeviceTable, _dt: f32, msg: &mut Self::Cmd) -> bool {
        let targets = match active {
            // The service has no limp: it only writes angles. Stay silent; after its 1 s
            // timeout it stops writing and the hand holds its last target (docs/sources.md §7).
            // Our messages stop holding the other hand: the next one begins a new hold.
            Active::Idle | Active::Safe(SafeAction::Limp, _) => {
                self.other.release();
                return false;
            }
            Active::Command(t) | Active::Safe(_, t) => t,
        };
        // This hand's wire q by entry (NaN: no joint there, a table bug).
        let mut own = [f32::NAN; HAND_ENTRIES];
        for (i, w) in table.wire_targets(targets) {
            if let Some(q) = own.get_mut(i) {
                *q = w.q;
            }
        }
        let mut shared = self.shared.lock().unwrap_or_else(|p| p.into_inner());
        for (e, q) in self.own_range().zip(own) {
            shared[e] = Some(q).filter(|q| q.is_finite());
        }
        // The other hand: its own device's latest targets, else held where it was measured
        // when this hold began; without either we cannot hold it: stay silent.
        let mut sent = [0.0; HAND_ENTRIES];
        let mut all_sent = true;
        for (q, e) in sent.iter_mut().zip(self.other_range()) {
            match shared[e] {
                Some(v) => *q = v,
                None => all_sent = false,
            }
        }
        drop(shared);
        let other = if all_sent {
            self.other.release();
            sent
        } else {
            match self.other.hold() {
                Some(q) => q,
                None => return false,
            }
        };
        msg.cmds.clear();
        msg.cmds.resize(ENTRIES, entry(0.0));
        for (e, q) in self.own_range().zip(own) {
            msg.cmds[e] = entry(q);
        }
        for (e, q) in self.other_range().zip(other) {
            msg.cmds[e] = entry(q);
        }
        // A table always covers its six entries; a NaN here would be a table bug: say nothing.
        msg.cmds.iter().all(|c| c.q.is_finite())
    }

    fn reconnected(&mut self) {
        self.other.release();
    }

    fn decode_into(&mut self, s: &Self::State, table: &DeviceTable, st: &mut HandState) -> bool {
        if s.states.len() != ENTRIES {
            return false;
        }
        let other = &s.states[self.other_range()];
        if other.iter().all(|m| m.q.is_finite()) {
            let mut o = [0.0; HAND_ENTRIES];
            for (o, m) in o.iter_mut().zip(other) {
                *o = m.q;
            }
            self.other.measure(o);
        }
        let own = &s.states[self.own_range()];
        let mut lost = [0u32; HAND_ENTRIES];
        for (l, m) in lost.iter_mut().zip(own) {
            *l = m.lost;
        }
        let missed = self
            .last_lost
            .is_some_and(|prev| prev.iter().zip(&lost).any(|(p, l)| l > p));
        self.last_lost = Some(lost);
        table.state_from_wire_into(&mut st.joints, |i| own.get(i).map(|m| (m.q, m.dq, m.tau_est)));
        st.faults = if missed { faults::HARDWARE } else { 0 };
        true
    }
}
