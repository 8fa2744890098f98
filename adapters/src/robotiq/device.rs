//! The Robotiq [`HandDevice`]: one thread per gripper exchanging the request and the status
//! with it on deadlines (200 Hz by default, the manual's "usual speed"), through a [`Link`]
//! (Modbus RTU on a serial line or over TCP, or the in-process emulator). The canonical jaw
//! maps through the variant's table onto rPR; the status becomes canonical state, gOBJ the
//! state's `contact` (the table's `Contact::Reported`).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use tokio::sync::watch;

use super::driver::{to_hand_state, Driver, Event};
use super::regs::{Request, Status};
use crate::control::{Active, CommandState, Counters, CycleClock};
use crate::device::{DeviceError, DeviceInfo, StateTaps};
use crate::model::{faults, Freshness, HandState, SafeAction};

/// Why an exchange with the gripper failed.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    /// No (complete) reply in time: the gripper is silent, unpowered or on another id.
    #[error("no reply within {0:?}")]
    Timeout(Duration),
    /// A reply failed its CRC.
    #[error("a reply failed its CRC")]
    Crc,
    /// A reply that is not the answer to the request (another slave, another function).
    #[error("unexpected reply: {0}")]
    Unexpected(String),
    /// The line itself (a serial port unplugged, a TCP connection closed).
    #[error("{0}")]
    Io(#[from] std::io::Error),
}

/// How the device reaches its gripper: one exchange writes the request image and reads the
/// status image.
pub trait Link: Send {
    /// Writes `request` (0x03E8..) and reads the status (0x07D0..).
    fn exchange(&mut self, request: &Request) -> Result<Status, LinkError>;
    /// After a failed exchange: reopen what needs reopening (a TCP connection, an unplugged
    /// adapter). Default: nothing to reopen.
    fn recover(&mut self) -> Result<(), LinkError> {
        Ok(())
    }
    /// What it is, for the log (`/dev/ttyUSB0 @ 115200 slave 9`).
    fn describe(&self) -> String;
}

/// The in-process emulated gripper as a [`Link`] (backend emulator): each exchange writes
/// then reads its registers at the wall clock's `now`.
#[derive(Debug, Clone)]
pub struct EmulatedLink(pub Arc<Mutex<super::emulator::Gripper>>);

impl Link for EmulatedLink {
    fn exchange(&mut self, request: &Request) -> Result<Status, LinkError> {
        use super::emulator::Table;
        use super::regs::{REQUEST_ADDR, STATUS_ADDR};
        let mut g = self.0.lock().unwrap_or_else(|p| p.into_inner());
        let now = Instant::now();
        let bad = |e: super::emulator::BadAddress| LinkError::Unexpected(e.to_string());
        g.write(REQUEST_ADDR, request.to_words(), now).map_err(bad)?;
        let mut w = [0u16; 3];
        g.read(Table::Input, STATUS_ADDR, &mut w, now).map_err(bad)?;
        Ok(Status::from_words(&w))
    }

    fn describe(&self) -> String {
        "an emulated gripper (in process)".into()
    }
}

/// The device loop's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopConfig {
    pub rate_hz: f64,
    /// A status older than this is stale (and the link down).
    pub stale_after: Duration,
    /// rSP and rFR of every move.
    pub speed: u8,
    pub force: u8,
}

/// How many periods late the device loop still catches up (runs its cycles back to back)
/// rather than dropping them.
pub const CATCH_UP: u32 = 10;

/// One Robotiq gripper.
pub struct RobotiqDevice {
    info: DeviceInfo,
    cmd: CommandState,
    state_rx: watch::Receiver<HandState>,
    taps: Arc<StateTaps>,
    stop: Arc<AtomicBool>,
    thread: Mutex<Option<JoinHandle<()>>>,
}

impl RobotiqDevice {
    /// Starts the device loop on `link`.
    pub fn start(info: DeviceInfo, link: Box<dyn Link>, cfg: LoopConfig) -> Result<Self, DeviceError> {
        let cmd = CommandState::new(info.table.clone());
        let (tx, state_rx) = watch::channel(HandState::empty(info.table.joint_count()));
        let stop = Arc::new(AtomicBool::new(false));
        let taps: Arc<StateTaps> = Arc::default();
        let (l_cmd, l_stop, l_taps, table) = (cmd.clone(), stop.clone(), taps.clone(), info.table.clone());
        let span = tracing::info_span!("device", name = %info.name, kind = %info.kind, backend = info.backend.as_str());
        if !(cfg.rate_hz.is_finite() && cfg.rate_hz > 0.0) {
            return Err(DeviceError::Config(format!("rate {} Hz", cfg.rate_hz)));
        }
        let thread = std::thread::Builder::new()
            .name(format!("robotiq-{}", info.name))
            .spawn(move || {
                crate::realtime::enter_device_loop(); // [realtime]: this thread only
                let _span = span.enter();
                run(link, cfg, &table, &l_cmd, &l_stop, &tx, &l_taps);
            })
            .map_err(DeviceError::link)?;
        Ok(Self {
            info,
            cmd,
            state_rx,
            taps,
            stop,
            thread: Mutex::new(Some(thread)),
        })
    }

    /// Stops the device loop.
    pub fn stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.lock().unwrap_or_else(|p| p.into_inner()).take() {
            let _ = t.join();
        }
    }
}

impl Drop for RobotiqDevice {
    fn drop(&mut self) {
        self.stop();
    }
}

/// The device loop: one exchange per period, on deadlines.
fn run(
    mut link: Box<dyn Link>,
    cfg: LoopConfig,
    table: &crate::mapping::DeviceTable,
    cmd: &CommandState,
    stop: &AtomicBool,
    tx: &watch::Sender<HandState>,
    taps: &StateTaps,
) {
    let period = Duration::from_secs_f64(1.0 / cfg.rate_hz);
    let jaw = &table.joints[0];
    let mut driver = Driver::new(cfg.speed, cfg.force);
    let mut tracker = crate::link::LinkTracker::default();
    let mut clock = CycleClock::default();
    let mut active = Active::Idle;
    let mut st = HandState::empty(table.joint_count());
    let mut prev: Option<(Status, Instant)> = None;
    let mut last_ok: Option<Instant> = None;
    let mut failing = false;
    let mut next = Instant::now();
    tracing::info!(link = %link.describe(), rate_hz = cfg.rate_hz, "robotiq: resetting and activating the gripper");
    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        clock.tick(&cmd.counters, now);
        cmd.step_into(&st.joints, &mut active);
        let target = match &active {
            _ if crate::link::blind_hold(tracker.ever_measured(), &active) => None,
            Active::Command(t) | Active::Safe(SafeAction::Hold | SafeAction::Open, t) => {
                Some(jaw.q_to_wire(t[0].q).round().clamp(0.0, 255.0) as u8)
            }
            Active::Idle | Active::Safe(SafeAction::Limp, _) => None,
        };
        let request = driver.request(target);
        match link.exchange(&request) {
            Ok(s) => {
                let at = Instant::now();
                match driver.observe(at, &s) {
                    Event::None => {}
                    Event::ActivationStarted => tracing::info!("robotiq: activation started (rACT 1)"),
                    Event::Activated => tracing::info!(position = s.position, "robotiq: activated (gSTA 3)"),
                    Event::ActivationTimedOut => tracing::warn!(
                        timeout_s = super::driver::ACTIVATION_TIMEOUT.as_secs(),
                        "robotiq: activation did not complete; resetting and activating again"
                    ),
                    Event::FoundReset => {
                        tracing::warn!(
                            "robotiq: the gripper was reset (power cycle or another master): activating again"
                        )
                    }
                    Event::MajorFault(f) => {
                        tracing::warn!(gflt = f, "robotiq: major fault: resetting and activating again")
                    }
                }
                if request.gto {
                    Counters::inc(&cmd.counters.sent);
                }
                to_hand_state(table, &s, at, prev, &mut st);
                prev = Some((s, at));
                last_ok = Some(at);
                if failing {
                    tracing::info!(link = %link.describe(), "robotiq: the gripper answers again");
                    failing = false;
                }
            }
            Err(e) => {
                if matches!(e, LinkError::Crc) {
                    Counters::inc(&cmd.counters.crc_errors);
                }
                if !failing {
                    tracing::warn!(link = %link.describe(), error = %e, "robotiq: exchange failed");
                    failing = true;
                }
                if let Err(e) = link.recover() {
                    tracing::debug!(error = %e, "robotiq: reopening the link failed");
                }
            }
        }
        let fresh = last_ok.is_some_and(|t| Instant::now().saturating_duration_since(t) <= cfg.stale_after);
        st.freshness = if fresh { Freshness::Fresh } else { Freshness::Stale };
        if fresh {
            st.faults &= !faults::LINK_DOWN;
            Counters::inc(&cmd.counters.state_samples);
        } else {
            st.faults |= faults::LINK_DOWN;
        }
        if tracker.observe(fresh, &st.joints, cmd) {
            tracing::info!("robotiq: back: holding the measured position until the next command");
        }
        crate::link::stamp(&mut st, cmd, cmd.is_safe(), true);
        tx.send_modify(|out| out.clone_from(&st));
        taps.run(&st);
        // On the grid of deadlines: a cycle that ran late is followed at once by the next, so
        // the rate is kept on average (at 200 Hz an FC23 exchange at 115200 baud takes most of
        // the 5 ms period); more than [`CATCH_UP`] periods late (a stall), the missed
        // deadlines are dropped and the grid starts again from now.
        next += period;
        let after = Instant::now();
        if next <= after {
            Counters::inc(&cmd.counters.missed_cycles);
            if after - next > period * CATCH_UP {
                next = after;
            }
        } else {
            std::thread::sleep(next - after);
        }
    }
}

impl crate::link::BusDevice for RobotiqDevice {
    fn info(&self) -> &DeviceInfo {
        &self.info
    }

    fn commands(&self) -> &CommandState {
        &self.cmd
    }

    fn state_rx(&self) -> &watch::Receiver<HandState> {
        &self.state_rx
    }

    fn taps(&self) -> &crate::device::StateTaps {
        &self.taps
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::Backend;
    use crate::device::HandDevice;
    use crate::model::HandCommand;
    use crate::model::{CommandBody, DeviceKind, Side};
    use crate::motion::Verdict;
    use crate::robotiq::emulator::{Gripper, Tuning};
    use crate::robotiq::table::{table, Variant};

    fn device(object_at: Option<f32>) -> (RobotiqDevice, Arc<Mutex<Gripper>>) {
        let t = Arc::new(table(Variant::TwoF85, Side::Center));
        let tuning = Tuning {
            activation: Duration::from_millis(200),
            ..Tuning::default()
        };
        let g = Arc::new(Mutex::new(Gripper::new(
            Variant::TwoF85.spec(),
            tuning,
            0.0,
            object_at,
            Instant::now(),
        )));
        let info = DeviceInfo {
            name: "g".into(),
            kind: DeviceKind::Robotiq,
            side: Side::Center,
            backend: Backend::Emulator,
            table: t,
        };
        let cfg = LoopConfig {
            rate_hz: 200.0,
            stale_after: Duration::from_millis(100),
            speed: 255,
            force: 255,
        };
        (
            RobotiqDevice::start(info, Box::new(EmulatedLink(g.clone())), cfg).unwrap(),
            g,
        )
    }

    /// Waits (on state samples, at most `within`) until `f` holds for the device's state.
    fn wait_for(d: &RobotiqDevice, within: Duration, what: &str, f: impl Fn(&HandState) -> bool) -> HandState {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_time()
            .build()
            .unwrap();
        let mut rx = d.state();
        rt.block_on(async {
            tokio::time::timeout(within, async {
                loop {
                    {
                        let st = rx.borrow_and_update();
                        if f(&st) {
                            return st.clone();
                        }
                    }
                    rx.changed().await.unwrap();
                }
            })
            .await
            .unwrap_or_else(|_| panic!("{what}: not within {within:?}: {:?}", *d.state().borrow()))
        })
    }

    /// The device resets and activates the gripper, then a closure of 1 closes it onto the
    /// object: gOBJ 2 becomes the state's contact and the motion verdict "holding".
    #[test]
    fn activates_then_closes_onto_the_object_and_reports_holding() {
        let (d, g) = device(Some(128.0));
        wait_for(&d, Duration::from_secs(3), "activated", |_| {
            g.lock().unwrap().status().activated()
        });
        d.command(HandCommand {
            seq: 1,
            body: CommandBody::Closure {
                closure: 1.0,
                stiffness: None,
            },
            tag: 7,
        })
        .unwrap();
        let st = wait_for(&d, Duration::from_secs(3), "holding", |st| {
            st.motion.verdict == Verdict::Holding
        });
        assert_eq!(st.contact, vec![true]);
        assert_eq!(st.freshness, Freshness::Fresh);
        let q = st.joints[0].q;
        assert!((q - 128.0 / 255.0 * 0.8).abs() < 0.01, "{q}");
        assert!(st.joints[0].tau > 0.5, "grip current, A: {st:?}");
        assert_eq!(st.cmd_seq, 1);
        assert_eq!(g.lock().unwrap().applied().position, 255);
        // Opening leaves the object: no contact, at position.
        d.command(HandCommand {
            seq: 2,
            body: CommandBody::Closure {
                closure: 0.0,
                stiffness: None,
            },
            tag: 8,
        })
        .unwrap();
        let st = wait_for(&d, Duration::from_secs(3), "open", |st| st.joints[0].q < 0.01);
        assert_eq!(st.contact, vec![false]);
        let stats = d.stats();
        assert!(stats.sent > 0 && stats.state_samples > 0 && stats.link_up, "{stats:?}");
    }

    /// A gripper that stops answering: the state goes stale with LINK_DOWN; when it answers
    /// again (reset by a power cycle) it is activated again.
    #[test]
    fn a_silent_gripper_goes_stale_and_is_activated_again_when_back() {
        struct Flaky(EmulatedLink, Arc<AtomicBool>);
        impl Link for Flaky {
            fn exchange(&mut self, r: &Request) -> Result<Status, LinkError> {
                if self.1.load(Ordering::Relaxed) {
                    return Err(LinkError::Timeout(Duration::from_millis(1)));
                }
                self.0.exchange(r)
            }
            fn describe(&self) -> String {
                "flaky".into()
            }
        }
        let (d0, g) = device(None);
        drop(d0);
        let silent = Arc::new(AtomicBool::new(false));
        let info = DeviceInfo {
            name: "g".into(),
            kind: DeviceKind::Robotiq,
            side: Side::Center,
            backend: Backend::Emulator,
            table: Arc::new(table(Variant::TwoF85, Side::Center)),
        };
        let cfg = LoopConfig {
            rate_hz: 200.0,
            stale_after: Duration::from_millis(50),
            speed: 255,
            force: 255,
        };
        let d = RobotiqDevice::start(info, Box::new(Flaky(EmulatedLink(g.clone()), silent.clone())), cfg).unwrap();
        wait_for(&d, Duration::from_secs(3), "activated", |_| {
            g.lock().unwrap().status().activated()
        });
        silent.store(true, Ordering::Relaxed);
        let st = wait_for(&d, Duration::from_secs(2), "stale", |st| {
            st.freshness == Freshness::Stale
        });
        assert_ne!(st.faults & faults::LINK_DOWN, 0);
        // Power cycle: a fresh, reset gripper answers.
        *g.lock().unwrap() = Gripper::new(
            Variant::TwoF85.spec(),
            Tuning {
                activation: Duration::from_millis(100),
                ..Tuning::default()
            },
            0.0,
            None,
            Instant::now(),
        );
        silent.store(false, Ordering::Relaxed);
        wait_for(&d, Duration::from_secs(3), "activated again", |st| {
            st.freshness == Freshness::Fresh && g.lock().unwrap().status().activated()
        });
        assert!(d.stats().reconnects >= 1);
    }
}
