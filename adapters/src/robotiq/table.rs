//! The three Robotiq variants (their stroke, speed and force ranges and their URDF joint) and
//! their table: one canonical joint `jaw`, measured from open, positive = closing, in the
//! URDF joint's own unit (the canonical value is the URDF value: `UrdfFrame::Canonical`),
//! the wire the gripper's position byte (rPR / gPO: 0 open .. 255 closed).
//!
//! Sources (docs/robotiq.md, "Register map and sources"):
//! - 2F-85: `finger_joint`, revolute 0 .. 0.8 rad (ros-industrial robotiq,
//!   robotiq_2f_85_gripper_visualization/urdf/robotiq_arg2f_85_model_macro.xacro; the same
//!   limits on PickNikRobotics/ros2_robotiq_gripper's `robotiq_85_left_knuckle_joint`).
//! - 2F-140: `finger_joint`, revolute 0 .. 0.7 rad (ros2_robotiq_gripper,
//!   robotiq_description/urdf/robotiq_2f_140.xacro).
//! - Hand-E: `hande_left_finger_joint`, prismatic 0 .. 0.025 m, half the 50 mm stroke, 0 open
//!   (ros2_robotiq_gripper, robotiq_description/urdf/robotiq_hand_e_macro.urdf.xacro: the
//!   finger mimics `hande_finger_distance` × -0.5 + 0.025).
//! - Speeds (mm/s at rSP 0 and 255): 20-150 (2F-85, Hand-E), 30-250 (2F-140)
//!   (pyRobotiqGripper 3.3.14 constants.py; Robotiq's product specifications). Forces (N at
//!   rFR 0 and 255): 20-235 (2F-85), 10-125 (2F-140), 20-185 (Hand-E) (product specifications).

use serde::{Deserialize, Serialize};

use crate::mapping::{DeviceTable, JointMap, Limits, UrdfFrame};
use crate::model::{DeviceKind, Side};
use crate::motion::{Contact, MotionThresholds};

/// Which Robotiq gripper.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
pub enum Variant {
    /// 2F-85: 85 mm stroke, two adaptive fingers.
    #[default]
    #[serde(rename = "2f-85")]
    TwoF85,
    /// 2F-140: 140 mm stroke.
    #[serde(rename = "2f-140")]
    TwoF140,
    /// Hand-E: 50 mm stroke, parallel fingers.
    #[serde(rename = "hand-e")]
    HandE,
}

/// A variant's facts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VariantSpec {
    /// The profile's name (`robotiq.variant`).
    pub name: &'static str,
    /// Full stroke, mm (fingertip opening at rPR 0).
    pub stroke_mm: f32,
    /// Finger speed at rSP 0 and at rSP 255, mm/s.
    pub speed_mm_s: (f32, f32),
    /// Grip force at rFR 0 and at rFR 255, N.
    pub force_n: (f32, f32),
    /// The URDF joint (robotiq_description), without the prefix.
    pub urdf_joint: &'static str,
    /// The URDF joint's closed limit (rad, or m for the prismatic Hand-E); open is 0.
    pub closed: f32,
}

impl Variant {
    pub const ALL: [Variant; 3] = [Variant::TwoF85, Variant::TwoF140, Variant::HandE];

    pub const fn spec(self) -> VariantSpec {
        match self {
            Variant::TwoF85 => VariantSpec {
                name: "2f-85",
                stroke_mm: 85.0,
                speed_mm_s: (20.0, 150.0),
                force_n: (20.0, 235.0),
                urdf_joint: "finger_joint",
                closed: 0.8,
            },
            Variant::TwoF140 => VariantSpec {
                name: "2f-140",
                stroke_mm: 140.0,
                speed_mm_s: (30.0, 250.0),
                force_n: (10.0, 125.0),
                urdf_joint: "finger_joint",
                closed: 0.7,
            },
            Variant::HandE => VariantSpec {
                name: "hand-e",
                stroke_mm: 50.0,
                speed_mm_s: (20.0, 150.0),
                force_n: (20.0, 185.0),
                urdf_joint: "hande_left_finger_joint",
                closed: 0.025,
            },
        }
    }

    pub fn name(self) -> &'static str {
        self.spec().name
    }
}

impl VariantSpec {
    /// Finger speed at `rsp`, position counts per second (255 counts = the stroke).
    pub fn counts_per_s(&self, rsp: u8) -> f32 {
        let (lo, hi) = self.speed_mm_s;
        let mm_s = lo + (hi - lo) * f32::from(rsp) / 255.0;
        mm_s * 255.0 / self.stroke_mm
    }

    /// Grip force at `rfr`, N.
    pub fn force_at(&self, rfr: u8) -> f32 {
        let (lo, hi) = self.force_n;
        lo + (hi - lo) * f32::from(rfr) / 255.0
    }
}

/// The URDF joint name for a gripper on `side`: robotiq_description's macros take a
/// `prefix`; a centre gripper has none, a left or right one `left_` / `right_`.
pub fn urdf_name(variant: Variant, side: Side) -> String {
    match side {
        Side::Left | Side::Right => format!("{}_{}", side.as_str(), variant.spec().urdf_joint),
        Side::Center => variant.spec().urdf_joint.to_string(),
    }
}

/// The table of a `variant` on `side`.
pub fn table(variant: Variant, side: Side) -> DeviceTable {
    let v = variant.spec();
    let jaw = JointMap {
        name: crate::model::GRIPPER_JOINTS[0],
        wire_index: 0,
        urdf: urdf_name(variant, side),
        sign: 1.0,
        scale: 255.0 / v.closed,
        offset: 0.0,
        // The fingers' mechanical stops.
        limits: Limits::at_stops(0.0, v.closed),
    };
    DeviceTable {
        // A jaw of a fraction of a radian (or 25 mm): the tolerance is 4 % of its travel
        // (about 10 position counts), 500 ms like every gripper. The gripper reports an object
        // itself (gOBJ): contact is what it says.
        motion: MotionThresholds {
            tolerance: 0.04 * v.closed,
            ..MotionThresholds::GRIPPER
        }
        .with_contact(Contact::Reported),
        ..DeviceTable::with_postures(
            DeviceKind::Robotiq,
            side,
            vec![jaw],
            (vec![0.0], vec![v.closed]),
            // The gripper takes no gains: these only fill the canonical hold command.
            (crate::dex1::table::KP, crate::dex1::table::KD),
            UrdfFrame::Canonical,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{JointCommand, JointState};

    #[test]
    fn closed_is_255_and_open_is_0_on_every_variant() {
        for v in Variant::ALL {
            let t = table(v, Side::Center);
            let j = &t.joints[0];
            assert_eq!(j.q_to_wire(0.0), 0.0, "{v:?}");
            assert!((j.q_to_wire(v.spec().closed) - 255.0).abs() < 1e-3, "{v:?}");
            assert_eq!(t.urdf_frame, UrdfFrame::Canonical);
            let closed = t.closure_targets(1.0, None).unwrap();
            assert!((t.to_wire(&closed)[0].q - 255.0).abs() < 1e-3);
            let half = t.closure_of_state(&[JointState {
                q: v.spec().closed / 2.0,
                ..Default::default()
            }]);
            assert!((half - 0.5).abs() < 1e-4, "{v:?} {half}");
            let _ = JointCommand::default();
        }
        assert_eq!(table(Variant::TwoF85, Side::Center).joints[0].urdf, "finger_joint");
        assert_eq!(table(Variant::TwoF140, Side::Left).joints[0].urdf, "left_finger_joint");
        assert_eq!(
            table(Variant::HandE, Side::Right).joints[0].urdf,
            "right_hande_left_finger_joint"
        );
    }

    #[test]
    fn speeds_span_the_variants_ranges() {
        let s = Variant::TwoF85.spec();
        // 150 mm/s over 85 mm: 450 counts/s; 20 mm/s: 60 counts/s.
        assert!((s.counts_per_s(255) - 450.0).abs() < 0.01);
        assert!((s.counts_per_s(0) - 60.0).abs() < 0.01);
        assert_eq!(Variant::TwoF140.spec().force_at(255), 125.0);
    }
}
