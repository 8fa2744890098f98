//! Status+command exchange rate of handgate's Robotiq device over Modbus RTU, against the wire
//! limit computed from the frame lengths, the baud rate and the turnaround.
//!
//! The gripper is the emulator (`robotiq::emulator`) behind a simulated half-duplex RS-485
//! line at 8N1 (10 bits a character): the request takes its wire time, the gripper answers
//! after a turnaround of 3.5 characters (the least silence Modbus RTU allows between frames;
//! assumed: the manual gives no figure), the answer takes its wire time. handgate's device
//! runs its real loop over the Modbus kit's RTU master, which keeps the line silent for the
//! spec's frame gap (1.75 ms above 19200 baud) before each request. One exchange is one FC23
//! (write 3 request registers, read 3 status registers): 19 bytes out, 11 back.
//!
//! Wire limit: 1 / (wire(19) + turnaround + wire(11) + gap). Cases: the device at the
//! manual's 200 Hz, and asked for 1000 Hz (as fast as the line answers).
//!
//! Run: `cargo bench -p handgate-adapters --bench robotiq` (optional argument: seconds per
//! case, default 5). Prints one markdown table row per case.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use handgate_adapters::device::{Backend, DeviceInfo, HandDevice};
use handgate_adapters::front::stream::Session;
use handgate_adapters::modbus::master::RtuTiming;
use handgate_adapters::modbus::rtu;
use handgate_adapters::model::{CommandBody, DeviceKind, HandCommand, Side};
use handgate_adapters::robotiq::device::{LoopConfig, RobotiqDevice};
use handgate_adapters::robotiq::emulator::{Gripper, Tuning};
use handgate_adapters::robotiq::front::{rtu_session_on, ImageMap};
use handgate_adapters::robotiq::rtu::RtuLink;
use handgate_adapters::robotiq::table::{table, Variant};
use handgate_adapters::serial::transport::{Connector, Transport, TransportError};

/// Bits of one character on the gripper's line (8N1).
const BITS: u32 = 10;
/// FC23 request and answer lengths (slave, function, addresses, counts, byte count, 6 data
/// bytes, CRC; slave, function, byte count, 6 data bytes, CRC).
const REQUEST: usize = 19;
const ANSWER: usize = 11;

fn wire(bytes: usize, baud: u32) -> Duration {
    Duration::from_secs_f64(bytes as f64 * f64::from(BITS) / f64::from(baud))
}

fn turnaround(baud: u32) -> Duration {
    Duration::from_secs_f64(3.5 * f64::from(BITS) / f64::from(baud))
}

/// One exchange's wire time, the master's gap included.
fn exchange_time(baud: u32) -> Duration {
    wire(REQUEST, baud) + turnaround(baud) + wire(ANSWER, baud) + rtu::frame_gap(baud)
}

fn sleep_until(t: Instant) {
    let now = Instant::now();
    if t > now {
        std::thread::sleep(t - now);
    }
}

/// The emulated gripper on a simulated line.
struct Line {
    session: handgate_adapters::modbus::session::RtuSession<ImageMap>,
    baud: u32,
    answer: Vec<u8>,
    answer_at: Option<Instant>,
}

impl Transport for Line {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        let sent = Instant::now() + wire(bytes.len(), self.baud);
        self.answer.clear();
        let mut out = Vec::new();
        let _ = self.session.on_bytes(bytes, sent, &mut out, &mut |_| {});
        if !out.is_empty() {
            self.answer_at = Some(sent + turnaround(self.baud) + wire(out.len(), self.baud));
            self.answer = out;
        }
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, TransportError> {
        match self.answer_at {
            Some(at) if at <= Instant::now() + timeout => {
                sleep_until(at);
                let n = self.answer.len().min(buf.len());
                buf[..n].copy_from_slice(&self.answer[..n]);
                self.answer.drain(..n);
                if self.answer.is_empty() {
                    self.answer_at = None;
                }
                Ok(n)
            }
            _ => {
                std::thread::sleep(timeout);
                Ok(0)
            }
        }
    }

    fn clear_input(&mut self) -> Result<(), TransportError> {
        Ok(())
    }
}

struct LineConnector(Arc<Mutex<Gripper>>, u32);

impl Connector for LineConnector {
    fn connect(&mut self) -> Result<Box<dyn Transport>, TransportError> {
        Ok(Box::new(Line {
            session: rtu_session_on(self.0.clone(), 9),
            baud: self.1,
            answer: Vec::with_capacity(64),
            answer_at: None,
        }))
    }
    fn describe(&self) -> String {
        format!("a simulated RS-485 line at {} baud", self.1)
    }
}

fn run_case(baud: u32, rate_hz: f64, secs: f64) {
    let tuning = Tuning {
        activation: Duration::from_millis(100),
        ..Tuning::default()
    };
    let g = Arc::new(Mutex::new(Gripper::new(
        Variant::TwoF85.spec(),
        tuning,
        0.0,
        None,
        Instant::now(),
    )));
    let timing = RtuTiming {
        response_timeout: Duration::from_millis(50),
        ..RtuTiming::serial(baud)
    };
    let link = RtuLink::open(Box::new(LineConnector(g.clone(), baud)), timing, 9).expect("opens");
    let info = DeviceInfo {
        name: "bench".into(),
        kind: DeviceKind::Robotiq,
        side: Side::Center,
        backend: Backend::Serial,
        table: Arc::new(table(Variant::TwoF85, Side::Center)),
    };
    let cfg = LoopConfig {
        rate_hz,
        stale_after: Duration::from_secs(1),
        speed: 255,
        force: 100,
    };
    let dev = RobotiqDevice::start(info, Box::new(link), cfg).expect("starts");
    let warm = Instant::now();
    while !g.lock().unwrap().status().activated() {
        assert!(warm.elapsed() < Duration::from_secs(10), "never activated");
        std::thread::sleep(Duration::from_millis(5));
    }
    // Keep the fingers moving: a command every 50 ms between two closures.
    let s0 = dev.stats();
    let e0 = g.lock().unwrap().counters();
    let t0 = Instant::now();
    let mut seq = 0u64;
    while t0.elapsed().as_secs_f64() < secs {
        seq += 1;
        let closure = if seq % 2 == 0 { 0.2 } else { 0.8 };
        dev.command(HandCommand {
            seq,
            body: CommandBody::Closure {
                closure,
                stiffness: None,
            },
            tag: 0,
        })
        .expect("mapped");
        std::thread::sleep(Duration::from_millis(50));
    }
    let el = t0.elapsed().as_secs_f64();
    let s1 = dev.stats();
    let e1 = g.lock().unwrap().counters();
    dev.stop();
    // The gripper's count: every FC23 it answered is one status read (and one write).
    let exchanges = (e1.reads - e0.reads) as f64 / el;
    let failed = (s1.cycles - s0.cycles).saturating_sub(e1.reads - e0.reads);
    let limit = 1.0 / exchange_time(baud).as_secs_f64();
    println!(
        "| {baud} | {rate_hz:.0} Hz | {:.0} | {:.0} | {limit:.1} | {exchanges:.1} | {:.0} % | {} | {failed} | {} |",
        wire(REQUEST + ANSWER, baud).as_secs_f64() * 1e6,
        exchange_time(baud).as_secs_f64() * 1e6,
        100.0 * exchanges / limit,
        s1.missed_cycles - s0.missed_cycles,
        e1.early_writes - e0.early_writes,
    );
}

fn main() {
    // `cargo bench` passes "--bench"; take the first numeric argument as seconds per case.
    let secs = std::env::args()
        .skip(1)
        .find_map(|a| a.parse::<f64>().ok())
        .unwrap_or(5.0);
    println!("| baud | loop asked | wire time of the frames (us) | exchange incl. turnaround and gap (us) | wire limit (Hz) | exchanges/s | of the limit | missed deadlines | cycles without an answer | writes within 5 ms of the last |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for rate in [200.0, 1000.0] {
        run_case(115_200, rate, secs);
    }
}
