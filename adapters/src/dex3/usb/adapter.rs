//! The Dex3-1-over-USB [`HandDevice`]: canonical commands are resolved through the Dex3 table
//! against the measured state and handed to the 1 kHz [`Dex3UsbLoop`] (latest wins); the
//! loop's measurements become canonical state. The transport is chosen by [`UsbSource`]: a
//! real hand through libusb, the MCU emulator in-process, or the emulator as a separate
//! process behind a Unix socket — the emulator plugs in exactly where the hardware would.

use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};

use async_trait::async_trait;
use tokio::sync::watch;

use super::device_loop::{Dex3UsbHandle, Dex3UsbLoop, Link, LoopConfig, LoopError, Observer};
use super::emulator::{Dex3Emulator, EmulatorClock, EmulatorConfig, EmulatorTransport, SharedEmulator};
use super::rusb_transport::RusbTransport;
use super::socket::UnixSocketTransport;
use super::transport::TransportFactory;
use crate::control::{Active, CommandState, Counters};
use crate::device::{DeviceError, DeviceInfo, DeviceStats, Discover, HandDevice};
use crate::dex3::{Dex3Command, Dex3Measurement};
use crate::mapping::DeviceTable;
use crate::model::{faults, Freshness, HandCommand, HandState, Imu, JointCommand, Pad, Power, SafeAction};

/// Where the frames go.
#[derive(Debug, Clone, PartialEq)]
pub enum UsbSource {
    /// A real hand (VID 0x34B7, PID by side), optionally by serial number.
    Hardware { serial: Option<String> },
    /// The MCU emulator in this process, on its own wall clock.
    Emulator(Box<EmulatorConfig>),
    /// The MCU emulator in another process (`handgate emulate dex3 --socket PATH`).
    Socket(PathBuf),
}

/// Wire commands (IDL order) for canonical targets.
pub fn to_dex3_command(table: &DeviceTable, targets: &[JointCommand]) -> Dex3Command {
    let mut c = Dex3Command::default();
    for (m, w) in c.motors.iter_mut().zip(table.to_wire(targets)) {
        *m = w.into();
    }
    c
}

/// Canonical state from a loop measurement, into `st` (its buffers reused: the loop thread
/// does this every cycle). Sets every field but the command echo, the wall-clock time and
/// `mode` (`link::stamp` and the observer set the first two; a Dex3 has no mode).
pub fn to_hand_state(table: &DeviceTable, m: &Dex3Measurement, connected: bool, st: &mut HandState) {
    table.state_from_wire_into(&mut st.joints, |i| m.motors.get(i).map(|x| (x.q, x.dq, x.tau)));
    let mut f = 0;
    for (j, map) in st.joints.iter_mut().zip(&table.joints) {
        let mm = &m.motors[map.wire_index];
        j.temperature = mm.present.then_some(mm.temperature_winding);
        if mm.error != 0 {
            f |= faults::MOTOR_ERROR;
        }
        if mm.timeout {
            f |= faults::MOTOR_TIMEOUT;
        }
    }
    if m.error != 0 {
        f |= faults::HARDWARE;
    }
    if !connected {
        f |= faults::LINK_DOWN;
    }
    let fresh = connected && !m.stale && m.seq > 0;
    st.closure = table.closure_of_state(&st.joints);
    st.pads.resize_with(m.pads.len(), Pad::default);
    for (i, (pad, p)) in st.pads.iter_mut().zip(&m.pads).enumerate() {
        pad.set_dex3(i, p.pressure, p.temperature);
    }
    st.imu = Some(Imu {
        quaternion: [1.0, 0.0, 0.0, 0.0],
        gyroscope: m.imu.gyro,
        accelerometer: m.imu.accel,
    });
    st.power = Some(Power {
        voltage: m.power.power_v,
        current: m.power.power_a,
    });
    st.faults = f;
    st.freshness = if fresh { Freshness::Fresh } else { Freshness::Stale };
    st.measured_at = (m.seq > 0).then_some(m.measured_at);
}

/// Opens the transport again (after a disconnect, or for discovery).
type MakeFactory = Arc<dyn Fn() -> TransportFactory + Send + Sync>;

/// A Dex3-1 over USB (or its emulator at the same seam).
pub struct Dex3UsbDevice {
    info: DeviceInfo,
    cmd: CommandState,
    /// (loop command seq, client seq, client tag) of the commands handed to the loop, oldest
    /// first: the loop-thread observer tags a measurement with the client command its exchange sent.
    sent: Arc<Mutex<VecDeque<(u64, u64, u32)>>>,
    handle: Arc<Mutex<Option<Dex3UsbHandle>>>,
    state_tx: Arc<watch::Sender<HandState>>,
    state_rx: watch::Receiver<HandState>,
    /// Told of each state on the loop thread, after every cycle.
    taps: Arc<crate::device::StateTaps>,
    /// How the loop's transport is opened, and the loop's settings (to restart it after
    /// discovery, which needs the transport to itself).
    make: MakeFactory,
    config: LoopConfig,
    /// The in-process emulator, when that is the source (tests inject faults through it).
    pub emulator: Option<SharedEmulator>,
}

impl Dex3UsbDevice {
    /// Starts the loop on `source`, turning each measurement into state on the loop thread.
    pub fn start(info: DeviceInfo, source: UsbSource, config: LoopConfig) -> Result<Self, LoopError> {
        let side = info.side;
        let (make, emulator): (MakeFactory, Option<SharedEmulator>) = match source {
            UsbSource::Hardware { serial } => (Arc::new(move || RusbTransport::factory(side, serial.clone())), None),
            UsbSource::Emulator(cfg) => {
                let cfg = EmulatorConfig {
                    clock: EmulatorClock::Wall,
                    ..*cfg
                };
                let emu: SharedEmulator = Arc::new(Mutex::new(Dex3Emulator::new(side, cfg)));
                let e = emu.clone();
                (Arc::new(move || EmulatorTransport::factory(e.clone())), Some(emu))
            }
            UsbSource::Socket(path) => (Arc::new(move || UnixSocketTransport::factory(path.clone())), None),
        };
        let table = info.table.clone();
        let cmd = CommandState::new(table.clone());
        let (tx, state_rx) = watch::channel(HandState::empty(table.joint_count()));
        let device = Self {
            info,
            cmd,
            sent: Arc::default(),
            handle: Arc::new(Mutex::new(None)),
            state_tx: Arc::new(tx),
            state_rx,
            taps: Arc::default(),
            make,
            config,
            emulator,
        };
        device.spawn_loop()?;
        Ok(device)
    }

    /// Starts the device loop, its measurements turned into canonical state on the loop thread
    /// after every cycle (no second thread woken per cycle and device).
    fn spawn_loop(&self) -> Result<(), LoopError> {
        let (table, b_cmd, b_sent, tx, taps) = (
            self.info.table.clone(),
            self.cmd.clone(),
            self.sent.clone(),
            self.state_tx.clone(),
            self.taps.clone(),
        );
        let name = self.info.name.clone();
        let mut last_connects = 0;
        // (client seq, tag) of the newest command a measurement reflects.
        let mut echo = (0u64, 0u32);
        let mut clock = crate::control::CycleClock::default();
        // The state built every cycle, its buffers reused.
        let mut st = HandState::empty(table.joint_count());
        let observer: Observer = Box::new(move |m: &Dex3Measurement, link: Link| {
            // Called after every cycle (and every failed connect attempt) on the loop thread.
            clock.tick(&b_cmd.counters, std::time::Instant::now());
            to_hand_state(&table, m, link.connected, &mut st);
            if link.connects != last_connects && m.seq > 0 && !m.stale {
                // The loop itself holds the first measured state after a (re)connect; forget
                // the targets that were in force before.
                if last_connects != 0 {
                    tracing::info!(
                        device = %name,
                        connects = link.connects,
                        "hand reconnected: holding the measured position until the next command"
                    );
                    b_cmd.reseed(&st.joints);
                }
                last_connects = link.connects;
            }
            if m.seq > 0 && !m.stale {
                b_cmd.mark_measured();
            }
            b_cmd.counters.link_up.store(link.connected as u64, Ordering::Relaxed);
            echo = reflected(&mut b_sent.lock().unwrap_or_else(|p| p.into_inner()), m.cmd_seq).unwrap_or(echo);
            crate::link::stamp(&mut st, &b_cmd, b_cmd.is_safe(), true);
            // The echo is the command this measurement's exchange sent, not the last applied.
            (st.cmd_seq, st.cmd_tag) = echo;
            tx.send_modify(|out| out.clone_from(&st));
            taps.run(&st);
        });
        let handle = Dex3UsbLoop::spawn_observed((self.make)(), self.config.clone(), Some(observer))?;
        *self.handle.lock().unwrap_or_else(|p| p.into_inner()) = Some(handle);
        Ok(())
    }

    /// Folds the pending command into targets against the latest measurement and hands the
    /// result to the loop.
    fn apply(&self) {
        let measured = self.state_rx.borrow().joints.clone();
        let active = self.cmd.step(&measured);
        let targets = match &active {
            Active::Idle => return,
            Active::Command(t) | Active::Safe(_, t) => t,
        };
        if let Some(h) = self.handle.lock().unwrap_or_else(|p| p.into_inner()).as_ref() {
            let mut sent = self.sent.lock().unwrap_or_else(|p| p.into_inner());
            let loop_seq = h.set_command(to_dex3_command(&self.info.table, targets));
            let (seq, tag) = self.cmd.applied();
            sent.push_back((loop_seq, seq, tag));
            while sent.len() > SENT_HISTORY {
                sent.pop_front();
            }
            Counters::inc(&self.cmd.counters.sent);
        }
    }

    /// Stops the loop.
    pub fn stop(&self) {
        if let Some(h) = self.handle.lock().unwrap_or_else(|p| p.into_inner()).take() {
            h.stop();
        }
    }
}

impl Drop for Dex3UsbDevice {
    fn drop(&mut self) {
        self.stop();
    }
}

/// Commands remembered for tagging measurements (the loop sends one per 1 ms cycle; older
/// entries are superseded long before they could be looked up).
const SENT_HISTORY: usize = 64;

/// The (client seq, tag) of the newest command handed to the loop at or before loop seq
/// `loop_seq`, dropping the older entries; `None` when no such command is known.
fn reflected(sent: &mut VecDeque<(u64, u64, u32)>, loop_seq: u64) -> Option<(u64, u32)> {
    let n = sent.iter().take_while(|(s, _, _)| *s <= loop_seq).count();
    if n == 0 {
        return None;
    }
    let (_, seq, tag) = sent[n - 1];
    sent.drain(..n - 1);
    Some((seq, tag))
}

#[async_trait]
impl HandDevice for Dex3UsbDevice {
    fn info(&self) -> &DeviceInfo {
        &self.info
    }

    fn command(&self, cmd: HandCommand) -> Result<(), DeviceError> {
        let body = self.info.table.checked(cmd.body).inspect_err(|_| {
            crate::control::Counters::inc(&self.cmd.counters.rejected);
        })?;
        self.command_checked(cmd.seq, body, cmd.tag)
    }

    fn command_checked(&self, seq: u64, body: crate::mapping::CheckedBody, tag: u32) -> Result<(), DeviceError> {
        self.cmd.submit_checked(seq, body, tag);
        self.apply();
        // Motors whose 1 s timeout protection tripped while the link stalled (shorter than a
        // reconnect, which clears it) stay limp until the latch is cleared. A NEW client
        // command is the intent to move again: clear it now that the new targets are in
        // place (the old target is never re-energised by itself). docs/reliability.md.
        if self.state_rx.borrow().faults & faults::MOTOR_TIMEOUT != 0 {
            if let Some(h) = self.handle.lock().unwrap_or_else(|p| p.into_inner()).as_ref() {
                h.clear_timeouts();
            }
        }
        Ok(())
    }

    fn state(&self) -> watch::Receiver<HandState> {
        self.state_rx.clone()
    }

    fn state_taps(&self) -> Option<&crate::device::StateTaps> {
        Some(&self.taps)
    }

    fn commanded(&self) -> Option<Vec<f32>> {
        self.cmd.targets()
    }

    async fn safe_state(&self, action: SafeAction) -> Result<(), DeviceError> {
        if crate::link::blind_hold_request(&self.state_rx.borrow(), action) {
            // Never "hold" a position that was never measured: the loop's own connect hold
            // (damping at the first measured state) is already in force.
            return Ok(());
        }
        self.cmd.request_safe(action);
        self.apply();
        Ok(())
    }

    fn discovery(&self) -> Option<&dyn Discover> {
        Some(self)
    }

    fn stats(&self) -> DeviceStats {
        let mut s = self.cmd.counters.snapshot();
        if let Some(h) = self.handle.lock().unwrap_or_else(|p| p.into_inner()).as_ref() {
            let l = h.stats();
            s.crc_errors = l.frame_crc_errors + l.packet_crc_errors;
            s.reconnects = l.reconnects;
            s.missed_cycles = l.misses;
            s.state_samples = l.good_frames;
            s.link_up = l.connected;
        }
        s
    }
}

#[async_trait]
impl Discover for Dex3UsbDevice {
    /// Stops the device loop (discovery needs the transport to itself: it sends zero-gain
    /// frames, nothing moves), asks every (bus, id) which motor or sensor answers, prints the
    /// `[devices.usb.wiring]` template, and restarts the loop (which holds the first measured
    /// position after its connect, as after any reconnect).
    async fn discover(&self) -> Result<String, DeviceError> {
        let handle = self.handle.lock().unwrap_or_else(|p| p.into_inner()).take();
        let (make, scalings) = (self.make.clone(), self.config.scalings);
        let report = tokio::task::spawn_blocking(move || {
            if let Some(h) = handle {
                h.stop();
            }
            let mut t = (make())().map_err(DeviceError::link)?;
            super::discovery::discover(t.as_mut(), super::discovery::DiscoveryOptions::default(), &scalings)
                .map_err(DeviceError::link)
        })
        .await
        .map_err(|_| DeviceError::Stopped)?;
        self.spawn_loop().map_err(DeviceError::link)?;
        Ok(report?.wiring_template())
    }
}
