//! Which layout a raw sample of a Unitree type was written in.
//!
//! Unitree changed the layout of some hand messages without changing their type names
//! (docs/sources.md §1): `HandCmd_` gained `reserve[4]` in December 2024, `PressSensorState_`
//! gained `lost`/`reserve` in February 2025, and the G1 basic-services page still prints an
//! older `HandState_` (IMU before the pressure sequence, no `system_v`/`device_v`/`error`) and an
//! hg `MotorCmd_` with three reserve words. CycloneDDS 0.10.2 matches endpoints by type name
//! only, so a client built against an old layout matches and exchanges samples that decode
//! into garbage (or not at all). The only trace on the wire is the sample's size: [`check`]
//! decodes a sample's bytes as the current layout and as each known older one and says which
//! one accounts for every byte.
//!
//! [`Raw`] is a [`TopicType`] that registers a wire type's name but keeps each sample's bytes
//! undecoded, so a reader of it sees whatever layout a writer sends.

use std::fmt;
use std::marker::PhantomData;

use cyclonedds_rs::TopicType;
use serde::de::{DeserializeOwned, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::unitree_hg as hg;
use crate::{from_cdr_body, to_cdr_le, DdsTypeName};

/// A sample of `T`'s DDS type, kept as the bytes after the 4-byte encapsulation header (the
/// byte order is not kept; [`check`] tries both).
pub struct Raw<T> {
    pub bytes: Vec<u8>,
    _type: PhantomData<fn() -> T>,
}

impl<T> Raw<T> {
    pub fn new(bytes: Vec<u8>) -> Self {
        Self {
            bytes,
            _type: PhantomData,
        }
    }
}

impl<T> fmt::Debug for Raw<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Raw").field("len", &self.bytes.len()).finish()
    }
}

impl<T> Clone for Raw<T> {
    fn clone(&self) -> Self {
        Self::new(self.bytes.clone())
    }
}

impl<T> Serialize for Raw<T> {
    /// The bytes as they are (a [`Raw`] is only read, never written, by handgate).
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeTuple;
        let mut t = s.serialize_tuple(self.bytes.len())?;
        for b in &self.bytes {
            t.serialize_element(b)?;
        }
        t.end()
    }
}

struct RawVisitor<T>(PhantomData<fn() -> T>);

impl<'de, T> Visitor<'de> for RawVisitor<T> {
    type Value = Raw<T>;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("the bytes of a sample")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Raw<T>, A::Error> {
        let mut bytes = Vec::new();
        // Reads byte by byte until the decoder's size bound or the end of the sample stops
        // it: that end is the sample's end, not an error.
        while let Ok(Some(b)) = seq.next_element::<u8>() {
            bytes.push(b);
            if bytes.len() as u64 >= crate::cdr_codec::MAX_DECODE_BYTES {
                break;
            }
        }
        Ok(Raw::new(bytes))
    }
}

impl<'de, T> Deserialize<'de> for Raw<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_tuple(usize::MAX, RawVisitor(PhantomData))
    }
}

impl<T: DdsTypeName> DdsTypeName for Raw<T> {
    const DDS_TYPE_NAME: &'static str = T::DDS_TYPE_NAME;
}

impl<T: DdsTypeName> TopicType for Raw<T> {
    fn typename() -> std::ffi::CString {
        std::ffi::CString::new(T::DDS_TYPE_NAME).expect("static type name has no NUL")
    }
    fn has_key() -> bool {
        false
    }
    fn key_cdr(&self) -> Vec<u8> {
        Vec::new()
    }
    fn force_md5_keyhash() -> bool {
        false
    }
}

// ---------------------------------------------------------------------------------------------
// Older layouts (never sent by handgate; only to recognise them)

/// hg `MotorCmd_` as the G1 basic-services page prints it: three reserve words.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct MotorCmdReserve3 {
    mode: u8,
    q: f32,
    dq: f32,
    tau: f32,
    kp: f32,
    kd: f32,
    reserve: [u32; 3],
}

/// `HandCmd_` before December 2024: no `reserve[4]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct HandCmdNoReserve {
    motor_cmd: Vec<hg::MotorCmd_>,
}

/// `HandCmd_` as the G1 basic-services page prints it: no `reserve[4]`, `MotorCmd_` with
/// three reserve words.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct HandCmdBasicServicesPage {
    motor_cmd: Vec<MotorCmdReserve3>,
}

/// `PressSensorState_` before February 2025: no `lost`, no `reserve`.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct PressSensorStateNoLost {
    pressure: [f32; 12],
    temperature: [f32; 12],
}

/// `HandState_` with the current field order but `PressSensorState_` before February 2025.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct HandStatePressNoLost {
    motor_state: Vec<hg::MotorState_>,
    press_sensor_state: Vec<PressSensorStateNoLost>,
    imu_state: hg::IMUState_,
    power_v: f32,
    power_a: f32,
    system_v: f32,
    device_v: f32,
    error: [u32; 2],
    reserve: [u32; 2],
}

/// hg `MotorState_` as the G1 basic-services page prints it.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct MotorStateBasicServicesPage {
    mode: u8,
    q: f32,
    dq: f32,
    ddq: f32,
    tau_est: f32,
    q_raw: f32,
    dq_raw: f32,
    ddq_raw: f32,
    temperature: [i16; 2],
    sensor: [u32; 2],
    vol: f32,
    motorstate: u32,
    reserve: [u32; 4],
}

/// `HandState_` as the G1 basic-services page prints it: IMU before the pressure sequence,
/// no `system_v`/`device_v`/`error`.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct HandStateBasicServicesPage {
    motor_state: Vec<MotorStateBasicServicesPage>,
    imu_state: hg::IMUState_,
    press_sensor_state: Vec<PressSensorStateNoLost>,
    power_v: f32,
    power_a: f32,
    reserve: [u32; 2],
}

// ---------------------------------------------------------------------------------------------
// The check

/// What [`check`] concluded about one sample.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Verdict {
    /// The current layout accounts for every byte.
    Current,
    /// The current layout does not, this older one does (its description).
    Older(&'static str),
    /// Neither the current nor a known older layout accounts for the bytes.
    Unknown,
}

/// The result of [`check`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LayoutCheck {
    pub verdict: Verdict,
    /// Bytes after the encapsulation header.
    pub size: usize,
    /// What the current layout would take for the same sequence lengths, when the sample
    /// decodes as the current layout at all.
    pub current_size: Option<usize>,
    /// Entries (motors) the sample carries: the length of its first sequence (`motor_cmd`,
    /// `motor_state`: the first field of every layout), read in whichever byte order gives a
    /// length the sample can hold. `None`: too short to say.
    pub entries: Option<usize>,
}

/// The length of the sequence `body` starts with, in the byte order that gives a length the
/// body can hold (a motor entry takes more than one byte, so a real length is below
/// `body.len()`; the other order reads a huge number).
fn first_sequence_len(body: &[u8]) -> Option<usize> {
    let b: [u8; 4] = body.get(..4)?.try_into().ok()?;
    [u32::from_le_bytes(b), u32::from_be_bytes(b)]
        .into_iter()
        .map(|n| n as usize)
        .filter(|n| *n < body.len())
        .min()
}

/// Whether `body` (a sample without its header) decodes as `V` in either byte order and
/// re-encodes to the same length (up to the 0–3 bytes of padding a writer may append).
/// Returns the re-encoded length when it decodes.
fn fit<V: Serialize + DeserializeOwned>(body: &[u8]) -> (bool, Option<usize>) {
    let mut decoded_len = None;
    for v in from_cdr_body::<V>(body) {
        let Ok(enc) = to_cdr_le(&v) else { continue };
        let len = enc.len() - 4;
        if body.len() >= len && body.len() - len < 4 {
            return (true, Some(len));
        }
        decoded_len.get_or_insert(len);
    }
    (false, decoded_len)
}

/// Whether a sample's bytes fit one layout, and the re-encoded length when they decode.
type Fit = fn(&[u8]) -> (bool, Option<usize>);

/// A type with a layout history: its current layout and the older ones, newest first.
struct History {
    type_name: &'static str,
    current: Fit,
    older: &'static [(&'static str, Fit)],
}

const HISTORIES: &[History] = &[
    History {
        type_name: hg::HandCmd_::DDS_TYPE_NAME,
        current: fit::<hg::HandCmd_>,
        older: &[
            (
                "HandCmd_ without reserve[4] (unitree_sdk2 before December 2024)",
                fit::<HandCmdNoReserve>,
            ),
            (
                "HandCmd_ as the G1 basic-services page prints it (no reserve[4], MotorCmd_ with reserve[3])",
                fit::<HandCmdBasicServicesPage>,
            ),
        ],
    },
    History {
        type_name: hg::HandState_::DDS_TYPE_NAME,
        current: fit::<hg::HandState_>,
        older: &[
            (
                "HandState_ whose PressSensorState_ has no lost/reserve (unitree_sdk2 before February 2025)",
                fit::<HandStatePressNoLost>,
            ),
            (
                "HandState_ as the G1 basic-services page prints it (IMU before the pressure sensors, no system_v/device_v/error)",
                fit::<HandStateBasicServicesPage>,
            ),
        ],
    },
];

/// Type names [`check`] knows a layout history for.
pub fn checked_types() -> impl Iterator<Item = &'static str> {
    HISTORIES.iter().map(|h| h.type_name)
}

/// Which layout `body` (a sample of type `type_name` without its encapsulation header) was
/// written in. `None`: no layout history is known for `type_name`.
pub fn check(type_name: &str, body: &[u8]) -> Option<LayoutCheck> {
    let h = HISTORIES.iter().find(|h| h.type_name == type_name)?;
    let (ok, current_size) = (h.current)(body);
    let verdict = if ok {
        Verdict::Current
    } else {
        h.older
            .iter()
            .find(|(_, f)| f(body).0)
            .map_or(Verdict::Unknown, |(what, _)| Verdict::Older(what))
    };
    Some(LayoutCheck {
        verdict,
        size: body.len(),
        current_size,
        entries: first_sequence_len(body),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{from_cdr, to_cdr_be};

    fn body(v: &impl Serialize) -> Vec<u8> {
        to_cdr_le(v).unwrap()[4..].to_vec()
    }

    fn cmd(n: usize) -> hg::HandCmd_ {
        hg::HandCmd_ {
            motor_cmd: vec![hg::MotorCmd_::default(); n],
            ..Default::default()
        }
    }

    #[test]
    fn entries_are_the_first_sequence_in_either_byte_order() {
        for n in [1, 2, 7, 16, 20] {
            let le = check(hg::HandCmd_::DDS_TYPE_NAME, &body(&cmd(n))).unwrap();
            assert_eq!(le.entries, Some(n), "{n} motors, little endian");
            let be = to_cdr_be(&cmd(n)).unwrap()[4..].to_vec();
            assert_eq!(
                check(hg::HandCmd_::DDS_TYPE_NAME, &be).unwrap().entries,
                Some(n),
                "{n} motors, big endian"
            );
            let st = hg::HandState_ {
                motor_state: vec![hg::MotorState_::default(); n],
                ..Default::default()
            };
            assert_eq!(
                check(hg::HandState_::DDS_TYPE_NAME, &body(&st)).unwrap().entries,
                Some(n)
            );
        }
        assert_eq!(check(hg::HandCmd_::DDS_TYPE_NAME, &[1, 0]).unwrap().entries, None);
    }

    #[test]
    fn current_layouts_are_current_in_either_byte_order() {
        for n in [1, 2, 7] {
            let c = check(hg::HandCmd_::DDS_TYPE_NAME, &body(&cmd(n))).unwrap();
            assert_eq!(c.verdict, Verdict::Current, "{n} motors");
            assert_eq!(c.current_size, Some(c.size));
            let be = to_cdr_be(&cmd(n)).unwrap()[4..].to_vec();
            assert_eq!(
                check(hg::HandCmd_::DDS_TYPE_NAME, &be).unwrap().verdict,
                Verdict::Current
            );
        }
        let s = hg::HandState_ {
            motor_state: vec![hg::MotorState_::default(); 7],
            press_sensor_state: vec![hg::PressSensorState_::default(); 9],
            ..Default::default()
        };
        let c = check(hg::HandState_::DDS_TYPE_NAME, &body(&s)).unwrap();
        assert_eq!(c.verdict, Verdict::Current);
        // Trailing padding a writer may add is not a different layout.
        let mut padded = body(&cmd(7));
        padded.extend_from_slice(&[0, 0]);
        let c = check(hg::HandCmd_::DDS_TYPE_NAME, &padded).unwrap();
        assert_eq!(c.verdict, Verdict::Current);
    }

    #[test]
    fn older_hand_cmd_layouts_are_recognised_by_size() {
        let old = HandCmdNoReserve {
            motor_cmd: vec![hg::MotorCmd_::default(); 7],
        };
        let c = check(hg::HandCmd_::DDS_TYPE_NAME, &body(&old)).unwrap();
        assert!(
            matches!(c.verdict, Verdict::Older(w) if w.contains("December 2024")),
            "{c:?}"
        );
        assert_eq!(c.size, 4 + 7 * 28);
        let page = HandCmdBasicServicesPage {
            motor_cmd: vec![
                MotorCmdReserve3 {
                    mode: 1,
                    q: 0.0,
                    dq: 0.0,
                    tau: 0.0,
                    kp: 0.0,
                    kd: 0.0,
                    reserve: [0; 3]
                };
                7
            ],
        };
        // 7 × 36 + 4 bytes decode as the current layout too (7 motors and more bytes), so
        // only the size tells it apart.
        let c = check(hg::HandCmd_::DDS_TYPE_NAME, &body(&page)).unwrap();
        assert!(
            matches!(c.verdict, Verdict::Older(w) if w.contains("basic-services")),
            "{c:?}"
        );
        assert_eq!(c.current_size, Some(4 + 7 * 28 + 16));
    }

    #[test]
    fn older_hand_state_layouts_are_recognised_by_size() {
        let s = HandStatePressNoLost {
            motor_state: vec![hg::MotorState_::default(); 7],
            press_sensor_state: vec![
                PressSensorStateNoLost {
                    pressure: [0.0; 12],
                    temperature: [0.0; 12]
                };
                9
            ],
            imu_state: hg::IMUState_::default(),
            power_v: 0.0,
            power_a: 0.0,
            system_v: 0.0,
            device_v: 0.0,
            error: [0; 2],
            reserve: [0; 2],
        };
        let c = check(hg::HandState_::DDS_TYPE_NAME, &body(&s)).unwrap();
        assert!(
            matches!(c.verdict, Verdict::Older(w) if w.contains("February 2025")),
            "{c:?}"
        );
        let page = HandStateBasicServicesPage {
            motor_state: Vec::new(),
            imu_state: hg::IMUState_::default(),
            press_sensor_state: Vec::new(),
            power_v: 0.0,
            power_a: 0.0,
            reserve: [0; 2],
        };
        let c = check(hg::HandState_::DDS_TYPE_NAME, &body(&page)).unwrap();
        assert!(
            matches!(c.verdict, Verdict::Older(w) if w.contains("basic-services")),
            "{c:?}"
        );
    }

    #[test]
    fn garbage_is_unknown_and_other_types_have_no_history() {
        let c = check(hg::HandCmd_::DDS_TYPE_NAME, &[1, 2, 3]).unwrap();
        assert_eq!(c.verdict, Verdict::Unknown);
        assert!(check("unitree_go::msg::dds_::MotorCmds_", &[0; 8]).is_none());
        assert_eq!(checked_types().count(), 2);
    }

    #[test]
    fn raw_keeps_every_byte_after_the_header() {
        let enc = to_cdr_le(&cmd(7)).unwrap();
        let raw: Raw<hg::HandCmd_> = from_cdr(&enc).unwrap();
        assert_eq!(raw.bytes, enc[4..]);
        assert_eq!(
            <Raw<hg::HandCmd_> as TopicType>::typename().to_str().unwrap(),
            hg::HandCmd_::DDS_TYPE_NAME
        );
    }
}
