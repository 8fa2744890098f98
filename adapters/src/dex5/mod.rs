//! Unitree Dex5-1 five-finger hand, reached over DDS as a client of the robot's hand service
//! (docs/sources.md §7 "Dex5-1"). The protocol: the mapping table and the choices where the
//! sources disagree ([`table`]), the DDS-client codec ([`adapter`]), the front codec a Dex5
//! client drives any device through ([`front`]) and the emulated hand service ([`emulator`]).
//! The glue: its profile keys ([`config`]) and its registry entry ([`kind`]).
//!
//! The wire, as both public clients use it: unitree_hg `HandCmd_` on `rt/dex5/{side}/cmd`,
//! `HandState_` on `rt/dex5/{side}/state`, one entry per URDF joint: **20 entries** for
//! **16 motors** (the distal flex joint of each long finger rides on its middle joint's
//! motor). Entries in the order index, middle, ring, pinky (four each: spread, then three
//! flex joints from the palm out), then the thumb (yaw, roll, two flex joints). Every entry's
//! mode byte is `0x01` in xr_teleoperate's commands; q in the URDF's radians.

pub mod adapter;
pub mod config;
pub mod emulator;
pub mod front;
pub mod kind;
pub mod serve;
pub mod table;

use crate::model::Side;

/// Canonical joint names, canonical order (= the wire order of both messages). Per finger,
/// `_0` is the spread (or the thumb's yaw) and the higher numbers go from the palm out.
pub const JOINTS: [&str; WIRE_LEN] = [
    "index_0", "index_1", "index_2", "index_3", "middle_0", "middle_1", "middle_2", "middle_3", "ring_0", "ring_1",
    "ring_2", "ring_3", "pinky_0", "pinky_1", "pinky_2", "pinky_3", "thumb_0", "thumb_1", "thumb_2", "thumb_3",
];

/// Entries per hand in `HandCmd_` / `HandState_`: one per URDF joint (docs/sources.md §7:
/// xr_teleoperate's controller and unitree_dds_wrapper's state reader both use 20). What
/// tells a Dex5 answering on another hand's topics from a Dex3-1 (7 entries).
pub const WIRE_LEN: usize = 20;

/// Motors per hand (unitree_dds_wrapper's `NUM_MOTORS`): four in the thumb, three in each
/// long finger.
pub const MOTORS: usize = 16;

/// The first thumb entry: entries 16..19 are the thumb, 0..15 the four long fingers.
pub const THUMB_FIRST: usize = 16;

/// The mode byte xr_teleoperate writes in every entry ("position control"). handgate reads
/// it as the G1's other unitree_hg motors use it: 1 = motor enabled under the PD law, 0 =
/// disabled (an inference, docs/sources.md §7).
pub const MODE_ENABLED: u8 = 0x01;
/// The mode byte of a disabled motor (no torque).
pub const MODE_DISABLED: u8 = 0x00;

/// The service's loop and state rate handgate assumes, Hz: no source gives one; the G1's
/// Dex3-1 service is assumed to run at this rate too (docs/profiles.md "Assumptions").
pub const SERVICE_HZ: f64 = 500.0;

/// The service's (command, state) topics for `side`: `rt/dex5/{left,right}/{cmd,state}`
/// (docs/sources.md §7). `None` for a side the hand does not have (center).
pub fn topics(side: Side) -> Option<(String, String)> {
    match side {
        Side::Left | Side::Right => Some((format!("rt/dex5/{side}/cmd"), format!("rt/dex5/{side}/state"))),
        Side::Center => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn topics_per_side_and_none_for_center() {
        assert_eq!(
            topics(Side::Left),
            Some(("rt/dex5/left/cmd".to_string(), "rt/dex5/left/state".to_string()))
        );
        assert_eq!(
            topics(Side::Right),
            Some(("rt/dex5/right/cmd".to_string(), "rt/dex5/right/state".to_string()))
        );
        assert_eq!(topics(Side::Center), None);
    }

    #[test]
    fn joint_names_are_unique_and_the_thumb_comes_last() {
        let mut names = JOINTS.to_vec();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), WIRE_LEN);
        assert!(JOINTS[THUMB_FIRST..].iter().all(|n| n.starts_with("thumb_")));
        assert!(JOINTS[..THUMB_FIRST].iter().all(|n| !n.starts_with("thumb_")));
    }
}
