//! The generic [`HandDevice`] of a register-mapped hand: canonical targets map through the
//! kind's table to wire positions, the kind's codec turns them into the target block the
//! line writes; the line's readings become canonical state through the kind's codec. Several
//! hands on one line share one [`HandLine`] (one thread), so each device holds an `Arc` of it.

use std::marker::PhantomData;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use tokio::sync::watch;

use super::line::{HandLine, Reading};
use super::{RegisterHand, MAX_BLOCK};
use crate::control::{Active, CommandState, Counters};
use crate::device::{DeviceError, DeviceInfo};
use crate::mapping::DeviceTable;
use crate::model::{faults, Freshness, HandState, SafeAction};

/// Canonical state of one hand from its reading, into `st` (buffers reused): the kind's
/// codec, then link, freshness and closure. Sets every field but the command echo and the
/// wall-clock time (`link::stamp`'s).
pub fn to_hand_state<H: RegisterHand>(
    table: &DeviceTable,
    r: &Reading,
    stale_after: Duration,
    now: Instant,
    st: &mut HandState,
) {
    if r.round > 0 {
        H::state(table, r.regs(), st);
    }
    if !r.online {
        st.faults |= faults::LINK_DOWN;
    }
    st.closure = table.closure_of_state(&st.joints);
    let fresh = r.online && r.round > 0 && now.saturating_duration_since(r.measured_at) <= stale_after;
    st.freshness = if fresh { Freshness::Fresh } else { Freshness::Stale };
    st.measured_at = (r.round > 0).then_some(r.measured_at);
}

/// One register-mapped hand on a (possibly shared) line.
pub struct ModbusHandDevice<H: RegisterHand> {
    info: DeviceInfo,
    line: Arc<HandLine>,
    slave: u8,
    cmd: CommandState,
    state_rx: watch::Receiver<HandState>,
    taps: Arc<crate::device::StateTaps>,
    /// The wire positions measured when a limp safe state began (no torque-off on the wire).
    limp: Mutex<Option<Vec<f32>>>,
    stop: Arc<AtomicBool>,
    bridge: Mutex<Option<JoinHandle<()>>>,
    _hand: PhantomData<H>,
}

impl<H: RegisterHand> ModbusHandDevice<H> {
    /// A device for hand `slave` on `line`; `stale_after`: the bound on a reading's age.
    pub fn start(info: DeviceInfo, line: Arc<HandLine>, slave: u8, stale_after: Duration) -> Result<Self, DeviceError> {
        let mut rx = line.subscribe(slave).map_err(DeviceError::link)?;
        let table = info.table.clone();
        let cmd = CommandState::new(table.clone());
        let (tx, state_rx) = watch::channel(HandState::empty(table.joint_count()));
        let stop = Arc::new(AtomicBool::new(false));
        let taps: Arc<crate::device::StateTaps> = Arc::default();
        let (b_cmd, b_stop, b_taps) = (cmd.clone(), stop.clone(), taps.clone());
        let name = H::FACTS.name;
        let span = tracing::info_span!("device", name = %info.name, kind = %info.kind, backend = info.backend.as_str());
        let bridge = std::thread::Builder::new()
            .name(format!("{name}-{}", info.name))
            .spawn(move || {
                crate::realtime::enter_device_loop(); // [realtime]: this thread only
                let _span = span.enter();
                let Ok(rt) = tokio::runtime::Builder::new_current_thread().enable_time().build() else {
                    return;
                };
                rt.block_on(async move {
                    let mut link = crate::link::LinkTracker::default();
                    let mut clock = crate::control::CycleClock::default();
                    let mut st = HandState::empty(table.joint_count());
                    while !b_stop.load(Ordering::Relaxed) {
                        let changed = tokio::time::timeout(Duration::from_millis(50), rx.changed()).await;
                        let now = Instant::now();
                        clock.tick(&b_cmd.counters, now);
                        if matches!(changed, Ok(Err(_))) {
                            break;
                        }
                        let r = *rx.borrow_and_update();
                        to_hand_state::<H>(&table, &r, stale_after, now, &mut st);
                        let online = st.freshness == Freshness::Fresh;
                        if link.is_up() && !online {
                            tracing::info!(
                                online = r.online,
                                last_error = r.last_error.unwrap_or(""),
                                "{name} hand state stale"
                            );
                        }
                        if link.observe(online, &st.joints, &b_cmd) {
                            tracing::info!("{name} hand back: holding the measured position until the next command");
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
            line,
            slave,
            cmd,
            state_rx,
            taps,
            limp: Mutex::new(None),
            stop,
            bridge: Mutex::new(Some(bridge)),
            _hand: PhantomData,
        })
    }

    fn apply(&self) -> Result<(), DeviceError> {
        let table = &self.info.table;
        let measured = self.state_rx.borrow().joints.clone();
        let active = self.cmd.step(&measured);
        let mut limp = self.limp.lock().unwrap_or_else(|p| p.into_inner());
        let n = table.joints.iter().map(|j| j.wire_index + 1).max().unwrap_or(0);
        let wire: Vec<f32> = match &active {
            Active::Idle => return Ok(()),
            // No torque-off on the wire: hold the positions measured when the limp began.
            Active::Safe(SafeAction::Limp, _) => match &*limp {
                Some(w) => w.clone(),
                None => {
                    let st = self.state_rx.borrow();
                    if st.measured_at.is_none() {
                        return Ok(());
                    }
                    let mut w = vec![0.0; n];
                    for (j, js) in table.joints.iter().zip(&st.joints) {
                        w[j.wire_index] = j.q_to_wire(js.q);
                    }
                    *limp = Some(w.clone());
                    w
                }
            },
            Active::Command(t) | Active::Safe(_, t) => {
                *limp = None;
                let mut w = vec![0.0; n];
                for (i, t) in table.wire_targets(t) {
                    w[i] = t.q;
                }
                w
            }
        };
        let mut block = [0u16; MAX_BLOCK];
        let len = H::TARGET.1 as usize;
        H::targets(&wire, &mut block[..len]);
        self.line
            .set_target(self.slave, &block[..len])
            .map_err(DeviceError::link)?;
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

impl<H: RegisterHand> Drop for ModbusHandDevice<H> {
    fn drop(&mut self) {
        self.stop();
    }
}

impl<H: RegisterHand> crate::link::BusDevice for ModbusHandDevice<H> {
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
        let c = &self.line.counters;
        (c.reconnects.load(Ordering::Relaxed), c.bad_crc.load(Ordering::Relaxed))
    }
}
