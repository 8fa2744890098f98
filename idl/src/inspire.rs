//! `inspire::` — the Inspire FTP (RH56DFTP) hand's own DDS messages, as the Inspire DDS driver
//! (inspire_hand_sdk `hand_idl/`) registers them. Rust twin of `idl/inspire.idl`.
//!
//! Unlike the Unitree types there is no `msg::dds_` module: the DDS type names are
//! `inspire::inspire_hand_ctrl`, `inspire::inspire_hand_state` and `inspire::inspire_hand_touch`.
//! Every field is an IDL *bounded* sequence (`sequence<int16, 6>` …): on the wire it is an
//! ordinary sequence (u32 count, elements), and the bound is enforced both ways here as
//! CycloneDDS does — encoding or decoding more elements than the bound is an error, and a
//! decoder never reserves memory for an announced count above the bound.
//!
//! The Inspire DFX hand and BrainCo Revo2 do not have types of their own: their services speak
//! `unitree_go::msg::dds_::MotorCmds_` / `MotorStates_` ([`crate::unitree_go`]).
//! Facts about all three hands: docs/sources.md §7.

use crate::keyless_topic_type;
use serde::{Deserialize, Serialize};

/// Entries of every control and state array: one per actuator.
pub const ACTUATORS: usize = 6;
/// Actuator order of every 6-element array (the same for both hands).
pub const ACTUATOR_NAMES: [&str; ACTUATORS] = ["pinky", "ring", "middle", "index", "thumb_bend", "thumb_rotate"];
/// Register range of `pos_set`, `angle_set`, `force_set`, `speed_set` (and the `*_act` values).
pub const UNITS_MAX: i16 = 1000;

/// `mode` bit: write `angle_set` (register ANGLE_SET, 1486).
pub const MODE_ANGLE: i8 = 0b0001;
/// `mode` bit: write `pos_set` (register POS_SET, 1474).
pub const MODE_POS: i8 = 0b0010;
/// `mode` bit: write `force_set` (register FORCE_SET, 1498).
pub const MODE_FORCE: i8 = 0b0100;
/// `mode` bit: write `speed_set` (register SPEED_SET, 1522).
pub const MODE_SPEED: i8 = 0b1000;

/// Command for one hand, on `rt/inspire_hand/ctrl/{l,r}`. Only the arrays whose `mode` bit is
/// set are applied (xr_teleoperate sends `angle_set` with `mode = MODE_ANGLE`).
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct InspireHandCtrl {
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<6, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<6, _, _>"
    )]
    pub pos_set: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<6, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<6, _, _>"
    )]
    pub angle_set: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<6, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<6, _, _>"
    )]
    pub force_set: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<6, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<6, _, _>"
    )]
    pub speed_set: Vec<i16>,
    pub mode: i8,
}
keyless_topic_type!(InspireHandCtrl, "inspire::inspire_hand_ctrl");

/// State of one hand, on `rt/inspire_hand/state/{l,r}`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct InspireHandState {
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<6, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<6, _, _>"
    )]
    pub pos_act: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<6, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<6, _, _>"
    )]
    pub angle_act: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<6, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<6, _, _>"
    )]
    pub force_act: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<6, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<6, _, _>"
    )]
    pub current: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<6, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<6, _, _>"
    )]
    pub err: Vec<u8>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<6, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<6, _, _>"
    )]
    pub status: Vec<u8>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<6, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<6, _, _>"
    )]
    pub temperature: Vec<u8>,
}
keyless_topic_type!(InspireHandState, "inspire::inspire_hand_state");

/// Taxels per tactile segment: fingertip end 3×3.
pub const TOUCH_TIP: usize = 9;
/// Fingertip pad 12×8 (also the thumb's finger pad).
pub const TOUCH_TOP: usize = 96;
/// Finger pad of pinky, ring, middle, index: 10×8.
pub const TOUCH_PAD: usize = 80;
/// Thumb middle section 3×3.
pub const TOUCH_THUMB_MIDDLE: usize = 9;
/// Palm 14×8.
pub const TOUCH_PALM: usize = 112;
/// All taxels of one hand (the "1062 tactile points" of the RH56DFTP).
pub const TOUCH_TOTAL: usize =
    4 * (TOUCH_TIP + TOUCH_TOP + TOUCH_PAD) + TOUCH_TIP + TOUCH_TOP + TOUCH_THUMB_MIDDLE + TOUCH_TOP + TOUCH_PALM;

/// Tactile arrays of one hand, on `rt/inspire_hand/touch/{l,r}` (published only when the driver
/// talks Modbus TCP to the hand, not over RS-485). Finger one = pinky … five = thumb.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct InspireHandTouch {
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<9, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<9, _, _>"
    )]
    pub fingerone_tip_touch: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<96, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<96, _, _>"
    )]
    pub fingerone_top_touch: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<80, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<80, _, _>"
    )]
    pub fingerone_palm_touch: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<9, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<9, _, _>"
    )]
    pub fingertwo_tip_touch: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<96, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<96, _, _>"
    )]
    pub fingertwo_top_touch: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<80, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<80, _, _>"
    )]
    pub fingertwo_palm_touch: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<9, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<9, _, _>"
    )]
    pub fingerthree_tip_touch: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<96, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<96, _, _>"
    )]
    pub fingerthree_top_touch: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<80, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<80, _, _>"
    )]
    pub fingerthree_palm_touch: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<9, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<9, _, _>"
    )]
    pub fingerfour_tip_touch: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<96, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<96, _, _>"
    )]
    pub fingerfour_top_touch: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<80, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<80, _, _>"
    )]
    pub fingerfour_palm_touch: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<9, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<9, _, _>"
    )]
    pub fingerfive_tip_touch: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<96, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<96, _, _>"
    )]
    pub fingerfive_top_touch: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<9, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<9, _, _>"
    )]
    pub fingerfive_middle_touch: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<96, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<96, _, _>"
    )]
    pub fingerfive_palm_touch: Vec<i16>,
    #[serde(
        serialize_with = "crate::cdr_codec::bounded_seq::serialize::<112, _, _>",
        deserialize_with = "crate::cdr_codec::bounded_seq::deserialize::<112, _, _>"
    )]
    pub palm_touch: Vec<i16>,
}
keyless_topic_type!(InspireHandTouch, "inspire::inspire_hand_touch");

impl InspireHandCtrl {
    /// What the Inspire SDK's `get_inspire_hand_ctrl()` builds: every array 6 zeros, mode 0
    /// (apply nothing).
    pub fn sdk_default() -> Self {
        Self {
            pos_set: vec![0; ACTUATORS],
            angle_set: vec![0; ACTUATORS],
            force_set: vec![0; ACTUATORS],
            speed_set: vec![0; ACTUATORS],
            mode: 0,
        }
    }
}

impl InspireHandState {
    /// What the Inspire SDK's `get_inspire_hand_state()` builds: every array 6 zeros.
    pub fn sdk_default() -> Self {
        Self {
            pos_act: vec![0; ACTUATORS],
            angle_act: vec![0; ACTUATORS],
            force_act: vec![0; ACTUATORS],
            current: vec![0; ACTUATORS],
            err: vec![0; ACTUATORS],
            status: vec![0; ACTUATORS],
            temperature: vec![0; ACTUATORS],
        }
    }
}

impl InspireHandTouch {
    /// What the Inspire SDK's `get_inspire_hand_touch()` builds: every array at its bound, zeros.
    pub fn sdk_default() -> Self {
        Self {
            fingerone_tip_touch: vec![0; TOUCH_TIP],
            fingerone_top_touch: vec![0; TOUCH_TOP],
            fingerone_palm_touch: vec![0; TOUCH_PAD],
            fingertwo_tip_touch: vec![0; TOUCH_TIP],
            fingertwo_top_touch: vec![0; TOUCH_TOP],
            fingertwo_palm_touch: vec![0; TOUCH_PAD],
            fingerthree_tip_touch: vec![0; TOUCH_TIP],
            fingerthree_top_touch: vec![0; TOUCH_TOP],
            fingerthree_palm_touch: vec![0; TOUCH_PAD],
            fingerfour_tip_touch: vec![0; TOUCH_TIP],
            fingerfour_top_touch: vec![0; TOUCH_TOP],
            fingerfour_palm_touch: vec![0; TOUCH_PAD],
            fingerfive_tip_touch: vec![0; TOUCH_TIP],
            fingerfive_top_touch: vec![0; TOUCH_TOP],
            fingerfive_middle_touch: vec![0; TOUCH_THUMB_MIDDLE],
            fingerfive_palm_touch: vec![0; TOUCH_TOP],
            palm_touch: vec![0; TOUCH_PALM],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{from_cdr, to_cdr_be, to_cdr_le};

    /// The same fields without bounds, to build over-long samples a peer could send.
    #[derive(Serialize)]
    struct UnboundedCtrl {
        pos_set: Vec<i16>,
        angle_set: Vec<i16>,
        force_set: Vec<i16>,
        speed_set: Vec<i16>,
        mode: i8,
    }

    #[test]
    fn sizes_of_the_sdk_defaults() {
        // 4 x (count 4 + 6 x 2) + mode 1, after the 4-byte header.
        assert_eq!(to_cdr_le(&InspireHandCtrl::sdk_default()).unwrap().len(), 4 + 65);
        // 4 x 16, then three u8 sequences of 4 + 6 bytes, each count 4-aligned: 64 + 10 + 2 + 10 + 2 + 10.
        assert_eq!(to_cdr_le(&InspireHandState::sdk_default()).unwrap().len(), 4 + 98);
        assert_eq!(TOUCH_TOTAL, 1062);
    }

    #[test]
    fn over_long_sequence_is_an_encode_error() {
        let mut c = InspireHandCtrl::sdk_default();
        c.speed_set.push(1);
        assert!(to_cdr_le(&c).is_err());
        assert!(to_cdr_be(&c).is_err());
        let mut t = InspireHandTouch::sdk_default();
        t.palm_touch.push(0);
        assert!(to_cdr_le(&t).is_err());
    }

    #[test]
    fn over_long_sequence_is_a_decode_error_not_an_allocation() {
        let ok = UnboundedCtrl {
            pos_set: vec![1; 6],
            angle_set: vec![2; 6],
            force_set: vec![3; 6],
            speed_set: vec![4; 6],
            mode: MODE_ANGLE | MODE_SPEED,
        };
        let bytes = to_cdr_le(&ok).unwrap();
        let back: InspireHandCtrl = from_cdr(&bytes).unwrap();
        assert_eq!((back.angle_set[0], back.mode), (2, 0b1001));

        // Seven elements (one over the bound), honestly encoded.
        let seven = UnboundedCtrl {
            angle_set: vec![2; 7],
            ..ok
        };
        assert!(from_cdr::<InspireHandCtrl>(&to_cdr_le(&seven).unwrap()).is_err());
        assert!(from_cdr::<InspireHandCtrl>(&to_cdr_be(&seven).unwrap()).is_err());

        // A count word announcing ~4 billion elements fails before reading them.
        let mut lying = bytes.clone();
        lying[4..8].copy_from_slice(&0xFFFF_FFF0u32.to_le_bytes());
        assert!(from_cdr::<InspireHandCtrl>(&lying).is_err());
    }

    #[test]
    fn state_round_trips_in_both_byte_orders() {
        let s = InspireHandState {
            pos_act: vec![10, 20, 30, 40, 50, 60],
            angle_act: vec![1000, 999, 0, -1, 500, 1],
            force_act: vec![-5, 0, 5, 100, 200, 300],
            current: vec![0; 6],
            err: vec![0, 1, 2, 4, 8, 16],
            status: vec![2; 6],
            temperature: vec![35; 6],
        };
        for bytes in [to_cdr_le(&s).unwrap(), to_cdr_be(&s).unwrap()] {
            assert_eq!(from_cdr::<InspireHandState>(&bytes).unwrap(), s);
        }
    }
}
