//! Every number the LEAP Hand adapter relies on, with its source.
//!
//! Sources:
//! * **\[LEAP\]** leap-hand/LEAP_Hand_API: `python/main.py` (ids 0-15 at 4 000 000 baud,
//!   operating mode 5, P 600 / I 0 / D 200 with x0.75 on ids 0, 4, 8, goal current 350
//!   "in unit 1ma", "500 normal or 350 for lite"), `readme.md` ("For Full, you can raise the
//!   current limit up to 550ma"), `python/leap_hand_utils/leap_hand_utils.py` (LEAP radians:
//!   the motor's angle, 180° = flat; sim/URDF angle = LEAP − π) and
//!   `leap_hand_utils/dynamixel_client.py` (present current/velocity/position read as one
//!   10-byte block at 126; 2π/4096 rad per tick; 0.229 rpm per velocity unit).
//! * **\[XC330\]** DynamixelSDK 4.1.0 (PyPI), `dynamixel_easy_sdk/control_table/xc330_m288.model`
//!   and `dynamixel.model`: model number 1240, the control table, 0.0239691227 rad/s per
//!   velocity unit, current in raw units (1 mA, \[LEAP\]).
//! * **\[URDF\]** leap-hand/LEAP_Hand_Sim `assets/leap_hand/robot.urdf`: joints named `0`..`15`
//!   (the motor ids), their limits in the sim's frame, velocity 8.48 rad/s, effort 0.95 N·m.

pub use crate::dynamixel::control_table::{reg, ro, rw, OperatingMode, Reg};

/// Servos on a LEAP Hand v1 \[LEAP\].
pub const MOTORS: usize = 16;
/// Their ids, in joint order: index 0-3, middle 4-7, ring 8-11, thumb 12-15 \[LEAP\].
pub const DEFAULT_IDS: [u8; MOTORS] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15];
/// The bus's baud rate \[LEAP\].
pub const BAUD: u32 = 4_000_000;
/// Model number of the XC330-M288 \[XC330\].
pub const XC330_M288_MODEL_NUMBER: u16 = 1240;
/// Firmware version the emulated servos report (assumed: DynamixelSDK 4.1.0 ships a
/// `xc330_m288_fw52.model`, so 52 is a firmware these servos run).
pub const FIRMWARE_VERSION: u8 = 52;
/// Encoder ticks per output revolution \[XC330\] (0..4095 over -π..π, 2048 at zero).
pub const TICKS_PER_REV: f32 = 4096.0;
/// Radians per position tick \[LEAP\] (`DEFAULT_POS_SCALE`).
pub const RAD_PER_TICK: f32 = std::f32::consts::TAU / TICKS_PER_REV;
/// Rad/s per Present Velocity unit (0.229 rpm) \[XC330\] \[LEAP\].
pub const RAD_S_PER_VELOCITY_UNIT: f32 = 0.229 * std::f32::consts::TAU / 60.0;
/// mA per Goal/Present Current unit \[LEAP\] ("in unit 1ma").
pub const MA_PER_CURRENT_UNIT: f32 = 1.0;
/// Output torque per ampere, N·m/A. Assumed: the URDF's effort limit (0.95 N·m) at the
/// XC330-M288's 1.8 A stall current, linear; ROBOTIS publishes a torque/current curve, not
/// a constant, and the LEAP sources give none.
pub const TORQUE_PER_AMP: f32 = 0.95 / 1.8;

/// Position P gain written at init \[LEAP\].
pub const POSITION_P: u16 = 600;
/// Position I gain \[LEAP\].
pub const POSITION_I: u16 = 0;
/// Position D gain \[LEAP\].
pub const POSITION_D: u16 = 200;
/// Ids whose P and D are 3/4 of the others' ("side to side should be a bit less") \[LEAP\]:
/// the MCP side joints of index, middle and ring.
pub const SIDE_IDS: [u8; 3] = [0, 4, 8];
/// Goal current of a LEAP Hand Lite, mA \[LEAP\] (`curr_lim = 350`).
pub const GOAL_CURRENT_LITE_MA: u16 = 350;
/// Goal current of a full LEAP Hand, mA \[LEAP\] ("up to 550ma").
pub const GOAL_CURRENT_FULL_MA: u16 = 550;

/// The block read every cycle: Present Current (126, 2) + Present Velocity (128, 4) + Present
/// Position (132, 4), one read of 10 consecutive bytes \[LEAP\] (`ADDR_PRESENT_POS_VEL_CUR`).
pub const PRESENT_BLOCK: Reg = ro(126, 10);
/// Goal Position (116, 4), sync-written every cycle.
pub const GOAL: Reg = reg::GOAL_POSITION;

/// P or D for servo `id`: `full`, or 3/4 of it on the side joints.
pub fn gain_for(id: u8, full: u16) -> u16 {
    if SIDE_IDS.contains(&id) {
        (u32::from(full) * 3 / 4) as u16
    } else {
        full
    }
}

/// LEAP radians (the motor's angle) of a present position.
pub fn ticks_to_rad(ticks: i32) -> f32 {
    ticks as f32 * RAD_PER_TICK
}

/// The goal position for LEAP radians `rad`, rounded to the nearest tick and kept inside
/// one turn (0..=4095, the position mode's range).
pub fn rad_to_ticks(rad: f32) -> i32 {
    let t = if rad.is_finite() {
        (rad / RAD_PER_TICK).round()
    } else {
        2048.0
    };
    t.clamp(0.0, TICKS_PER_REV - 1.0) as i32
}

/// One servo's present values as the block at 126 carries them: (current mA, velocity rad/s,
/// position LEAP rad).
pub fn parse_present(block: &[u8]) -> Option<(f32, f32, f32)> {
    let cur = crate::dynamixel::protocol::le_i16(block.get(0..2)?)?;
    let vel = crate::dynamixel::protocol::le_i32(block.get(2..6)?)?;
    let pos = crate::dynamixel::protocol::le_i32(block.get(6..10)?)?;
    Some((
        f32::from(cur) * MA_PER_CURRENT_UNIT,
        vel as f32 * RAD_S_PER_VELOCITY_UNIT,
        ticks_to_rad(pos),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_present_block_is_current_velocity_position_back_to_back() {
        assert_eq!(PRESENT_BLOCK.addr, reg::PRESENT_CURRENT.addr);
        assert_eq!(reg::PRESENT_VELOCITY.addr, 128);
        assert_eq!(
            PRESENT_BLOCK.addr + PRESENT_BLOCK.len,
            reg::PRESENT_POSITION.addr + reg::PRESENT_POSITION.len
        );
        let mut b = Vec::new();
        b.extend_from_slice(&(-120i16).to_le_bytes());
        b.extend_from_slice(&10i32.to_le_bytes());
        b.extend_from_slice(&2048i32.to_le_bytes());
        let (c, v, p) = parse_present(&b).unwrap();
        assert_eq!(c, -120.0);
        assert!((v - 10.0 * 0.229 * std::f32::consts::TAU / 60.0).abs() < 1e-6);
        assert!((p - std::f32::consts::PI).abs() < 1e-6, "2048 ticks = 180° = flat");
        assert!(parse_present(&b[..9]).is_none());
    }

    #[test]
    fn gains_and_ticks() {
        assert_eq!(gain_for(0, POSITION_P), 450);
        assert_eq!(gain_for(4, POSITION_D), 150);
        assert_eq!(gain_for(1, POSITION_P), 600);
        assert_eq!(gain_for(12, POSITION_P), 600);
        assert_eq!(rad_to_ticks(std::f32::consts::PI), 2048);
        assert_eq!(rad_to_ticks(-1.0), 0);
        assert_eq!(rad_to_ticks(100.0), 4095);
        assert_eq!(rad_to_ticks(f32::NAN), 2048);
    }
}
