//! The G1's `rt/hand_sdk` interface (docs/sources.md §6): unitree_go MotorCmds_ with 4 entries; the
//! blend weight is `round(w * 100)` in `cmds[0].mode`; ai_sport blends all five fields as
//! `w * user + (1 - w) * its own`. handgate ramps the weight up at a profile rate when a
//! command arrives (never a step from 0 to 1), keeps publishing at the profile rate while
//! active (ai_sport falls back when the stream stops), and on a safe state ramps the weight
//! down to 0 with the last command, then stops publishing: control returns to ai_sport.
//! There is no state topic: state is "commanded only".

use handgate_idl::unitree_go;

use crate::control::Active;
use crate::dds_device::DdsCodec;
use crate::mapping::DeviceTable;
use crate::model::{Freshness, HandState, JointCommand, JointState};

use super::MOTORS;

/// Weight ramp parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WeightRamp {
    /// Weight to reach while commanded, [0, 1].
    pub target: f32,
    /// Weight change per second (> 0).
    pub per_second: f32,
}

impl Default for WeightRamp {
    fn default() -> Self {
        Self {
            target: 1.0,
            per_second: 1.0,
        }
    }
}

/// Encodes rt/hand_sdk messages with a ramped weight.
#[derive(Debug, Clone)]
pub struct HandSdkCodec {
    pub ramp: WeightRamp,
    weight: f32,
    last: Option<Vec<JointCommand>>,
}

impl HandSdkCodec {
    pub fn new(ramp: WeightRamp) -> Self {
        Self {
            ramp,
            weight: 0.0,
            last: None,
        }
    }

    /// Current blend weight.
    pub fn weight(&self) -> f32 {
        self.weight
    }

    /// The integer ai_sport receives in `cmds[0].mode`.
    pub fn weight_byte(w: f32) -> u8 {
        (w.clamp(0.0, 1.0) * 100.0).round() as u8
    }
}

impl DdsCodec for HandSdkCodec {
    type Cmd = unitree_go::MotorCmds_;
    type State = unitree_go::MotorStates_;

    fn encode_into(&mut self, active: &Active, table: &DeviceTable, dt: f32, msg: &mut Self::Cmd) -> bool {
        let step = self.ramp.per_second.max(1e-3) * dt;
        match (active, &mut self.last) {
            (Active::Idle, _) => return false,
            (Active::Command(t), last) => {
                match last {
                    Some(l) => l.clone_from(t),
                    None => *last = Some(t.clone()),
                }
                self.weight = (self.weight + step).min(self.ramp.target.clamp(0.0, 1.0));
            }
            // Hand control back to ai_sport smoothly with the last command, then go quiet.
            (Active::Safe(..), None) => return false,
            (Active::Safe(..), Some(_)) => {
                if self.weight <= 0.0 {
                    return false;
                }
                self.weight = (self.weight - step).max(0.0);
            }
        }
        let Some(target) = &self.last else {
            return false;
        };
        msg.cmds.clear();
        msg.cmds.resize(MOTORS, Default::default());
        for (i, w) in table.wire_targets(target) {
            if let Some(m) = msg.cmds.get_mut(i) {
                *m = w.into();
            }
        }
        msg.cmds[0].mode = Self::weight_byte(self.weight);
        true
    }

    fn decode_into(&mut self, _s: &Self::State, _table: &DeviceTable, _st: &mut HandState) -> bool {
        false
    }

    fn commanded_state(&self, table: &DeviceTable, st: &mut HandState) {
        st.joints.clear();
        match &self.last {
            Some(t) => st.joints.extend(t.iter().map(|c| JointState {
                q: c.q,
                dq: c.dq,
                tau: c.tau,
                temperature: None,
            })),
            None => st.joints.resize(table.joint_count(), JointState::default()),
        }
        st.freshness = Freshness::CommandedOnly;
        st.mode = Self::weight_byte(self.weight);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{SafeAction, Side};

    #[test]
    fn weight_ramps_up_and_down_never_steps() {
        let t = crate::hand_sdk::table::table(Side::Left);
        let mut c = HandSdkCodec::new(WeightRamp {
            target: 1.0,
            per_second: 2.0,
        });
        let close = t.closure_targets(1.0, None).unwrap();
        let mut weights = Vec::new();
        for _ in 0..150 {
            let m = c.encode(&Active::Command(close.clone()), &t, 0.005).unwrap();
            assert_eq!(m.cmds.len(), 4);
            assert!(m.cmds.iter().all(|x| x.tau > 0.0), "positive tau closes");
            weights.push(m.cmds[0].mode);
        }
        assert_eq!(*weights.last().unwrap(), 100);
        assert!(
            weights.windows(2).all(|w| w[1] >= w[0] && w[1] - w[0] <= 1),
            "{weights:?}"
        );
        assert!(weights[0] <= 1);
        let mut down = Vec::new();
        while let Some(m) = c.encode(&Active::Safe(SafeAction::Hold, vec![]), &t, 0.005) {
            down.push(m.cmds[0].mode);
            assert!(down.len() < 1000);
        }
        assert_eq!(*down.last().unwrap(), 0);
        assert!(down.windows(2).all(|w| w[1] <= w[0] && w[0] - w[1] <= 1));
    }

    #[test]
    fn idle_publishes_nothing() {
        let t = crate::hand_sdk::table::table(Side::Left);
        assert!(HandSdkCodec::new(WeightRamp::default())
            .encode(&Active::Idle, &t, 0.005)
            .is_none());
    }
}
