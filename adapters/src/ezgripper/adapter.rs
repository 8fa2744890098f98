//! The EZGripper [`HandDevice`]: the canonical jaw (measured from open, positive = closing,
//! the Dex1's radians) maps through the EZGripper table to SAKE's percent (0 closed ..
//! `max_open_percent` open) and is set on the gripper's servo; the bus's measurements become
//! canonical state. Several grippers on one port share one [`EzGripperBus`] (one thread, sync
//! read/write serving all of them in one round), so each device holds an `Arc` of its bus.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use async_trait::async_trait;
use tokio::sync::watch;

use super::driver::{Calibration, EzGripperBus, GripperState};
use crate::control::{Active, CommandState, Counters};
use crate::device::{Calibrate, DeviceError, DeviceInfo};
use crate::dynamixel::protocol::ServoId;
use crate::mapping::DeviceTable;
use crate::model::{faults, Freshness, HandState, JointState, SafeAction};

/// SAKE's driver reports `tau_est = effort / 10` (docs/sources.md §5); handgate keeps that scale: the
/// canonical joint torque is `effort_pct / 10` ("N·m-like", positive = squeezing).
pub const EFFORT_PCT_PER_TAU: f32 = 10.0;

/// Canonical state of one gripper, into `st` (its buffers reused: the bridge does this every
/// bus round). Sets every field but the command echo and the wall-clock time
/// (`link::stamp`'s).
pub fn to_hand_state(table: &DeviceTable, g: &GripperState, st: &mut HandState) {
    let j = &table.joints[0];
    st.joints.clear();
    st.joints.push(JointState {
        q: j.q_from_wire(g.position_pct),
        dq: j.rate_from_wire(g.velocity_pct_s),
        tau: g.effort_pct / EFFORT_PCT_PER_TAU,
        temperature: g.online.then_some(g.temperature_c as f32),
    });
    let mut f = 0;
    if !g.hardware_error.is_empty() {
        f |= faults::HARDWARE;
    }
    if !g.online {
        f |= faults::LINK_DOWN;
    }
    // A gripper whose calibration failed has no zero: it ignores targets and reads closed,
    // which a client must be able to tell from a gripper that closed on purpose.
    if matches!(g.calibration, Calibration::Failed { .. }) {
        f |= faults::HARDWARE;
    }
    let fresh = g.online && !g.stale && g.round > 0;
    st.closure = table.closure_of_state(&st.joints);
    st.faults = f;
    st.freshness = if fresh { Freshness::Fresh } else { Freshness::Stale };
    st.measured_at = (g.round > 0).then_some(g.measured_at);
    st.mode = g.grasp.code();
}

/// One EZGripper on a (possibly shared) bus.
pub struct EzGripperDevice {
    info: DeviceInfo,
    bus: Arc<EzGripperBus>,
    id: ServoId,
    /// Force limit %, applied with every position target.
    force_pct: f32,
    cmd: CommandState,
    state_rx: watch::Receiver<HandState>,
    /// Told of each state on the bridge thread.
    taps: Arc<crate::device::StateTaps>,
    stop: Arc<AtomicBool>,
    bridge: Mutex<Option<JoinHandle<()>>>,
}

impl EzGripperDevice {
    /// A device for servo `id` on `bus`; `force_pct` is the grip force limit (% of the
    /// servo's current limit).
    pub fn start(info: DeviceInfo, bus: Arc<EzGripperBus>, id: ServoId, force_pct: f32) -> Result<Self, DeviceError> {
        let mut rx = bus.subscribe(id).map_err(DeviceError::link)?;
        let table = info.table.clone();
        let cmd = CommandState::new(table.clone());
        let (tx, state_rx) = watch::channel(HandState::empty(table.joint_count()));
        let stop = Arc::new(AtomicBool::new(false));
        let taps: Arc<crate::device::StateTaps> = Arc::default();
        let (b_cmd, b_stop, b_taps) = (cmd.clone(), stop.clone(), taps.clone());
        let span = tracing::info_span!("device", name = %info.name, kind = %info.kind, backend = info.backend.as_str());
        let bridge = std::thread::Builder::new()
            .name(format!("ezgripper-{}", info.name))
            .spawn(move || {
                crate::realtime::enter_device_loop(); // [realtime]: this thread only
                let _span = span.enter();
                let Ok(rt) = tokio::runtime::Builder::new_current_thread().enable_time().build() else {
                    return;
                };
                rt.block_on(async move {
                    let mut link = crate::link::LinkTracker::default();
                    let mut cal_failure_logged = false;
                    let mut clock = crate::control::CycleClock::default();
                    // The gripper's state and the one built from it every round, their
                    // buffers reused.
                    let mut g = rx.borrow().clone();
                    let mut st = HandState::empty(table.joint_count());
                    while !b_stop.load(Ordering::Relaxed) {
                        let changed = tokio::time::timeout(Duration::from_millis(50), rx.changed()).await;
                        // One bus cycle (or the bridge's 50 ms wait for one).
                        clock.tick(&b_cmd.counters, std::time::Instant::now());
                        if matches!(changed, Ok(Err(_))) {
                            break;
                        }
                        g.clone_from(&rx.borrow_and_update());
                        match (&g.calibration, cal_failure_logged) {
                            (Calibration::Failed { reason }, false) => {
                                tracing::error!(%reason, "calibration failed: targets are not applied until a calibration succeeds (restart with calibrate_on_start, or set ezgripper.zero_ticks in the profile)");
                                cal_failure_logged = true;
                            }
                            (Calibration::Calibrated { .. }, true) => cal_failure_logged = false,
                            _ => {}
                        }
                        to_hand_state(&table, &g, &mut st);
                        let online = st.freshness == Freshness::Fresh;
                        if link.is_up() && !online {
                            tracing::info!(
                                online = g.online,
                                measured_ms_ago = g.measured_at.elapsed().as_millis() as u64,
                                last_error = g.last_error.as_deref().unwrap_or(""),
                                "gripper state stale"
                            );
                        }
                        if link.observe(online, &st.joints, &b_cmd) {
                            // Back after an unplug or a silent servo: never replay.
                            tracing::info!("gripper back: holding the measured position until the next command");
                        }
                        if online {
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
            force_pct,
            cmd,
            state_rx,
            taps,
            stop,
            bridge: Mutex::new(Some(bridge)),
        })
    }

    fn apply(&self) -> Result<(), DeviceError> {
        let measured = self.state_rx.borrow().joints.clone();
        let active = self.cmd.step(&measured);
        let (targets, force) = match &active {
            Active::Idle => return Ok(()),
            Active::Safe(SafeAction::Limp, t) => (t, 0.0),
            Active::Command(t) | Active::Safe(_, t) => (t, self.force_pct),
        };
        let pct = self.info.table.to_wire(targets)[0].q;
        let g = self.bus.gripper(self.id).map_err(DeviceError::link)?;
        g.set_target(pct, force).map_err(DeviceError::link)?;
        Counters::inc(&self.cmd.counters.sent);
        Ok(())
    }

    /// Stops the bridge (the bus stops when its last device is dropped).
    pub fn stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(b) = self.bridge.lock().unwrap_or_else(|p| p.into_inner()).take() {
            let _ = b.join();
        }
    }
}

impl Drop for EzGripperDevice {
    fn drop(&mut self) {
        self.stop();
    }
}

impl crate::link::BusDevice for EzGripperDevice {
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
        (b.reconnects, b.crc_errors)
    }

    fn calibration(&self) -> Option<&dyn Calibrate> {
        Some(self)
    }
}

/// How long a calibration may take before `calibrate` gives up waiting (the driver's own
/// timeout, `calibration_timeout_ms`, is 6.6 s by default).
pub const CALIBRATION_WAIT: Duration = Duration::from_secs(15);

#[async_trait]
impl Calibrate for EzGripperDevice {
    /// Closes the gripper to its stop to find the zero (it moves), waits for the result and
    /// returns the zero as the profile's `zero_ticks`.
    async fn calibrate(&self) -> Result<String, DeviceError> {
        let mut rx = self.bus.subscribe(self.id).map_err(DeviceError::link)?;
        rx.mark_unchanged();
        self.bus.calibrate(self.id).map_err(DeviceError::link)?;
        let wait = async {
            let mut started = false;
            loop {
                match rx.borrow_and_update().calibration.clone() {
                    super::driver::Calibration::Running => started = true,
                    super::driver::Calibration::Calibrated { zero_ticks } if started => {
                        return Ok(format!("zero_ticks = {zero_ticks}"))
                    }
                    super::driver::Calibration::Failed { reason } if started => {
                        return Err(DeviceError::Config(format!("calibration failed: {reason}")))
                    }
                    _ => {}
                }
                if rx.changed().await.is_err() {
                    return Err(DeviceError::Stopped);
                }
            }
        };
        tokio::time::timeout(CALIBRATION_WAIT, wait)
            .await
            .map_err(|_| DeviceError::NotConfirmed(CALIBRATION_WAIT))?
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Side;

    fn measured(calibration: Calibration) -> GripperState {
        GripperState {
            online: true,
            stale: false,
            round: 1,
            calibration,
            ..GripperState::initial(ServoId::new(1).unwrap())
        }
    }

    #[test]
    fn a_failed_calibration_is_a_hardware_fault_not_a_closed_gripper() {
        let t = super::super::table::table(Side::Left, 5.4, 100.0);
        let mut failed = HandState::default();
        to_hand_state(
            &t,
            &measured(Calibration::Failed {
                reason: "jaw did not come to rest".into(),
            }),
            &mut failed,
        );
        assert_ne!(failed.faults & faults::HARDWARE, 0, "{failed:?}");
        let mut ok = HandState::default();
        to_hand_state(&t, &measured(Calibration::Calibrated { zero_ticks: 100 }), &mut ok);
        assert_eq!(ok.faults & faults::HARDWARE, 0, "{ok:?}");
    }
}
