//! The RH56 [`HandDevice`]: canonical targets map through the Inspire table (angles 0..1000,
//! 1000 = open, the FTP's mapping) to ANGLE_SET on the hand's line; the line's readings become
//! canonical state. Several hands on one line share one [`Rh56Bus`] (one thread), so each
//! device holds an `Arc` of its line, as the EZGripper does.
//!
//! State: q from ANGLE_ACT; dq and tau not measured (0; FORCE_ACT is in grams, not a torque);
//! temperature from TEMP; ERROR ≠ 0 → `MOTOR_ERROR`, ERROR bit 3 (motor) or STATUS 5/6/7
//! (overcurrent, stall, actuator fault) → `HARDWARE`; `mode` = the highest STATUS code (0..7);
//! contact per finger = STATUS 3 (stopped at FORCE_SET) or FORCE_ACT ≥
//! [`crate::inspire_ftp::adapter::CONTACT_FORCE`]; stale when the hand missed its last reply or
//! its reading is older than the device's `stale_after`.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use tokio::sync::watch;

use super::bus::{HandReading, Rh56Bus};
use super::regs::{self, FINGERS};
use crate::control::{Active, CommandState, Counters};
use crate::device::{DeviceError, DeviceInfo};
use crate::inspire_ftp::adapter::{angle_register, CONTACT_FORCE};
use crate::mapping::DeviceTable;
use crate::model::{faults, Freshness, HandState, SafeAction};

/// Canonical state of one hand from its reading, into `st` (buffers reused). Sets every field
/// but the command echo and the wall-clock time (`link::stamp`'s).
pub fn to_hand_state(table: &DeviceTable, r: &HandReading, stale_after: Duration, now: Instant, st: &mut HandState) {
    table.state_from_wire_into(&mut st.joints, |i| r.angle.get(i).map(|a| (f32::from(*a), 0.0, 0.0)));
    for (j, m) in st.joints.iter_mut().zip(&table.joints) {
        (j.dq, j.tau) = (0.0, 0.0);
        j.temperature = (r.slow_read && r.online).then(|| f32::from(r.temp[m.wire_index]));
    }
    let mut f = 0;
    if r.error.iter().any(|e| *e != 0) {
        f |= faults::MOTOR_ERROR;
    }
    if r.error.iter().any(|e| e & regs::error_bits::MOTOR != 0)
        || r.status.iter().any(|s| {
            matches!(
                *s,
                regs::status::OVERCURRENT | regs::status::STALL | regs::status::ACTUATOR_FAULT
            )
        })
    {
        f |= faults::HARDWARE;
    }
    if !r.online {
        f |= faults::LINK_DOWN;
    }
    st.faults = f;
    st.mode = r.status.iter().copied().filter(|s| *s <= 7).max().unwrap_or(0);
    st.contact.clear();
    st.contact.extend(table.joints.iter().map(|j| {
        r.status.get(j.wire_index) == Some(&regs::status::FORCE_REACHED)
            || r.force.get(j.wire_index).is_some_and(|f| *f >= CONTACT_FORCE)
    }));
    pads(r, st);
    st.closure = table.closure_of_state(&st.joints);
    let fresh = r.online && r.round > 0 && now.saturating_duration_since(r.measured_at) <= stale_after;
    st.freshness = if fresh { Freshness::Fresh } else { Freshness::Stale };
    st.measured_at = (r.round > 0).then_some(r.measured_at);
}

/// A DFTP's tactile cells as the state's 17 named pads (the Inspire FTP kind's names and
/// shapes, raw 0..4095), buffers reused; none when the line reads no cells.
fn pads(r: &HandReading, st: &mut HandState) {
    if r.tactile.len() != regs::TACTILE_CELLS {
        st.pads.clear();
        return;
    }
    st.pads.truncate(regs::TACTILE_REGIONS.len());
    for (k, (name, addr, rows, cols)) in regs::TACTILE_REGIONS.iter().enumerate() {
        if st.pads.len() <= k {
            st.pads.push(crate::model::Pad {
                name: (*name).to_string(),
                rows: *rows,
                cols: *cols,
                pressure: Vec::with_capacity((rows * cols) as usize),
                temperature: Vec::new(),
            });
        }
        let first = (addr - regs::TACTILE) as usize / 2;
        let p = &mut st.pads[k];
        p.pressure.clear();
        p.pressure.extend(
            r.tactile[first..first + (rows * cols) as usize]
                .iter()
                .map(|v| f32::from(*v)),
        );
    }
}

/// One RH56 hand on a (possibly shared) line.
pub struct Rh56Device {
    info: DeviceInfo,
    bus: Arc<Rh56Bus>,
    id: u8,
    cmd: CommandState,
    state_rx: watch::Receiver<HandState>,
    taps: Arc<crate::device::StateTaps>,
    /// The angles measured when a limp safe state began (the hand has no torque-off).
    limp: Mutex<Option<[i16; FINGERS]>>,
    stop: Arc<AtomicBool>,
    bridge: Mutex<Option<JoinHandle<()>>>,
}

impl Rh56Device {
    /// A device for hand `id` on `bus`; `stale_after`: the bound on a reading's age.
    pub fn start(info: DeviceInfo, bus: Arc<Rh56Bus>, id: u8, stale_after: Duration) -> Result<Self, DeviceError> {
        let mut rx = bus.subscribe(id).map_err(DeviceError::link)?;
        let table = info.table.clone();
        let cmd = CommandState::new(table.clone());
        let (tx, state_rx) = watch::channel(HandState::empty(table.joint_count()));
        let stop = Arc::new(AtomicBool::new(false));
        let taps: Arc<crate::device::StateTaps> = Arc::default();
        let (b_cmd, b_stop, b_taps) = (cmd.clone(), stop.clone(), taps.clone());
        let span = tracing::info_span!("device", name = %info.name, kind = %info.kind, backend = info.backend.as_str());
        let bridge = std::thread::Builder::new()
            .name(format!("rh56-{}", info.name))
            .spawn(move || {
                crate::realtime::enter_device_loop(); // [realtime]: this thread only
                let _span = span.enter();
                let Ok(rt) = tokio::runtime::Builder::new_current_thread().enable_time().build() else {
                    return;
                };
                rt.block_on(async move {
                    let mut link = crate::link::LinkTracker::default();
                    let mut clock = crate::control::CycleClock::default();
                    let mut r = rx.borrow().clone();
                    let mut st = HandState::empty(table.joint_count());
                    while !b_stop.load(Ordering::Relaxed) {
                        let changed = tokio::time::timeout(Duration::from_millis(50), rx.changed()).await;
                        let now = Instant::now();
                        clock.tick(&b_cmd.counters, now);
                        if matches!(changed, Ok(Err(_))) {
                            break;
                        }
                        r.clone_from(&rx.borrow_and_update());
                        to_hand_state(&table, &r, stale_after, now, &mut st);
                        let online = st.freshness == Freshness::Fresh;
                        if link.is_up() && !online {
                            tracing::info!(
                                online = r.online,
                                last_error = r.last_error.unwrap_or(""),
                                "RH56 hand state stale"
                            );
                        }
                        if link.observe(online, &st.joints, &b_cmd) {
                            tracing::info!("RH56 hand back: holding the measured position until the next command");
                        }
                        if online && changed.is_ok() {
                            Counters::inc(&b_cmd.counters.state_samples);
                        }
                        crate::link::stamp(&mut st, &b_cmd, b_cmd.is_safe(), true);
                        tx.send_modify(|out| out.clone_from(&st));
                        b_taps.run(&st);
                    }
                });
            })
            .map_err(DeviceError::link)?;
        Ok(Self {
            info,
            bus,
            id,
            cmd,
            state_rx,
            taps,
            limp: Mutex::new(None),
            stop,
            bridge: Mutex::new(Some(bridge)),
        })
    }

    fn apply(&self) -> Result<(), DeviceError> {
        let measured = self.state_rx.borrow().joints.clone();
        let active = self.cmd.step(&measured);
        let mut limp = self.limp.lock().unwrap_or_else(|p| p.into_inner());
        let angles = match &active {
            Active::Idle => return Ok(()),
            // No torque-off: hold the angles measured when the limp began.
            Active::Safe(SafeAction::Limp, _) => match *limp {
                Some(a) => a,
                None => {
                    let st = self.state_rx.borrow();
                    if st.measured_at.is_none() {
                        return Ok(());
                    }
                    let mut a = [0i16; FINGERS];
                    for (j, js) in self.info.table.joints.iter().zip(&st.joints) {
                        a[j.wire_index] = angle_register(j.q_to_wire(js.q));
                    }
                    *limp = Some(a);
                    a
                }
            },
            Active::Command(t) | Active::Safe(_, t) => {
                *limp = None;
                let mut a = [1000i16; FINGERS];
                for (i, w) in self.info.table.wire_targets(t) {
                    a[i] = angle_register(w.q);
                }
                a
            }
        };
        self.bus.set_angles(self.id, angles).map_err(DeviceError::link)?;
        Counters::inc(&self.cmd.counters.sent);
        Ok(())
    }

    /// Stops the bridge (the line stops when its last device is dropped).
    pub fn stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(b) = self.bridge.lock().unwrap_or_else(|p| p.into_inner()).take() {
            let _ = b.join();
        }
    }
}

impl Drop for Rh56Device {
    fn drop(&mut self) {
        self.stop();
    }
}

impl crate::link::BusDevice for Rh56Device {
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

    fn apply(&self) -> Result<(), DeviceError> {
        self.apply()
    }

    fn link_counters(&self) -> (u64, u64) {
        let b = self.bus.stats();
        (b.reconnects, b.bad_checksum)
    }
}
