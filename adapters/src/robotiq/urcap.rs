//! The Robotiq URCap's text protocol (the gripper server a UR controller runs on port 63352):
//! `SET <VAR> <n> [<VAR> <n> ...]` answered `ack`, `GET <VAR>` answered `<VAR> <n>`; one
//! line may carry several commands (`SET POS 128 SPE 255 FOR 100 GTO 1`, as the URCap's
//! `rq_move` sends them). Sources: the URCap's URScript functions (`rq_set_var`,
//! `rq_get_var`) as the public Python clients of this socket use them (robotiq_gripper.py
//! in ur_rtde's and many projects' examples: `ack` compared as exactly those three bytes, a
//! GET's answer split on white space). Answers carry no line end (assumed from those clients:
//! `data == b'ack'`). docs/robotiq.md.
//!
//! Pure: a line is answered against a [`Gripper`] (the front's register image) at `now`.

use std::time::Instant;

use super::emulator::{Gripper, Table};
use super::regs::{Request, Status, REQUEST_ADDR, STATUS_ADDR};

/// The longest line accepted (a full `SET` of every variable is under 60 bytes).
pub const MAX_LINE: usize = 256;

/// A line that is not the URCap's protocol.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{detail}")]
pub struct UrcapError {
    /// Counter key.
    pub reason: &'static str,
    pub detail: String,
}

fn bad(reason: &'static str, detail: String) -> UrcapError {
    UrcapError { reason, detail }
}

/// A variable's value in `r` (request) and `s` (status); `None` for an unknown name.
fn get(name: &str, r: &Request, s: &Status) -> Option<u8> {
    Some(match name {
        "ACT" => u8::from(s.act),
        "GTO" => u8::from(s.gto),
        "STA" => s.activation as u8,
        "OBJ" => s.object as u8,
        "FLT" => s.fault,
        "PRE" => s.requested,
        "POS" => s.position,
        "COU" => s.current,
        "SPE" => r.speed,
        "FOR" => r.force,
        "ATR" => u8::from(r.atr),
        "ARD" | "ADR" => u8::from(r.ard),
        _ => return None,
    })
}

/// Sets a writable variable in `r`; `false` for a name that is not one.
fn set(name: &str, v: u8, r: &mut Request) -> bool {
    match name {
        "ACT" => r.act = v != 0,
        "GTO" => r.gto = v != 0,
        "ATR" => r.atr = v != 0,
        "ARD" | "ADR" => r.ard = v != 0,
        "POS" => r.position = v,
        "SPE" => r.speed = v,
        "FOR" => r.force = v,
        _ => return false,
    }
    true
}

/// Answers one line (without its line end) into `out`.
pub fn answer_line(line: &[u8], g: &mut Gripper, now: Instant, out: &mut Vec<u8>) -> Result<(), UrcapError> {
    let text = std::str::from_utf8(line).map_err(|_| bad("not_text", "a line that is not text".into()))?;
    let mut words = text.split_ascii_whitespace().peekable();
    let mut answered = false;
    while let Some(verb) = words.next() {
        let mut w = [0u16; 3];
        // The register images are always readable: these cannot fail.
        let _ = g.read(Table::Holding, REQUEST_ADDR, &mut w, now);
        let mut r = Request::from_words(&w);
        let is_verb = |s: &&str| s.eq_ignore_ascii_case("SET") || s.eq_ignore_ascii_case("GET");
        if answered {
            out.push(b'\n');
        }
        if verb.eq_ignore_ascii_case("SET") {
            let mut n = 0;
            while let Some(name) = words.next_if(|s| !is_verb(s)) {
                let name = name.to_ascii_uppercase();
                let value = words
                    .next()
                    .ok_or_else(|| bad("bad_command", format!("SET {name} without a value")))?;
                let v: i64 = value
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .map(|v| v.round() as i64)
                    .ok_or_else(|| bad("bad_command", format!("SET {name} {value}: not a number")))?;
                if !set(&name, v.clamp(0, 255) as u8, &mut r) {
                    return Err(bad(
                        "bad_command",
                        format!("SET {name}: not a variable that can be set"),
                    ));
                }
                n += 1;
            }
            if n == 0 {
                return Err(bad("bad_command", "SET without a variable".into()));
            }
            let _ = g.write(REQUEST_ADDR, r.to_words(), now);
            out.extend_from_slice(b"ack");
        } else if verb.eq_ignore_ascii_case("GET") {
            let mut s = [0u16; 3];
            let _ = g.read(Table::Input, STATUS_ADDR, &mut s, now);
            let s = Status::from_words(&s);
            let mut n = 0;
            while let Some(name) = words.next_if(|s| !is_verb(s)) {
                let name = name.to_ascii_uppercase();
                let v =
                    get(&name, &r, &s).ok_or_else(|| bad("bad_command", format!("GET {name}: no such variable")))?;
                if n > 0 {
                    out.push(b'\n');
                }
                out.extend_from_slice(name.as_bytes());
                out.push(b' ');
                out.extend_from_slice(v.to_string().as_bytes());
                n += 1;
            }
            if n == 0 {
                return Err(bad("bad_command", "GET without a variable".into()));
            }
        } else {
            return Err(bad(
                "bad_command",
                format!("`{}`: not SET or GET", verb.chars().take(16).collect::<String>()),
            ));
        }
        answered = true;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;
    use crate::robotiq::emulator::{Measured, Motion, Tuning};

    fn front(now: Instant) -> Gripper {
        Gripper::external(
            Tuning {
                activation: Duration::from_millis(50),
                min_gap: Duration::ZERO,
                ..Tuning::default()
            },
            now,
        )
    }

    fn say(g: &mut Gripper, line: &str, now: Instant) -> String {
        let mut out = Vec::new();
        answer_line(line.as_bytes(), g, now, &mut out).unwrap();
        String::from_utf8(out).unwrap()
    }

    /// The URCap's activation sequence (rq_reset, rq_activate), then a move with several
    /// variables on one line, as UR programs send them.
    #[test]
    fn a_urcap_client_activates_and_moves() {
        let t = Instant::now();
        let mut g = front(t);
        assert_eq!(say(&mut g, "SET ACT 0", t), "ack");
        assert_eq!(say(&mut g, "SET ATR 0", t), "ack");
        assert_eq!(say(&mut g, "GET ACT", t), "ACT 0");
        assert_eq!(say(&mut g, "GET STA", t), "STA 0");
        assert_eq!(say(&mut g, "SET ACT 1", t), "ack");
        assert_eq!(say(&mut g, "GET STA", t), "STA 1");
        let t1 = t + Duration::from_millis(50);
        assert_eq!(say(&mut g, "GET ACT GET STA", t1), "ACT 1\nSTA 3");
        assert_eq!(g.take_motion(), None);
        assert_eq!(say(&mut g, "SET POS 200 SPE 255 FOR 100 GTO 1", t1), "ack");
        assert_eq!(
            g.take_motion(),
            Some(Motion::Go {
                position: 200,
                speed: 255,
                force: 100
            })
        );
        assert_eq!(say(&mut g, "GET PRE", t1), "PRE 200");
        assert_eq!(say(&mut g, "GET OBJ", t1), "OBJ 0");
        // The bound hand closes onto something at 150 counts.
        g.set_measured(Measured {
            position: 150.0,
            contact: true,
        });
        let t2 = t1 + Duration::from_millis(10);
        assert_eq!(say(&mut g, "GET POS", t2), "POS 150");
        assert_eq!(say(&mut g, "GET OBJ", t2), "OBJ 2");
        assert_eq!(say(&mut g, "get spe get for", t2), "SPE 255\nFOR 100");
        assert_eq!(say(&mut g, "SET GTO 0", t2), "ack");
        assert_eq!(g.take_motion(), Some(Motion::Stop));
        // Values past a byte are clamped, as the registers hold a byte.
        assert_eq!(say(&mut g, "SET POS 300 GTO 1", t2), "ack");
        assert_eq!(say(&mut g, "GET PRE", t2), "PRE 255");
    }

    #[test]
    fn lines_that_are_not_the_protocol_are_refused() {
        let t = Instant::now();
        let mut g = front(t);
        for line in [
            "HELLO",
            "SET",
            "GET",
            "SET POS",
            "SET POS x",
            "SET STA 3",
            "GET XYZ",
            "SET POS nan",
        ] {
            let mut out = Vec::new();
            let e = answer_line(line.as_bytes(), &mut g, t, &mut out).unwrap_err();
            assert_eq!(e.reason, "bad_command", "{line}: {e}");
        }
        let mut out = Vec::new();
        assert_eq!(
            answer_line(&[0xFF, 0xFE], &mut g, t, &mut out).unwrap_err().reason,
            "not_text"
        );
        // An empty line is nothing.
        assert_eq!(say(&mut g, "  ", t), "");
    }
}
