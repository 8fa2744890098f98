//! Unit scalings of the Dex3-1 USB frames: ONE table, every entry named with its source.
//!
//! Two sources disagree (docs/sources.md §3):
//! - the Dex3-1 user manual (`MotorCmd_t` / `MotorState_t` comments): torque 256 = 1 mN·m,
//!   speed 256/2π = 100 rad/s, position 32768/2π = 1 rad, k_pos 1280 = 1 mN·m/rad,
//!   k_spd 1280 = 1 mN·m/(100 rad/s), voltage 255 = 127.5 V;
//! - `motor_msg_HG.h` in unitreerobotics/dex1_1_service (the same Unitree "HG" motor frame):
//!   command torque q8 N·m (256 = 1 N·m), command speed q7 rad/s (128 = 1 rad/s), position
//!   32768/2π = 1 rad, k_pos / k_spd q15 in 0.0..1.0, feedback torque 256 = 1 N·m, feedback
//!   speed 256/2π = 1 rad/s, feedback voltage 2 = 1 V.
//!
//! With 256 per mN·m a 1.5 N·m joint torque would overflow an `i16`, so the manual's "mN" is
//! most likely a typo; [`Scalings::default`] is therefore the `motor_msg_HG.h` table and
//! [`Scalings::manual`] the alternative. Both are overridable from a profile (serde).
//!
//! ASSUMPTION: the q15 gains of `motor_msg_HG.h` are taken as kp in N·m/rad and kd in
//! N·m·s/rad directly (kp 1.0 = 32768). Nothing public says what full scale "1.0" is.
//!
//! Frame-level conversions (all from the manual's `McuToLinuxState_t` comments): supply
//! voltage `raw / 65536 * 3.3 * 21`, current `raw / 65536 * 3.3 * 10`, IMU `raw / 100`,
//! pressure "each 1 is 8 Pa". The manual writes the current formula next to `vin_v` as well;
//! we follow the manual literally (overridable), see docs/dex3-usb.md.

use serde::{Deserialize, Serialize};
use std::f32::consts::PI;

/// Raw counts per physical unit for every scaled field. `value_physical = raw / lsb_per_unit`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Scalings {
    /// Command `tor_des`, counts per N·m.
    pub cmd_torque_per_nm: f32,
    /// Command `spd_des`, counts per rad/s.
    pub cmd_speed_per_rad_s: f32,
    /// Command `pos_des`, counts per rad.
    pub cmd_position_per_rad: f32,
    /// Command `k_pos`, counts per N·m/rad.
    pub cmd_kp_per_unit: f32,
    /// Command `k_spd`, counts per N·m·s/rad.
    pub cmd_kd_per_unit: f32,
    /// Feedback `torque`, counts per N·m.
    pub fb_torque_per_nm: f32,
    /// Feedback `speed`, counts per rad/s.
    pub fb_speed_per_rad_s: f32,
    /// Feedback `pos`, counts per rad.
    pub fb_position_per_rad: f32,
    /// Feedback `vol` (motor terminal voltage), counts per V.
    pub fb_voltage_per_v: f32,
    /// Sensor frame `pressure[i]`, Pa per count (manual: "each 1 is 8 Pa").
    pub pressure_pa_per_count: f32,
    /// `pin_v`, V per count (manual: /65536 * 3.3 * 21).
    pub pin_v_per_count: f32,
    /// `vin_v`, per count (manual writes the current formula /65536 * 3.3 * 10 beside it).
    pub vin_v_per_count: f32,
    /// `vm_v`, V per count (manual: /65536 * 3.3 * 21).
    pub vm_v_per_count: f32,
    /// `pin_a`, A per count (manual: /65536 * 3.3 * 10).
    pub pin_a_per_count: f32,
    /// `imu_data[0..3]` accelerations, per count (manual: raw / 100; unit not stated).
    pub imu_accel_per_count: f32,
    /// `imu_data[3..6]` angular rates, per count (manual: raw / 100; unit not stated).
    pub imu_gyro_per_count: f32,
}

/// Named constants of the two sources.
pub mod table {
    use super::PI;
    /// motor_msg_HG.h: `tor_des` q8 N·m; feedback torque "256 = 1 Nm".
    pub const HG_TORQUE_PER_NM: f32 = 256.0;
    /// motor_msg_HG.h: `spd_des` q7 rad/s.
    pub const HG_CMD_SPEED_PER_RAD_S: f32 = 128.0;
    /// motor_msg_HG.h feedback speed "256/2π = 1 rad/s".
    pub const HG_FB_SPEED_PER_RAD_S: f32 = 256.0 / (2.0 * PI);
    /// Manual and motor_msg_HG.h feedback: "32768/2π = 1 rad".
    pub const POSITION_PER_RAD: f32 = 32768.0 / (2.0 * PI);
    /// motor_msg_HG.h: k_pos / k_spd q15 (1.0 = 32768).
    pub const HG_GAIN_Q15: f32 = 32768.0;
    /// motor_msg_HG.h: "2 = 1 V"; the manual: "255 = 127.5 V" (the same).
    pub const VOLTAGE_PER_V: f32 = 2.0;
    /// Manual: torque "256 = 1 mN·m".
    pub const MANUAL_TORQUE_PER_NM: f32 = 256.0 * 1000.0;
    /// Manual: speed "256/2π = 100 rad/s".
    pub const MANUAL_SPEED_PER_RAD_S: f32 = 256.0 / (2.0 * PI) / 100.0;
    /// Manual: k_pos "1280 = 1 mN·m/rad".
    pub const MANUAL_KP_PER_NM_RAD: f32 = 1280.0 * 1000.0;
    /// Manual: k_spd "1280 = 1 mN·m/(100 rad/s)".
    pub const MANUAL_KD_PER_NM_S_RAD: f32 = 1280.0 * 1000.0 * 100.0;
    /// Manual: sensor pressure "each 1 is 8 Pa".
    pub const PRESSURE_PA_PER_COUNT: f32 = 8.0;
    /// Manual: supply voltage `raw / 65536 * 3.3 * 21`.
    pub const SUPPLY_V_PER_COUNT: f32 = 3.3 * 21.0 / 65536.0;
    /// Manual: supply current `raw / 65536 * 3.3 * 10`.
    pub const SUPPLY_A_PER_COUNT: f32 = 3.3 * 10.0 / 65536.0;
    /// Manual: IMU `raw / 100`.
    pub const IMU_PER_COUNT: f32 = 0.01;
}

impl Default for Scalings {
    /// The `motor_msg_HG.h` table (see module docs).
    fn default() -> Self {
        use table::*;
        Self {
            cmd_torque_per_nm: HG_TORQUE_PER_NM,
            cmd_speed_per_rad_s: HG_CMD_SPEED_PER_RAD_S,
            cmd_position_per_rad: POSITION_PER_RAD,
            cmd_kp_per_unit: HG_GAIN_Q15,
            cmd_kd_per_unit: HG_GAIN_Q15,
            fb_torque_per_nm: HG_TORQUE_PER_NM,
            fb_speed_per_rad_s: HG_FB_SPEED_PER_RAD_S,
            fb_position_per_rad: POSITION_PER_RAD,
            fb_voltage_per_v: VOLTAGE_PER_V,
            pressure_pa_per_count: PRESSURE_PA_PER_COUNT,
            pin_v_per_count: SUPPLY_V_PER_COUNT,
            vin_v_per_count: SUPPLY_A_PER_COUNT,
            vm_v_per_count: SUPPLY_V_PER_COUNT,
            pin_a_per_count: SUPPLY_A_PER_COUNT,
            imu_accel_per_count: IMU_PER_COUNT,
            imu_gyro_per_count: IMU_PER_COUNT,
        }
    }
}

impl Scalings {
    /// The user manual's table taken literally (mN·m torque, "256/2π = 100 rad/s" speed).
    pub fn manual() -> Self {
        use table::*;
        Self {
            cmd_torque_per_nm: MANUAL_TORQUE_PER_NM,
            cmd_speed_per_rad_s: MANUAL_SPEED_PER_RAD_S,
            cmd_kp_per_unit: MANUAL_KP_PER_NM_RAD,
            cmd_kd_per_unit: MANUAL_KD_PER_NM_S_RAD,
            fb_torque_per_nm: MANUAL_TORQUE_PER_NM,
            fb_speed_per_rad_s: MANUAL_SPEED_PER_RAD_S,
            ..Self::default()
        }
    }

    /// Every factor must be finite and positive (a zero would divide by zero on decode).
    pub fn validate(&self) -> Result<(), ScalingError> {
        let fields = [
            ("cmd_torque_per_nm", self.cmd_torque_per_nm),
            ("cmd_speed_per_rad_s", self.cmd_speed_per_rad_s),
            ("cmd_position_per_rad", self.cmd_position_per_rad),
            ("cmd_kp_per_unit", self.cmd_kp_per_unit),
            ("cmd_kd_per_unit", self.cmd_kd_per_unit),
            ("fb_torque_per_nm", self.fb_torque_per_nm),
            ("fb_speed_per_rad_s", self.fb_speed_per_rad_s),
            ("fb_position_per_rad", self.fb_position_per_rad),
            ("fb_voltage_per_v", self.fb_voltage_per_v),
            ("pressure_pa_per_count", self.pressure_pa_per_count),
            ("pin_v_per_count", self.pin_v_per_count),
            ("vin_v_per_count", self.vin_v_per_count),
            ("vm_v_per_count", self.vm_v_per_count),
            ("pin_a_per_count", self.pin_a_per_count),
            ("imu_accel_per_count", self.imu_accel_per_count),
            ("imu_gyro_per_count", self.imu_gyro_per_count),
        ];
        for (name, v) in fields {
            if !(v.is_finite() && v > 0.0) {
                return Err(ScalingError { field: name, value: v });
            }
        }
        Ok(())
    }

    /// Encodes a command torque (N·m) to `tor_des`, saturating.
    pub fn encode_cmd_torque(&self, nm: f32) -> i16 {
        sat_i16(nm * self.cmd_torque_per_nm)
    }
    pub fn encode_cmd_speed(&self, rad_s: f32) -> i16 {
        sat_i16(rad_s * self.cmd_speed_per_rad_s)
    }
    pub fn encode_cmd_position(&self, rad: f32) -> i32 {
        sat_i32(rad * self.cmd_position_per_rad)
    }
    pub fn encode_cmd_kp(&self, kp: f32) -> u16 {
        sat_u16(kp * self.cmd_kp_per_unit)
    }
    pub fn encode_cmd_kd(&self, kd: f32) -> u16 {
        sat_u16(kd * self.cmd_kd_per_unit)
    }
    pub fn decode_cmd_torque(&self, raw: i16) -> f32 {
        raw as f32 / self.cmd_torque_per_nm
    }
    pub fn decode_cmd_speed(&self, raw: i16) -> f32 {
        raw as f32 / self.cmd_speed_per_rad_s
    }
    pub fn decode_cmd_position(&self, raw: i32) -> f32 {
        raw as f32 / self.cmd_position_per_rad
    }
    pub fn decode_cmd_kp(&self, raw: u16) -> f32 {
        raw as f32 / self.cmd_kp_per_unit
    }
    pub fn decode_cmd_kd(&self, raw: u16) -> f32 {
        raw as f32 / self.cmd_kd_per_unit
    }
    pub fn encode_fb_torque(&self, nm: f32) -> i16 {
        sat_i16(nm * self.fb_torque_per_nm)
    }
    pub fn encode_fb_speed(&self, rad_s: f32) -> i16 {
        sat_i16(rad_s * self.fb_speed_per_rad_s)
    }
    pub fn encode_fb_position(&self, rad: f32) -> i32 {
        sat_i32(rad * self.fb_position_per_rad)
    }
    pub fn encode_fb_voltage(&self, v: f32) -> u8 {
        (v * self.fb_voltage_per_v).round().clamp(0.0, 255.0) as u8
    }
    pub fn decode_fb_torque(&self, raw: i16) -> f32 {
        raw as f32 / self.fb_torque_per_nm
    }
    pub fn decode_fb_speed(&self, raw: i16) -> f32 {
        raw as f32 / self.fb_speed_per_rad_s
    }
    pub fn decode_fb_position(&self, raw: i32) -> f32 {
        raw as f32 / self.fb_position_per_rad
    }
    pub fn decode_fb_voltage(&self, raw: u8) -> f32 {
        raw as f32 / self.fb_voltage_per_v
    }
}

/// A scaling factor that is zero, negative or not finite.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("scaling {field} = {value} must be finite and positive")]
pub struct ScalingError {
    pub field: &'static str,
    pub value: f32,
}

/// Rounds and saturates; NaN maps to 0 (Rust's float-to-int `as` casts saturate and map NaN to 0).
fn sat_i16(x: f32) -> i16 {
    x.round() as i16
}
fn sat_i32(x: f32) -> i32 {
    x.round() as i32
}
fn sat_u16(x: f32) -> u16 {
    x.round() as u16
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hg_defaults() {
        let s = Scalings::default();
        assert_eq!(s.encode_cmd_torque(1.0), 256);
        assert_eq!(s.encode_cmd_speed(1.0), 128);
        assert_eq!(s.encode_cmd_position(2.0 * PI), 32768);
        assert_eq!(s.encode_cmd_kp(1.5), 49152);
        assert_eq!(s.encode_cmd_kd(0.1), 3277);
        assert_eq!(s.encode_fb_voltage(24.0), 48);
        assert!((s.decode_fb_speed(256) - 2.0 * PI).abs() < 1e-5);
        assert!((s.pin_v_per_count * 65536.0 - 69.3).abs() < 1e-3);
    }

    #[test]
    fn validation() {
        Scalings::default().validate().unwrap();
        Scalings::manual().validate().unwrap();
        let bad = Scalings {
            fb_speed_per_rad_s: 0.0,
            ..Scalings::default()
        };
        assert_eq!(bad.validate().unwrap_err().field, "fb_speed_per_rad_s");
        let nan = Scalings {
            imu_gyro_per_count: f32::NAN,
            ..Scalings::default()
        };
        assert!(nan.validate().is_err());
    }

    #[test]
    fn saturates_instead_of_wrapping() {
        let s = Scalings::default();
        assert_eq!(s.encode_cmd_torque(1000.0), i16::MAX);
        assert_eq!(s.encode_cmd_torque(-1000.0), i16::MIN);
        assert_eq!(s.encode_cmd_kp(-1.0), 0);
        assert_eq!(s.encode_cmd_kp(f32::NAN), 0);
        assert_eq!(s.encode_cmd_kp(3.0), u16::MAX);
    }

    #[test]
    fn manual_table_overflows_realistic_torque() {
        // The reason the manual's mN·m reading is doubted: 1.5 N·m saturates an i16.
        assert_eq!(Scalings::manual().encode_cmd_torque(1.5), i16::MAX);
    }

    #[test]
    fn deserialises_partial_override() {
        let s: Scalings = serde_json::from_str(r#"{"cmd_torque_per_nm": 256000.0}"#).unwrap();
        assert_eq!(s.cmd_torque_per_nm, 256000.0);
        assert_eq!(s.cmd_speed_per_rad_s, table::HG_CMD_SPEED_PER_RAD_S);
        assert!(serde_json::from_str::<Scalings>(r#"{"bogus": 1}"#).is_err());
    }
}
