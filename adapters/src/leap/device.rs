//! The LEAP Hand [`HandDevice`]: one thread owns the bus (a [`Connector`]: the U2D2's port,
//! or the in-process emulator) and runs the device loop on deadlines (500 Hz by default):
//! the targets in force become 16 goal positions in one Sync Write (116), then one Sync Read
//! (or Fast Sync Read) of present current, velocity and position (126, 10 bytes) of every
//! servo becomes the canonical state. Nothing is allocated per cycle once the buffers have
//! grown (requests encoded into reused buffers, replies decoded in place).
//!
//! Opening (and every reconnect) runs the LEAP's init (LEAP_Hand_API `python/main.py`):
//! torque off, Return Delay Time 0, operating mode 5 (current-based position), Position P
//! 600 / I 0 / D 200 (x0.75 on ids 0, 4, 8), goal current from the profile (350 mA lite, 550
//! full); then each servo's goal is set to where it stands before torque goes on, so the hand
//! never jumps to a position it was not commanded to.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use tokio::sync::watch;

use super::control_table::{
    gain_for, parse_present, rad_to_ticks, MOTORS, POSITION_D, POSITION_I, POSITION_P, PRESENT_BLOCK, TORQUE_PER_AMP,
};
use crate::control::{Active, CommandState, Counters, CycleClock};
use crate::device::{DeviceError, DeviceInfo, StateTaps};
use crate::dynamixel::control_table::{reg, OperatingMode, Reg};
use crate::dynamixel::protocol::{
    fast_sync_entries, is_fast_reply, wire_time, Decoder, FrameError, Request, StatusRef,
};
use crate::mapping::DeviceTable;
use crate::model::{faults, Freshness, HandState, SafeAction};
use crate::serial::transport::{Connector, Transport, TransportError};

/// How a LEAP Hand's bus is driven.
#[derive(Debug, Clone, PartialEq)]
pub struct LeapBusConfig {
    /// Servo ids in joint order.
    pub ids: Vec<u8>,
    pub baud: u32,
    /// Goal Current (102) written at init, mA.
    pub goal_current_ma: u16,
    /// Read with Fast Sync Read (0x8A: one reply packet for all 16) instead of Sync Read.
    pub fast_sync_read: bool,
    /// Device loop rate, Hz.
    pub rate_hz: f64,
    /// A measurement older than this is stale.
    pub stale_after: Duration,
    /// Grace for the replies beyond their wire time (USB adapter latency: an FTDI at its
    /// default 16 ms latency timer needs about 20 ms; at 1 ms, 2 ms).
    pub response_grace: Duration,
}

impl Default for LeapBusConfig {
    fn default() -> Self {
        Self {
            ids: super::control_table::DEFAULT_IDS.to_vec(),
            baud: super::control_table::BAUD,
            goal_current_ma: super::control_table::GOAL_CURRENT_LITE_MA,
            fast_sync_read: false,
            rate_hz: 500.0,
            stale_after: Duration::from_millis(100),
            response_grace: Duration::from_millis(2),
        }
    }
}

/// Bus counters (lock-free; read by `stats`).
#[derive(Debug, Default)]
pub struct BusCounters {
    pub exchanges: AtomicU64,
    /// Servo replies missing at an exchange's deadline.
    pub missing_replies: AtomicU64,
    pub crc_errors: AtomicU64,
    pub reconnects: AtomicU64,
    pub inits: AtomicU64,
}

/// One LEAP Hand.
pub struct LeapDevice {
    info: DeviceInfo,
    cmd: CommandState,
    state_rx: watch::Receiver<HandState>,
    taps: Arc<StateTaps>,
    counters: Arc<BusCounters>,
    stop: Arc<AtomicBool>,
    thread: Mutex<Option<JoinHandle<()>>>,
}

impl LeapDevice {
    /// Starts the device loop on `connector` (it connects, and reconnects, on its own thread).
    pub fn start(info: DeviceInfo, connector: Box<dyn Connector>, cfg: LeapBusConfig) -> Result<Self, DeviceError> {
        if cfg.ids.len() != MOTORS || cfg.ids.len() != info.table.joint_count() {
            return Err(DeviceError::Config(format!(
                "a LEAP Hand has {MOTORS} servos, {} ids given",
                cfg.ids.len()
            )));
        }
        let table = info.table.clone();
        let cmd = CommandState::new(table.clone());
        let (tx, state_rx) = watch::channel(HandState::empty(table.joint_count()));
        let stop = Arc::new(AtomicBool::new(false));
        let taps: Arc<StateTaps> = Arc::default();
        let counters: Arc<BusCounters> = Arc::default();
        let mut lp = Loop {
            table,
            cmd: cmd.clone(),
            cfg,
            connector,
            link: None,
            tx,
            taps: taps.clone(),
            counters: counters.clone(),
            stop: stop.clone(),
            present: [[0u8; 10]; MOTORS],
            got: [false; MOTORS],
            st: HandState::empty(MOTORS),
            active: Active::Idle,
            torque_on: false,
            measured_at: None,
            link_tracker: crate::link::LinkTracker::default(),
            clock: CycleClock::default(),
            read_req: Request::Ping { id: 0 },
            goal_req: Request::Ping { id: 0 },
        };
        lp.build_requests();
        let span = tracing::info_span!("device", name = %info.name, kind = %info.kind, backend = info.backend.as_str());
        let thread = std::thread::Builder::new()
            .name(format!("leap-{}", info.name))
            .spawn(move || {
                crate::realtime::enter_device_loop();
                let _span = span.enter();
                lp.run();
            })
            .map_err(DeviceError::link)?;
        Ok(Self {
            info,
            cmd,
            state_rx,
            taps,
            counters,
            stop,
            thread: Mutex::new(Some(thread)),
        })
    }

    /// Stops the device loop (the servos keep their last goal).
    pub fn stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.lock().unwrap_or_else(|p| p.into_inner()).take() {
            let _ = t.join();
        }
    }

    /// The bus counters.
    pub fn bus_counters(&self) -> &BusCounters {
        &self.counters
    }
}

impl Drop for LeapDevice {
    fn drop(&mut self) {
        self.stop();
    }
}

impl crate::link::BusDevice for LeapDevice {
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

    fn link_counters(&self) -> (u64, u64) {
        let c = &self.counters;
        (
            c.reconnects.load(Ordering::Relaxed),
            c.crc_errors.load(Ordering::Relaxed),
        )
    }
}

/// The bus as the loop holds it.
struct Link {
    t: Box<dyn Transport>,
    dec: Decoder,
    tx: Vec<u8>,
    rx: Box<[u8; 4096]>,
}

struct Loop {
    table: Arc<DeviceTable>,
    cmd: CommandState,
    cfg: LeapBusConfig,
    connector: Box<dyn Connector>,
    link: Option<Link>,
    tx: watch::Sender<HandState>,
    taps: Arc<StateTaps>,
    counters: Arc<BusCounters>,
    stop: Arc<AtomicBool>,
    /// Each servo's present block from the last exchange, and whether it answered.
    present: [[u8; 10]; MOTORS],
    got: [bool; MOTORS],
    st: HandState,
    active: Active,
    torque_on: bool,
    measured_at: Option<Instant>,
    link_tracker: crate::link::LinkTracker,
    clock: CycleClock,
    /// The cycle's two requests, built once (their buffers reused).
    read_req: Request,
    goal_req: Request,
}

/// Whether the exchange's failure is the bus's (reconnect) rather than silence.
type Exchange = Result<usize, TransportError>;

impl Loop {
    fn build_requests(&mut self) {
        let ids = self.cfg.ids.clone();
        self.read_req = if self.cfg.fast_sync_read {
            Request::FastSyncRead {
                addr: PRESENT_BLOCK.addr,
                len: PRESENT_BLOCK.len,
                ids,
            }
        } else {
            Request::SyncRead {
                addr: PRESENT_BLOCK.addr,
                len: PRESENT_BLOCK.len,
                ids,
            }
        };
        self.goal_req = Request::SyncWrite {
            addr: reg::GOAL_POSITION.addr,
            len: 4,
            entries: self.cfg.ids.iter().map(|&id| (id, vec![0u8; 4])).collect(),
        };
    }

    fn run(&mut self) {
        let period = Duration::from_secs_f64(1.0 / self.cfg.rate_hz.max(1.0));
        let mut next = crate::loops::first_deadline(period);
        let mut backoff = Duration::from_millis(50);
        let mut retry_at = Instant::now();
        while !self.stop.load(Ordering::Relaxed) {
            let now = Instant::now();
            self.clock.tick(&self.cmd.counters, now);
            if self.link.is_none() && now >= retry_at {
                match self.open() {
                    Ok(()) => backoff = Duration::from_millis(50),
                    Err(e) => {
                        tracing::debug!(error = %e, "LEAP bus not up; retrying");
                        retry_at = now + backoff;
                        backoff = (backoff * 2).min(Duration::from_secs(2));
                    }
                }
            }
            if self.link.is_some() {
                if let Err(e) = self.cycle() {
                    tracing::warn!(error = %e, "LEAP bus lost; reconnecting");
                    self.link = None;
                    self.torque_on = false;
                    Counters::inc(&self.counters.reconnects);
                    retry_at = Instant::now() + backoff;
                }
            }
            self.publish(Instant::now());
            // The next deadline on the grid; cycles that could not run are missed.
            next += period;
            let now = Instant::now();
            if now > next {
                let behind = (now - next).as_nanos() / period.as_nanos().max(1);
                self.cmd
                    .counters
                    .missed_cycles
                    .fetch_add(behind as u64 + 1, Ordering::Relaxed);
                next = crate::loops::grid_at_or_after(now, period);
            }
            let wait = next.saturating_duration_since(Instant::now());
            if !wait.is_zero() {
                std::thread::sleep(wait);
            }
        }
    }

    /// Connects and runs the init; the link is kept only when every servo answered.
    fn open(&mut self) -> Result<(), String> {
        let t = self.connector.connect().map_err(|e| e.to_string())?;
        self.link = Some(Link {
            t,
            // Replies of a cycle (at most 16 x 21 bytes) plus a read buffer's worth.
            dec: Decoder::with_capacity(8192),
            tx: Vec::with_capacity(512),
            rx: Box::new([0u8; 4096]),
        });
        match self.init() {
            Ok(()) => {
                Counters::inc(&self.counters.inits);
                tracing::info!(port = %self.connector.describe(), "LEAP Hand initialised");
                Ok(())
            }
            Err(e) => {
                self.link = None;
                Err(e)
            }
        }
    }

    /// Writes one item to every servo in one Sync Write, `value(id)` each.
    fn sync_write(&mut self, r: Reg, value: impl Fn(u8) -> i64) -> Result<(), TransportError> {
        let n = r.len as usize;
        let req = Request::SyncWrite {
            addr: r.addr,
            len: r.len,
            entries: self
                .cfg
                .ids
                .iter()
                .map(|&id| (id, value(id).to_le_bytes()[..n].to_vec()))
                .collect(),
        };
        let link = self.link.as_mut().ok_or(TransportError::Disconnected)?;
        req.encode_into(&mut link.tx)
            .map_err(|e| TransportError::Io(std::io::Error::other(e)))?;
        link.t.write_all(&link.tx)
    }

    fn init(&mut self) -> Result<(), String> {
        let e = |e: TransportError| e.to_string();
        self.sync_write(reg::TORQUE_ENABLE, |_| 0).map_err(e)?;
        self.sync_write(reg::RETURN_DELAY_TIME, |_| 0).map_err(e)?;
        self.sync_write(reg::OPERATING_MODE, |_| OperatingMode::CurrentBasedPosition as i64)
            .map_err(e)?;
        self.sync_write(reg::POSITION_P_GAIN, |id| i64::from(gain_for(id, POSITION_P)))
            .map_err(e)?;
        self.sync_write(reg::POSITION_I_GAIN, |_| i64::from(POSITION_I))
            .map_err(e)?;
        self.sync_write(reg::POSITION_D_GAIN, |id| i64::from(gain_for(id, POSITION_D)))
            .map_err(e)?;
        let ma = i64::from(self.cfg.goal_current_ma);
        self.sync_write(reg::GOAL_CURRENT, |_| ma).map_err(e)?;
        // Where each servo stands becomes its goal before torque goes on.
        let got = self.read_present().map_err(e)?;
        if got < MOTORS {
            let missing: Vec<u8> = (0..MOTORS).filter(|&i| !self.got[i]).map(|i| self.cfg.ids[i]).collect();
            return Err(format!("servo(s) {missing:?} did not answer"));
        }
        let goals: Vec<i64> = self
            .present
            .iter()
            .map(|b| i64::from(crate::dynamixel::protocol::le_i32(&b[6..10]).unwrap_or(2048)))
            .collect();
        let ids = self.cfg.ids.clone();
        self.sync_write(reg::GOAL_POSITION, |id| {
            ids.iter().position(|&i| i == id).map_or(2048, |k| goals[k])
        })
        .map_err(e)?;
        self.sync_write(reg::TORQUE_ENABLE, |_| 1).map_err(e)?;
        self.torque_on = true;
        self.measured_at = Some(Instant::now());
        Ok(())
    }

    /// One cycle: goals out (when something is commanded), present values in.
    fn cycle(&mut self) -> Result<(), TransportError> {
        self.cmd.step_into(&self.st.joints, &mut self.active);
        let limp = matches!(self.active, Active::Safe(SafeAction::Limp, _));
        let blind = crate::link::blind_hold(self.link_tracker.ever_measured(), &self.active);
        match &self.active {
            Active::Idle => {}
            _ if blind => {}
            _ if limp => {
                if self.torque_on {
                    self.sync_write(reg::TORQUE_ENABLE, |_| 0)?;
                    self.torque_on = false;
                    Counters::inc(&self.cmd.counters.sent);
                }
            }
            Active::Command(t) | Active::Safe(_, t) => {
                if let Request::SyncWrite { entries, .. } = &mut self.goal_req {
                    for (i, w) in self.table.wire_targets(t) {
                        if let Some((_, d)) = entries.get_mut(i) {
                            d.copy_from_slice(&rad_to_ticks(w.q).to_le_bytes());
                        }
                    }
                }
                let link = self.link.as_mut().ok_or(TransportError::Disconnected)?;
                self.goal_req
                    .encode_into(&mut link.tx)
                    .map_err(|e| TransportError::Io(std::io::Error::other(e)))?;
                link.t.write_all(&link.tx)?;
                if !self.torque_on {
                    self.sync_write(reg::TORQUE_ENABLE, |_| 1)?;
                    self.torque_on = true;
                }
                Counters::inc(&self.cmd.counters.sent);
            }
        }
        let got = self.read_present()?;
        if got == MOTORS {
            self.measured_at = Some(Instant::now());
        }
        Ok(())
    }

    /// Sends the read request and collects the servos' present blocks until every servo has
    /// answered or the replies' wire time plus the grace has passed. Returns how many answered.
    fn read_present(&mut self) -> Exchange {
        self.got = [false; MOTORS];
        let link = self.link.as_mut().ok_or(TransportError::Disconnected)?;
        self.read_req
            .encode_into(&mut link.tx)
            .map_err(|e| TransportError::Io(std::io::Error::other(e)))?;
        link.t.clear_input()?;
        link.dec.reset();
        link.t.write_all(&link.tx)?;
        Counters::inc(&self.counters.exchanges);
        let len = PRESENT_BLOCK.len as usize;
        let reply_len = if self.cfg.fast_sync_read {
            11 + MOTORS * (len + 4) - 4
        } else {
            MOTORS * (11 + len)
        };
        let deadline = Instant::now() + wire_time(link.tx.len() + reply_len, self.cfg.baud) + self.cfg.response_grace;
        let mut count = 0;
        let ids = &self.cfg.ids;
        while count < MOTORS {
            let now = Instant::now();
            if now >= deadline {
                break;
            }
            let n = link.t.read(&mut link.rx[..], deadline - now)?;
            if n == 0 {
                continue;
            }
            link.dec.push(&link.rx[..n]);
            while let Some(frame) = link.dec.next_frame_ref() {
                let pk = match frame {
                    Ok(pk) => pk,
                    Err(FrameError::BadCrc { .. }) => {
                        Counters::inc(&self.counters.crc_errors);
                        continue;
                    }
                    Err(_) => continue,
                };
                let mut take = |id: u8, data: &[u8]| {
                    if let Some(i) = ids.iter().position(|&x| x == id) {
                        if data.len() == len && !self.got[i] {
                            self.present[i].copy_from_slice(data);
                            self.got[i] = true;
                            count += 1;
                        }
                    }
                };
                if is_fast_reply(pk.id, pk.instruction) {
                    if let Ok(entries) = fast_sync_entries(pk.params, len) {
                        for e in entries {
                            if e.error.number == crate::dynamixel::protocol::ErrorNumber::None {
                                take(e.id, e.data);
                            }
                        }
                    }
                } else if let Ok(st) = StatusRef::from_packet(pk) {
                    if st.error.number == crate::dynamixel::protocol::ErrorNumber::None {
                        take(st.id, st.params);
                    }
                }
            }
        }
        self.counters
            .missing_replies
            .fetch_add((MOTORS - count) as u64, Ordering::Relaxed);
        Ok(count)
    }

    /// Builds the canonical state from the last present blocks and publishes it.
    fn publish(&mut self, now: Instant) {
        // Fresh while a complete read (every servo) is younger than `stale_after`: one missed
        // reply is not a link loss (which would re-seed the targets in force as a hold).
        let fresh = self.link.is_some()
            && self
                .measured_at
                .is_some_and(|t| now.saturating_duration_since(t) <= self.cfg.stale_after);
        let table = &self.table;
        let st = &mut self.st;
        if st.joints.len() != MOTORS {
            st.joints.resize(MOTORS, Default::default());
        }
        for i in 0..MOTORS {
            if !self.got[i] {
                continue;
            }
            if let Some((ma, vel, pos)) = parse_present(&self.present[i]) {
                let j = &table.joints[i];
                st.joints[i].q = j.q_from_wire(pos);
                st.joints[i].dq = j.rate_from_wire(vel);
                st.joints[i].tau = j.tau_from_wire(ma / 1000.0 * TORQUE_PER_AMP);
                st.joints[i].temperature = None;
            }
        }
        st.closure = table.closure_of_state(&st.joints);
        st.faults = if self.link.is_none() || !fresh {
            faults::LINK_DOWN
        } else {
            0
        };
        st.freshness = if fresh { Freshness::Fresh } else { Freshness::Stale };
        st.measured_at = self.measured_at;
        self.link_tracker.observe(fresh, &st.joints, &self.cmd);
        if fresh {
            Counters::inc(&self.cmd.counters.state_samples);
        }
        crate::link::stamp(st, &self.cmd, self.cmd.is_safe(), true);
        self.tx.send_modify(|out| out.clone_from(st));
        self.taps.run(st);
    }
}
