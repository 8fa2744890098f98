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
use crate::control::Active;
use crate::dds_device::{DdsCodec, MessageElement, SharedMessage};
use crate::mapping::DeviceTable;
use crate::model::{faults, HandState, SafeAction, Side};

/// The latest wire q each handgate device on one command topic sent for its own six entries
/// (element 0 the right hand, 1 the left).
pub type SharedTargets = SharedMessage<[f32; HAND_ENTRIES], 2>;

/// The DDS-client codec of one hand.
#[derive(Debug, Clone)]
pub struct DfxCodec {
    /// This hand's element of the message shared with the other hand's device (0 right, 1
    /// left), and the hold of the other hand (its measured wire q, entries in its order) our
    /// messages carry while no device of ours drives it.
    share: MessageElement<[f32; HAND_ENTRIES], [f32; HAND_ENTRIES], 2>,
    /// This hand's `lost` counters in the previous sample.
    last_lost: Option<[u32; HAND_ENTRIES]>,
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
            share: MessageElement::new(shared, super::element(side)?),
            last_lost: None,
        })
    }

    /// Entries of this hand in the 12-entry message.
    pub fn own_range(&self) -> std::ops::Range<usize> {
        hand_range(self.share.element())
    }

    fn other(&self) -> usize {
        1 - self.share.element()
    }

    /// The other hand's last measured wire q, if it was measured.
    pub fn other_q(&self) -> Option<[f32; HAND_ENTRIES]> {
        self.share.measured(self.other())
    }
}

/// Entries of element (hand) `e` in the 12-entry message.
fn hand_range(e: usize) -> std::ops::Range<usize> {
    e * HAND_ENTRIES..(e + 1) * HAND_ENTRIES
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
                self.share.release();
                return false;
            }
            Active::Command(t) | Active::Safe(_, t) => t,
        };
        // This hand's wire q by entry (NaN: no joint there, a table bug: say nothing).
        let mut own = [f32::NAN; HAND_ENTRIES];
        for (i, w) in table.wire_targets(targets) {
            if let Some(q) = own.get_mut(i) {
                *q = w.q;
            }
        }
        let own = own.iter().all(|q| q.is_finite()).then_some(own);
        // The other hand: its own device's latest targets, else held where it was measured
        // when this hold began; without either we cannot hold it: stay silent.
        let Some(hands) = self.share.compose(own, |q| q) else {
            return false;
        };
        msg.cmds.clear();
        for hand in hands {
            msg.cmds.extend(hand.map(entry));
        }
        true
    }

    fn reconnected(&mut self) {
        self.share.release();
    }

    fn decode_into(&mut self, s: &Self::State, table: &DeviceTable, st: &mut HandState) -> bool {
        if s.states.len() != ENTRIES {
            return false;
        }
        let other = &s.states[hand_range(self.other())];
        if other.iter().all(|m| m.q.is_finite()) {
            let mut o = [0.0; HAND_ENTRIES];
            for (o, m) in o.iter_mut().zip(other) {
                *o = m.q;
            }
            self.share.measure(self.other(), o);
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
