//! Dex5-1 mapping (docs/sources.md §7 "Dex5-1"): wire entry ↔ canonical joint ↔ URDF joint ↔
//! motor, signs, limits, the coupled joints, gains, and the choices handgate makes where the
//! sources disagree or say nothing ([`Conventions`]: the profile's `[devices.dex5]` keys).
//!
//! Entries (= canonical order, [`super::JOINTS`]): four per long finger, index, middle, ring,
//! pinky (URDF `Roll_x1` spread, `Pitch_x2`, `Pitch_x3`, `Pitch_x4` flex, x = 2..5), then the
//! thumb (`Yaw_11`, `Roll_12`, `Pitch_13`, `Pitch_14`); the URDF names end in `L` / `R`. Both
//! public clients index the state this way; xr_teleoperate also commands this way.
//!
//! Motors (unitree_dds_wrapper's joint → motor map, restated): thumb 0..3, then three per long
//! finger (spread, `Pitch_x2`, and one motor for `Pitch_x3` and `Pitch_x4` together). The
//! distal `Pitch_x4` has no motor of its own: it is **coupled** to `Pitch_x3` (the URDFs
//! declare no mimic joint). handgate models the coupling as proportional over the two URDF
//! ranges, `q_x4 = q_x3 · 1.3963 / 1.6842` (≈ 0.829, [`COUPLING`]), an assumption and a
//! convention ([`Conventions::coupling`]).
//!
//! Units and signs: the wire q is the URDF angle in rad (`UrdfFrame::Wire`). Every flex joint's
//! URDF range starts at 0 and goes positive on both hands, so positive = closing (0 is the
//! open hand, an inference from the ranges). The thumb's `Roll_12` is the mirror case: its
//! range is [−1.8151, 0] on the left and [0, 1.8151] on the right, so the left's canonical
//! sign is −1. The spreads (`Roll_x1`, ±0.384) and the thumb's yaw close nothing; their
//! canonical sign is the wire's, on both hands.
//!
//! Gains: the sources disagree (xr_teleoperate: fingers kp 0.10 / kd 0.001, thumb 1.0 / 0.02;
//! unitree_dds_wrapper: thumb yaw 10 / 0.9, the other thumb motors 5 / 0.4, fingers 0.02 /
//! 0.0004) and xr_teleoperate's note that the thumb's torques are in N·m and the fingers' in
//! mN·m is unconfirmed. So a Dex5's canonical kp / kd are **relative**: 1.0 is the gain the
//! profile's [`GainSource`] gives that entry, 0 is limp; the codecs multiply and divide by it
//! ([`Gains`]). Closure and hold use 1.0.

use serde::{Deserialize, Serialize};

use super::{JOINTS, MOTORS, THUMB_FIRST, WIRE_LEN};
use crate::mapping::{ClosureMap, DeviceTable, JointMap, Limits, UrdfFrame};
use crate::model::{DeviceKind, Side};

/// A finger.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Finger {
    Index,
    Middle,
    Ring,
    Pinky,
    Thumb,
}

/// What a joint does (its URDF name's prefix), which decides whether it closes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Role {
    /// A long finger's sideways `Roll_x1`: closes nothing.
    Spread,
    /// The thumb's `Yaw_11`: closes nothing.
    Yaw,
    /// The thumb's `Roll_12`, across the palm: closes away from 0 (mirrored between hands).
    Opposition,
    /// A `Pitch` joint: closes towards positive angles on both hands.
    Flex,
}

/// One wire entry of `HandCmd_` / `HandState_`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Slot {
    pub finger: Finger,
    pub role: Role,
    /// The URDF joint's name without its side letter (`Pitch_23`).
    pub urdf: &'static str,
    /// The motor moving it (unitree_dds_wrapper's numbering, thumb first).
    pub motor: usize,
}

const fn slot(finger: Finger, role: Role, urdf: &'static str, motor: usize) -> Slot {
    Slot {
        finger,
        role,
        urdf,
        motor,
    }
}

use Finger::{Index, Middle, Pinky, Ring, Thumb};
use Role::{Flex, Opposition, Spread, Yaw};

/// Every entry, wire order (docs/sources.md §7 "Dex5-1": xr_teleoperate's `dex5_api_joint_names`,
/// unitree_dds_wrapper's state index and joint → motor map).
pub const SLOTS: [Slot; WIRE_LEN] = [
    slot(Index, Spread, "Roll_21", 4),
    slot(Index, Flex, "Pitch_22", 5),
    slot(Index, Flex, "Pitch_23", 6),
    slot(Index, Flex, "Pitch_24", 6),
    slot(Middle, Spread, "Roll_31", 7),
    slot(Middle, Flex, "Pitch_32", 8),
    slot(Middle, Flex, "Pitch_33", 9),
    slot(Middle, Flex, "Pitch_34", 9),
    slot(Ring, Spread, "Roll_41", 10),
    slot(Ring, Flex, "Pitch_42", 11),
    slot(Ring, Flex, "Pitch_43", 12),
    slot(Ring, Flex, "Pitch_44", 12),
    slot(Pinky, Spread, "Roll_51", 13),
    slot(Pinky, Flex, "Pitch_52", 14),
    slot(Pinky, Flex, "Pitch_53", 15),
    slot(Pinky, Flex, "Pitch_54", 15),
    slot(Thumb, Yaw, "Yaw_11", 0),
    slot(Thumb, Opposition, "Roll_12", 1),
    slot(Thumb, Flex, "Pitch_13", 2),
    slot(Thumb, Flex, "Pitch_14", 3),
];

/// Canonical limits (rad, positive = closing) per entry: the URDFs' ranges, the narrower
/// figure where the two hands' files differ in the last decimals (`Pitch_x2` 1.5708 left,
/// 1.5707963 on the right's index and middle; `Pitch_x3` 1.684242699 left, 1.6842 on the
/// right's ring and pinky; `Pitch_x4` 1.3963 left, 1.396263378 on the right's index and
/// middle; `Pitch_13` 1.7652 left, 1.765226 right), so both hands have one canonical table
/// inside both files' ranges. The URDFs' literal figures (1.5707963 is theirs, not π/2).
#[allow(clippy::approx_constant)]
pub const LIMITS: [(f32, f32); WIRE_LEN] = per_finger(
    [
        (-0.38397, 0.38397),
        (0.0, 1.570_796_3),
        (0.0, 1.6842),
        (0.0, 1.396_263_4),
    ],
    [(-0.5867, 0.6803), (0.0, 1.8151), (0.0, 1.7652), (0.0, 1.6406)],
);

/// Fastest motion per entry, rad/s: the left URDF's `velocity` (the right file gives 0 for
/// some spreads, read as "not given"). The emulator's speed limit. The URDF's literal figures.
#[allow(clippy::approx_constant)]
pub const VELOCITY: [f32; WIRE_LEN] = per_finger([0.76794, 3.1416, 3.3685, 2.7925], [4.18; 4]);

/// A value per entry from one row for every long finger (spread, then the flex joints from
/// the palm out) and one for the thumb.
const fn per_finger<T: Copy>(finger: [T; 4], thumb: [T; 4]) -> [T; WIRE_LEN] {
    let mut out = [thumb[0]; WIRE_LEN];
    let mut i = 0;
    while i < WIRE_LEN {
        out[i] = if i < THUMB_FIRST {
            finger[i % 4]
        } else {
            thumb[i - THUMB_FIRST]
        };
        i += 1;
    }
    out
}

/// Largest feed-forward torque a command may carry, wire units: the URDFs' `effort` (0.93,
/// the left file; the right gives 0 for the long fingers). Both clients send 0.
pub const MAX_TAU: f32 = 0.93;

/// Largest canonical (relative) gain: ten times the profile's gains, the largest ratio
/// between the two sources' figures (the thumb yaw's kp, 10 against 1.0).
pub const MAX_GAIN_FACTOR: f32 = 10.0;

/// `Pitch_x4` per rad of `Pitch_x3` by default (the coupling, an assumption: proportional over
/// the two URDF ranges, so the open and the fully closed ends meet).
pub const COUPLING: f32 = LIMITS[3].1 / LIMITS[2].1;

/// The largest coupling a profile may set: a linkage turning the distal joint more than twice
/// as far as the middle one is not a finger's.
pub const MAX_COUPLING: f32 = 2.0;

/// Share of each closing joint's range the default closed posture flexes (the Dex3-1's rule,
/// docs/profiles.md `closure.closed`; an assumption).
pub const CLOSED_SHARE: f32 = 0.9;
/// The thumb's `Roll_12` (across the palm) in the closed posture, canonical rad: about half
/// its range, so a fist wraps the thumb over the fingers (an assumption).
pub const CLOSED_THUMB_ROLL: f32 = 0.9;

/// Whether entry `i` has no motor of its own (a `Pitch_x4`).
pub fn is_coupled(i: usize) -> bool {
    i < THUMB_FIRST && i % 4 == 3
}

/// The entry whose target moves entry `i`'s motor: `i` itself, or the `Pitch_x3` of a
/// coupled `Pitch_x4`.
pub fn driver(i: usize) -> usize {
    if is_coupled(i) {
        i - 1
    } else {
        i
    }
}

/// The entry driving motor `m` (the first entry on it).
pub fn motor_driver(m: usize) -> Option<usize> {
    SLOTS.iter().position(|s| s.motor == m)
}

/// Wire direction of canonical "closing" for entry `i` on `side`: −1 only for the left
/// thumb's `Roll_12`.
pub fn wire_sign(side: Side, i: usize) -> f32 {
    match (SLOTS[i].role, side) {
        (Role::Opposition, Side::Left) => -1.0,
        _ => 1.0,
    }
}

/// Wire limits (rad) of entry `i` on `side`, ordered.
pub fn wire_limits(side: Side, i: usize) -> (f32, f32) {
    let (lo, hi) = LIMITS[i];
    let s = wire_sign(side, i);
    ((lo * s).min(hi * s), (lo * s).max(hi * s))
}

/// Wire limits (rad) of the motor entry `i` drives on `side`: its own, narrowed for a
/// `Pitch_x3` to where its coupled `Pitch_x4` (at `coupling` times its angle) stays in its
/// range; one motor moves both, so it stops when either joint does.
pub fn motor_limits(side: Side, i: usize, coupling: f32) -> (f32, f32) {
    let (lo, hi) = wire_limits(side, i);
    match (i + 1 < WIRE_LEN && is_coupled(i + 1), coupling > 0.0) {
        (true, true) => {
            let (clo, chi) = wire_limits(side, i + 1);
            (lo.max(clo / coupling), hi.min(chi / coupling))
        }
        _ => (lo, hi),
    }
}

/// Whether entry `i` closes the hand (not a spread, not the thumb's yaw).
pub fn closes(i: usize) -> bool {
    matches!(SLOTS[i].role, Role::Opposition | Role::Flex)
}

/// The wire direction of entry `i` closing on an object on `side`; `None` for the spreads and
/// the thumb's yaw, which close nothing.
pub fn closing_dir(side: Side, i: usize) -> Option<f32> {
    closes(i).then(|| wire_sign(side, i))
}

/// Which URDF's joint names `rt/joint_states` uses. The two files differ in one name: the
/// left ring finger's spread is `Link_41L` in the official description and `Roll_41L` in
/// xr_teleoperate's copy (which renamed it, docs/sources.md §7).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UrdfNames {
    /// unitreerobotics/unitree_ros `dexterous_hand_description/dex5_1`.
    #[default]
    UnitreeRos,
    /// unitreerobotics/xr_teleoperate `assets/unitree_hand_Dex5`.
    XrTeleoperate,
}

impl UrdfNames {
    /// The profile value.
    pub fn as_str(self) -> &'static str {
        match self {
            UrdfNames::UnitreeRos => "unitree_ros",
            UrdfNames::XrTeleoperate => "xr_teleoperate",
        }
    }
}

/// The URDF joint name of entry `i` on `side`.
pub fn urdf_name(side: Side, i: usize, names: UrdfNames) -> String {
    let letter = match side {
        Side::Right => 'R',
        Side::Left | Side::Center => 'L',
    };
    let s = &SLOTS[i];
    if names == UrdfNames::UnitreeRos && letter == 'L' && s.urdf == "Roll_41" {
        return "Link_41L".to_string();
    }
    format!("{}{letter}", s.urdf)
}

/// How many entries a command carries and in which order. The state always has 20.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CommandLayout {
    /// One entry per joint, in the state's order (xr_teleoperate: 20 entries).
    #[default]
    Joints,
    /// One entry per motor, in unitree_dds_wrapper's motor order (16 entries, thumb first): the
    /// order of its gain arrays. No public client sends it; kept for a service that wants it.
    Motors,
}

impl CommandLayout {
    /// Entries in a command.
    pub fn entries(self) -> usize {
        match self {
            CommandLayout::Joints => WIRE_LEN,
            CommandLayout::Motors => MOTORS,
        }
    }

    /// The command entry carrying joint entry `i`'s target (a coupled joint's is its motor's).
    pub fn entry(self, i: usize) -> usize {
        match self {
            CommandLayout::Joints => i,
            CommandLayout::Motors => SLOTS[i].motor,
        }
    }

    /// The joint entry whose target command entry `e` carries.
    pub fn joint(self, e: usize) -> Option<usize> {
        match self {
            CommandLayout::Joints => (e < WIRE_LEN).then_some(e),
            CommandLayout::Motors => motor_driver(e),
        }
    }
}

/// Whose default gains handgate sends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GainSource {
    /// xr_teleoperate's `Dex5_1_Controller`: long fingers kp 0.10 / kd 0.001, thumb 1.0 / 0.02.
    #[default]
    XrTeleoperate,
    /// unitree_dds_wrapper 2.0.9 `DEFAULT_KP` / `DEFAULT_KD`, per motor: thumb yaw 10 / 0.9,
    /// the other thumb motors 5 / 0.4, the long fingers' 0.02 / 0.0004.
    UnitreeDdsWrapper,
}

impl GainSource {
    /// The profile value.
    pub fn as_str(self) -> &'static str {
        match self {
            GainSource::XrTeleoperate => "xr_teleoperate",
            GainSource::UnitreeDdsWrapper => "unitree_dds_wrapper",
        }
    }
}

/// Wire gains per entry: what a canonical (relative) gain of 1.0 becomes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gains {
    pub kp: [f32; WIRE_LEN],
    pub kd: [f32; WIRE_LEN],
}

impl Gains {
    /// The figures of `source`, per entry (a coupled entry takes its motor's).
    pub fn of(source: GainSource) -> Self {
        let pairs = SLOTS.map(|s| match (source, s.finger, s.motor) {
            (GainSource::XrTeleoperate, Finger::Thumb, _) => (1.0, 0.02),
            (GainSource::XrTeleoperate, _, _) => (0.10, 0.001),
            (GainSource::UnitreeDdsWrapper, _, 0) => (10.0, 0.9),
            (GainSource::UnitreeDdsWrapper, _, 1..=3) => (5.0, 0.4),
            (GainSource::UnitreeDdsWrapper, _, _) => (0.02, 0.0004),
        });
        Self {
            kp: pairs.map(|p| p.0),
            kd: pairs.map(|p| p.1),
        }
    }

    /// `Err` unless every gain is finite and > 0 (the front divides by them).
    pub fn validate(&self) -> Result<(), String> {
        match self.kp.iter().chain(&self.kd).find(|g| !(g.is_finite() && **g > 0.0)) {
            Some(g) => Err(format!("every Dex5 gain must be finite and > 0, got {g}")),
            None => Ok(()),
        }
    }

    /// Wire (kp, kd) of entry `i` for canonical relative gains.
    pub fn to_wire(&self, i: usize, kp: f32, kd: f32) -> (f32, f32) {
        (kp * self.kp[i], kd * self.kd[i])
    }

    /// Canonical relative (kp, kd) of entry `i` for wire gains (0 where the table's gain is
    /// not usable, which [`Self::validate`] refuses).
    pub fn from_wire(&self, i: usize, kp: f32, kd: f32) -> (f32, f32) {
        let rel = |w: f32, g: f32| if g > 0.0 { w / g } else { 0.0 };
        (rel(kp, self.kp[i]), rel(kd, self.kd[i]))
    }
}

impl Default for Gains {
    fn default() -> Self {
        Self::of(GainSource::default())
    }
}

/// Where the sources disagree or are silent, which way handgate goes (docs/profiles.md
/// "Assumptions"): a device's `[devices.dex5]` section, one key per field.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Conventions {
    pub gains: GainSource,
    pub urdf_names: UrdfNames,
    pub command_layout: CommandLayout,
    /// `Pitch_x4` per rad of `Pitch_x3` (default [`COUPLING`]).
    pub coupling: f32,
}

impl Default for Conventions {
    fn default() -> Self {
        Self {
            gains: GainSource::default(),
            urdf_names: UrdfNames::default(),
            command_layout: CommandLayout::default(),
            coupling: COUPLING,
        }
    }
}

impl Conventions {
    /// `Err` with a reason (for the key `coupling`) for a coupling that is not finite, not
    /// positive or above [`MAX_COUPLING`].
    pub fn validate(&self) -> Result<(), String> {
        let k = self.coupling;
        if k.is_finite() && k > 0.0 && k <= MAX_COUPLING {
            Ok(())
        } else {
            Err(format!(
                "must be above 0 and at most {MAX_COUPLING} (rad of each Pitch_x4 per rad of its Pitch_x3), got {k}"
            ))
        }
    }
}

/// What the codecs and the emulator take from the conventions, resolved once: the gains per
/// entry, the command layout and the coupling.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WireConfig {
    pub gains: Gains,
    pub layout: CommandLayout,
    pub coupling: f32,
}

impl WireConfig {
    pub fn of(c: &Conventions) -> Self {
        Self {
            gains: Gains::of(c.gains),
            layout: c.command_layout,
            coupling: c.coupling,
        }
    }

    /// A coupled `Pitch_x4` for its `Pitch_x3` at `q` (position or velocity, canonical or
    /// wire: both are the same for the flex joints).
    pub fn coupled(&self, q: f32) -> f32 {
        q * self.coupling
    }
}

impl Default for WireConfig {
    fn default() -> Self {
        Self::of(&Conventions::default())
    }
}

/// Canonical postures, canonical order.
pub fn open_posture() -> [f32; WIRE_LEN] {
    [0.0; WIRE_LEN]
}

/// [`CLOSED_SHARE`] of every flex joint's motor range ([`motor_limits`]: a `Pitch_x3` no
/// further than its coupled `Pitch_x4` can follow), each coupled joint by `coupling`, the
/// thumb's roll at [`CLOSED_THUMB_ROLL`], spreads and yaw at 0.
pub fn closed_posture(coupling: f32) -> [f32; WIRE_LEN] {
    let mut p = [0.0; WIRE_LEN];
    for i in 0..WIRE_LEN {
        p[i] = match SLOTS[i].role {
            Role::Spread | Role::Yaw => 0.0,
            Role::Opposition => CLOSED_THUMB_ROLL,
            Role::Flex if is_coupled(i) => p[i - 1] * coupling,
            // The flex joints' canonical and wire ranges are the same on both hands.
            Role::Flex => CLOSED_SHARE * motor_limits(Side::Right, i, coupling).1,
        };
    }
    p
}

/// Where a relaxed hand rests, canonical rad: flex joints slightly bent, spreads and yaw
/// centred, coupled joints by `coupling` (an assumption; never all zero, since
/// xr_teleoperate waits for a non-zero state).
pub fn rest_posture(coupling: f32) -> [f32; WIRE_LEN] {
    let mut p = [0.0; WIRE_LEN];
    for i in 0..WIRE_LEN {
        p[i] = match SLOTS[i].role {
            Role::Spread | Role::Yaw => 0.0,
            Role::Flex if is_coupled(i) => (p[i - 1] * coupling).min(LIMITS[i].1),
            Role::Opposition | Role::Flex => 0.1,
        };
    }
    p
}

/// The Dex5-1 table for `side` under `conventions` (its URDF names, the coupling of its
/// postures).
pub fn table(side: Side, conventions: &Conventions) -> DeviceTable {
    let joints = (0..WIRE_LEN)
        .map(|i| JointMap {
            name: JOINTS[i],
            wire_index: i,
            urdf: urdf_name(side, i, conventions.urdf_names),
            sign: wire_sign(side, i),
            scale: 1.0,
            offset: 0.0,
            limits: Limits::new(LIMITS[i].0, LIMITS[i].1),
        })
        .collect();
    DeviceTable {
        kind: DeviceKind::Dex5,
        side,
        joints,
        closure: ClosureMap::Postures {
            open: open_posture().to_vec(),
            closed: closed_posture(conventions.coupling).to_vec(),
            kp: 1.0,
            kd: 1.0,
        },
        hold_kp: 1.0,
        hold_kd: 1.0,
        max_step: None,
        max_kp: MAX_GAIN_FACTOR,
        max_kd: MAX_GAIN_FACTOR,
        max_tau: MAX_TAU,
        urdf_frame: UrdfFrame::Wire,
        motion: crate::motion::MotionThresholds::HAND,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The default Dex5 table for `side`.
    pub(crate) fn t(side: Side) -> DeviceTable {
        table(side, &Conventions::default())
    }

    /// unitree_dds_wrapper 2.0.9's joint → motor map (`JOINT2URDF_INDEX`), listed as it lists
    /// it: in wire entry order, index finger first, thumb last (test data).
    const WRAPPER_MOTOR_OF_ENTRY: [usize; 20] = [4, 5, 6, 6, 7, 8, 9, 9, 10, 11, 12, 12, 13, 14, 15, 15, 0, 1, 2, 3];

    #[test]
    fn the_motor_map_is_the_wrappers_and_every_motor_has_one_driver() {
        for (e, m) in WRAPPER_MOTOR_OF_ENTRY.iter().enumerate() {
            assert_eq!(SLOTS[e].motor, *m, "entry {e}");
        }
        for m in 0..MOTORS {
            let d = motor_driver(m).unwrap();
            assert_eq!(driver(d), d, "motor {m}: its first entry drives it");
        }
        assert_eq!(motor_driver(MOTORS), None);
        let coupled: Vec<usize> = (0..WIRE_LEN).filter(|i| is_coupled(*i)).collect();
        assert_eq!(coupled, [3, 7, 11, 15]);
        assert!(coupled.iter().all(|i| SLOTS[*i].motor == SLOTS[driver(*i)].motor));
        for l in [CommandLayout::Joints, CommandLayout::Motors] {
            for e in 0..l.entries() {
                let j = l.joint(e).unwrap();
                assert_eq!(l.entry(j), e, "{l:?} entry {e}");
            }
            assert_eq!(l.joint(l.entries()), None);
        }
    }

    #[test]
    fn urdf_names_follow_the_chosen_file() {
        let left = t(Side::Left);
        let right = t(Side::Right);
        assert_eq!(left.joints[0].urdf, "Roll_21L");
        assert_eq!(left.joints[8].urdf, "Link_41L", "the official left file's name");
        assert_eq!(right.joints[8].urdf, "Roll_41R");
        assert_eq!(right.joints[19].urdf, "Pitch_14R");
        assert_eq!(urdf_name(Side::Left, 8, UrdfNames::XrTeleoperate), "Roll_41L");
        // xr_teleoperate's names, in wire order, are every entry's.
        let xr: Vec<String> = (0..WIRE_LEN)
            .map(|i| urdf_name(Side::Right, i, UrdfNames::XrTeleoperate))
            .collect();
        assert_eq!(xr[..4], ["Roll_21R", "Pitch_22R", "Pitch_23R", "Pitch_24R"]);
        assert_eq!(xr[16..], ["Yaw_11R", "Roll_12R", "Pitch_13R", "Pitch_14R"]);
    }

    /// The URDFs' ranges as written per side (test data, docs/sources.md §7): the table's wire
    /// limits lie inside them, within the last decimals the two files disagree on.
    #[test]
    #[allow(clippy::approx_constant, clippy::excessive_precision)] // the URDFs' literal figures
    fn wire_limits_are_the_urdf_ranges_of_each_side() {
        let urdf = |side: Side, urdf: &str| -> (f32, f32) {
            let right = side == Side::Right;
            let inner = urdf.as_bytes().get(6).is_some_and(|c| *c <= b'3'); // index, middle: Pitch_2x, Pitch_3x
            match urdf {
                "Roll_12" if right => (0.0, 1.8151),
                "Roll_12" => (-1.8151, 0.0),
                "Yaw_11" => (-0.5867, 0.6803),
                "Pitch_13" if right => (0.0, 1.765226),
                "Pitch_13" => (0.0, 1.7652),
                "Pitch_14" => (0.0, 1.6406),
                u if u.starts_with("Roll") => (-0.38397, 0.38397),
                u if u.ends_with('2') && right && inner => (0.0, 1.5707963),
                u if u.ends_with('2') => (0.0, 1.5708),
                u if u.ends_with('3') && right && !inner => (0.0, 1.6842),
                u if u.ends_with('3') => (0.0, 1.684242699),
                _ if right && inner => (0.0, 1.396_263_378),
                _ => (0.0, 1.3963),
            }
        };
        for side in [Side::Left, Side::Right] {
            for (i, s) in SLOTS.iter().enumerate() {
                let (lo, hi) = wire_limits(side, i);
                let (ulo, uhi) = urdf(side, s.urdf);
                assert!(
                    ulo - 1e-6 <= lo && hi <= uhi + 1e-6 && (lo - ulo).abs() < 1e-4 && (hi - uhi).abs() < 1e-4,
                    "{side:?} {}: {lo}..{hi} against the URDF's {ulo}..{uhi}",
                    s.urdf
                );
            }
        }
    }

    #[test]
    fn closing_is_positive_on_the_wire_except_the_left_thumb_roll() {
        for side in [Side::Left, Side::Right] {
            let tb = t(side);
            let w = tb.to_wire(&tb.closure_targets(1.0, None).unwrap());
            for (i, w) in w.iter().enumerate() {
                match (SLOTS[i].role, side) {
                    (Role::Opposition, Side::Left) => assert!(w.q < -0.5, "{i}: {}", w.q),
                    (Role::Spread | Role::Yaw, _) => assert_eq!(w.q, 0.0),
                    _ => assert!(w.q > 0.5, "{side:?} {i}: {}", w.q),
                }
                let (lo, hi) = wire_limits(side, i);
                assert!(lo <= w.q && w.q <= hi);
            }
            assert_eq!(closing_dir(side, 0), None);
            assert_eq!(closing_dir(side, 16), None);
            assert_eq!(closing_dir(side, 17), Some(if side == Side::Left { -1.0 } else { 1.0 }));
        }
    }

    #[test]
    fn postures_respect_the_coupling_and_the_closure_estimate() {
        let tb = t(Side::Right);
        let closed = closed_posture(COUPLING);
        let rest = rest_posture(COUPLING);
        for i in [3, 7, 11, 15] {
            let stiff = closed_posture(MAX_COUPLING);
            assert!(
                (stiff[i] - CLOSED_SHARE * LIMITS[i].1).abs() < 1e-6 && stiff[i - 1] < closed[i - 1],
                "a stiffer coupling closes the distal joint as far, the middle one less"
            );
            assert_eq!(
                motor_limits(Side::Left, i - 1, MAX_COUPLING).1,
                LIMITS[i].1 / MAX_COUPLING
            );
            assert!((motor_limits(Side::Left, i - 1, COUPLING).1 - LIMITS[i - 1].1).abs() < 1e-6);
            assert_eq!(motor_limits(Side::Left, i, COUPLING), wire_limits(Side::Left, i));
            assert!((closed[i] - COUPLING * closed[i - 1]).abs() < 1e-6);
            assert!(
                (closed[i] - CLOSED_SHARE * LIMITS[i].1).abs() < 1e-4,
                "both ends of the coupling meet"
            );
            assert!((rest[i] - COUPLING * rest[i - 1]).abs() < 1e-6);
        }
        assert!(rest.iter().any(|q| *q != 0.0));
        for (i, (c, r)) in closed.iter().zip(rest).enumerate() {
            let l = tb.joints[i].limits;
            assert!(l.contains(*c) && l.contains(r), "{i}");
        }
        assert!((tb.closure_of(&closed) - 1.0).abs() < 1e-6);
        assert_eq!(tb.closure_of(&open_posture()), 0.0);
        let half = tb.closure_targets(0.5, None).unwrap();
        let q: Vec<f32> = half.iter().map(|c| c.q).collect();
        assert!((tb.closure_of(&q) - 0.5).abs() < 1e-6);
        assert!(
            half.iter().all(|c| c.kp == 1.0 && c.kd == 1.0),
            "closure at the profile's gains"
        );
    }

    #[test]
    fn gains_per_source_and_relative_round_trip() {
        let xr = Gains::of(GainSource::XrTeleoperate);
        assert_eq!((xr.kp[0], xr.kd[0]), (0.10, 0.001));
        assert_eq!((xr.kp[15], xr.kd[15]), (0.10, 0.001));
        assert_eq!((xr.kp[16], xr.kd[16]), (1.0, 0.02));
        let w = Gains::of(GainSource::UnitreeDdsWrapper);
        assert_eq!((w.kp[16], w.kd[16]), (10.0, 0.9), "thumb yaw, motor 0");
        assert_eq!((w.kp[19], w.kd[19]), (5.0, 0.4));
        assert_eq!((w.kp[3], w.kd[3]), (0.02, 0.0004), "a coupled entry takes its motor's");
        assert!(xr.validate().is_ok() && w.validate().is_ok());
        let mut bad = xr;
        bad.kd[4] = 0.0;
        assert!(bad.validate().is_err());
        assert_eq!(bad.from_wire(4, 0.1, 0.5), (1.0, 0.0));
        for i in 0..WIRE_LEN {
            let (kp, kd) = w.to_wire(i, 1.0, 1.0);
            assert_eq!((kp, kd), (w.kp[i], w.kd[i]));
            let (rkp, rkd) = w.from_wire(i, kp * 0.5, kd * 2.0);
            assert!((rkp - 0.5).abs() < 1e-6 && (rkd - 2.0).abs() < 1e-6);
        }
    }

    #[test]
    fn conventions_parse_from_their_key_names() {
        let c: Conventions = serde_json::from_str(
            r#"{"gains": "unitree_dds_wrapper", "urdf_names": "xr_teleoperate", "command_layout": "motors"}"#,
        )
        .unwrap();
        assert_eq!(
            c,
            Conventions {
                gains: GainSource::UnitreeDdsWrapper,
                urdf_names: UrdfNames::XrTeleoperate,
                command_layout: CommandLayout::Motors,
                coupling: COUPLING,
            }
        );
        for g in [GainSource::XrTeleoperate, GainSource::UnitreeDdsWrapper] {
            assert_eq!(serde_json::to_string(&g).unwrap(), format!("\"{}\"", g.as_str()));
        }
        for u in [UrdfNames::UnitreeRos, UrdfNames::XrTeleoperate] {
            assert_eq!(serde_json::to_string(&u).unwrap(), format!("\"{}\"", u.as_str()));
        }
        let d: Conventions = serde_json::from_str("{}").unwrap();
        assert_eq!(d, Conventions::default());
        assert!(d.validate().is_ok());
        assert!(serde_json::from_str::<Conventions>(r#"{"gain": "x"}"#).is_err());
        let k: Conventions = serde_json::from_str(r#"{"coupling": 1.0}"#).unwrap();
        assert_eq!(WireConfig::of(&k).coupled(0.5), 0.5);
        assert_eq!(WireConfig::of(&k).layout, CommandLayout::Joints);
        for bad in [0.0, -0.5, 2.5, f32::NAN] {
            assert!(Conventions { coupling: bad, ..d }.validate().is_err(), "{bad}");
        }
        let c = Conventions {
            urdf_names: UrdfNames::XrTeleoperate,
            coupling: 1.0,
            ..d
        };
        let t = table(Side::Left, &c);
        assert_eq!(t.joints[8].urdf, "Roll_41L");
        let ClosureMap::Postures { closed, .. } = &t.closure else {
            panic!("{:?}", t.closure)
        };
        assert_eq!(
            closed[3],
            closed[2].min(LIMITS[3].1),
            "the coupling reaches the postures"
        );
    }
}
