//! A Dex3-1 hand emulated behind a Unix socket, as a separate process (used by the
//! kill/restart tests; the gateway offers the same as `handgate emulate dex3`).
//!
//! Usage: dex3-emulator --side left|right --socket PATH [--initial-q q0,..,q6] [--clock wall|exchange]

use handgate_adapters::dex3::usb::emulator::{EmulatorClock, EmulatorConfig};
use handgate_adapters::dex3::usb::socket::run_emulator_server;
use handgate_adapters::dex3::{Side, MOTOR_COUNT};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

fn parse() -> Result<(Side, PathBuf, EmulatorConfig), String> {
    let mut side = None;
    let mut socket = None;
    let mut cfg = EmulatorConfig {
        clock: EmulatorClock::Wall,
        ..EmulatorConfig::default()
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut val = || args.next().ok_or(format!("{a} needs a value"));
        match a.as_str() {
            "--side" => side = Some(val()?.parse::<Side>()?),
            "--socket" => socket = Some(PathBuf::from(val()?)),
            "--initial-q" => {
                let v: Vec<f32> = val()?
                    .split(',')
                    .map(|s| s.trim().parse::<f32>().map_err(|e| format!("--initial-q: {e}")))
                    .collect::<Result<_, _>>()?;
                let q: [f32; MOTOR_COUNT] = v
                    .try_into()
                    .map_err(|_| format!("--initial-q needs {MOTOR_COUNT} values"))?;
                cfg.initial_q = Some(q);
            }
            "--clock" => {
                cfg.clock = match val()?.as_str() {
                    "wall" => EmulatorClock::Wall,
                    "exchange" => EmulatorClock::PerExchange(Duration::from_millis(1)),
                    other => return Err(format!("unknown clock {other:?}")),
                }
            }
            "-h" | "--help" => return Err(
                "usage: dex3-emulator --side left|right --socket PATH [--initial-q q0,..,q6] [--clock wall|exchange]"
                    .into(),
            ),
            other => return Err(format!("unknown argument {other:?}")),
        }
    }
    Ok((
        side.ok_or("--side is required")?,
        socket.ok_or("--socket is required")?,
        cfg,
    ))
}

fn main() -> ExitCode {
    let (side, socket, cfg) = match parse() {
        Ok(v) => v,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    match run_emulator_server(&socket, side, cfg) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("dex3-emulator: {e}");
            ExitCode::FAILURE
        }
    }
}
