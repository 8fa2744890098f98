//! Command state shared by every adapter's device loop: latest-wins slot, resolution through
//! the table against measured state, safe states, and re-seeding after the link comes back
//! (a stale setpoint is never replayed).

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use crate::device::DeviceStats;
use crate::mapping::{CheckedBody, DeviceTable, MappingError};
use crate::model::{CommandBody, Freshness, HandCommand, HandState, JointCommand, JointState, SafeAction};

/// What the loop should send this cycle.
#[derive(Debug, PartialEq)]
pub enum Active {
    /// Nothing commanded yet: send nothing (or the device's idle frame).
    Idle,
    /// Targets from a client command.
    Command(Vec<JointCommand>),
    /// Targets of a safe state.
    Safe(SafeAction, Vec<JointCommand>),
}

/// `clone_from` reuses the targets' buffer (a device loop copies the targets every cycle).
impl Clone for Active {
    fn clone(&self) -> Self {
        let mut a = Active::Idle;
        a.clone_from(self);
        a
    }

    fn clone_from(&mut self, src: &Self) {
        let mut buf = match std::mem::replace(self, Active::Idle) {
            Active::Command(t) | Active::Safe(_, t) => t,
            Active::Idle => Vec::new(),
        };
        *self = match src {
            Active::Idle => Active::Idle,
            Active::Command(t) => {
                buf.clone_from(t);
                Active::Command(buf)
            }
            Active::Safe(a, t) => {
                buf.clone_from(t);
                Active::Safe(*a, buf)
            }
        };
    }
}

#[derive(Debug)]
struct Inner {
    pending: Option<HandCommand>,
    pending_safe: Option<SafeAction>,
    active: Active,
    /// Where a command is resolved before it replaces the targets of `active` (whose buffer
    /// it then takes over): resolving allocates nothing once both buffers have grown.
    resolved: Vec<JointCommand>,
    last_seq: u64,
    last_tag: u32,
    /// Whether the device follows the targets in force ([`CommandState::observe_motion`]).
    motion: crate::motion::MotionDetector,
    /// The positions of the targets in force, for the motion detector (buffer reused).
    motion_targets: Vec<f32>,
}

/// The most joints the motion detector judges (every kind has fewer).
const MOTION_MAX_JOINTS: usize = 64;

/// Latest-command slot plus the targets currently in force.
#[derive(Debug, Clone)]
pub struct CommandState {
    table: Arc<DeviceTable>,
    inner: Arc<Mutex<Inner>>,
    pub counters: Arc<Counters>,
    /// Whether the device loop has measured the device at least once
    /// ([`Self::mark_measured`], set by `link::LinkTracker`).
    measured: Arc<AtomicBool>,
}

/// Lock-free counters (read by status without touching the device loop).
#[derive(Debug, Default)]
pub struct Counters {
    pub commands: AtomicU64,
    pub rejected: AtomicU64,
    pub sent: AtomicU64,
    pub state_samples: AtomicU64,
    pub crc_errors: AtomicU64,
    pub reconnects: AtomicU64,
    pub missed_cycles: AtomicU64,
    pub reseeds: AtomicU64,
    pub link_up: AtomicU64,
    /// Device-loop iterations (a loop that stops counting is hung: the systemd watchdog).
    pub cycles: AtomicU64,
    /// The device loop's cycle-to-cycle periods.
    pub periods: LoopPeriods,
    /// Times the published state went from fresh to stale ([`crate::link::stamp`] counts them).
    pub stale_events: AtomicU64,
    /// Whether the last published state was fresh.
    pub(crate) published_fresh: AtomicBool,
}

/// Upper bounds, seconds, of the loop-period histogram's buckets (Prometheus `le`; a last
/// `+Inf` bucket is implied): 5–10 µs wide around the 1 kHz loops' 1 ms, 10 µs around the
/// 500 Hz loops' 2 ms, coarse beyond (the benchmark's p99 comes from these).
pub const PERIOD_BOUNDS_S: [f64; 22] = [
    0.0002, 0.0005, 0.0009, 0.00095, 0.00098, 0.00099, 0.000995, 0.001005, 0.00101, 0.00102, 0.00105, 0.0011, 0.0015,
    0.0019, 0.00199, 0.00201, 0.0021, 0.0025, 0.005, 0.01, 0.05, 0.25,
];

/// Buckets of [`PERIOD_BOUNDS_S`] plus `+Inf`.
pub const PERIOD_BUCKETS: usize = PERIOD_BOUNDS_S.len() + 1;

/// A lock-free histogram of a device loop's periods (observed on the loop thread, read by
/// `/metrics` without touching the loop).
#[derive(Debug, Default)]
pub struct LoopPeriods {
    counts: [AtomicU64; PERIOD_BUCKETS],
    sum_ns: AtomicU64,
}

/// A snapshot of [`LoopPeriods`]: per-bucket counts (not cumulative; the last is `+Inf`)
/// and the sum of the periods.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PeriodBuckets {
    pub counts: [u64; PERIOD_BUCKETS],
    pub sum_ns: u64,
}

impl PeriodBuckets {
    pub fn count(&self) -> u64 {
        self.counts.iter().sum()
    }
}

impl LoopPeriods {
    pub fn observe(&self, d: std::time::Duration) {
        let s = d.as_secs_f64();
        let i = PERIOD_BOUNDS_S
            .iter()
            .position(|b| s <= *b)
            .unwrap_or(PERIOD_BOUNDS_S.len());
        self.counts[i].fetch_add(1, Ordering::Relaxed);
        self.sum_ns
            .fetch_add(d.as_nanos().min(u64::MAX as u128) as u64, Ordering::Relaxed);
    }

    pub fn snapshot(&self) -> PeriodBuckets {
        PeriodBuckets {
            counts: std::array::from_fn(|i| self.counts[i].load(Ordering::Relaxed)),
            sum_ns: self.sum_ns.load(Ordering::Relaxed),
        }
    }
}

/// Counts one device-loop iteration at `now` (and the period since the previous one).
#[derive(Debug, Default)]
pub struct CycleClock {
    last: Option<std::time::Instant>,
}

impl CycleClock {
    pub fn tick(&mut self, counters: &Counters, now: std::time::Instant) {
        Counters::inc(&counters.cycles);
        if let Some(l) = self.last.replace(now) {
            counters.periods.observe(now.saturating_duration_since(l));
        }
    }
}

impl Counters {
    pub fn inc(c: &AtomicU64) {
        c.fetch_add(1, Ordering::Relaxed);
    }
    pub fn snapshot(&self) -> DeviceStats {
        let g = |c: &AtomicU64| c.load(Ordering::Relaxed);
        DeviceStats {
            commands: g(&self.commands),
            rejected: g(&self.rejected),
            sent: g(&self.sent),
            state_samples: g(&self.state_samples),
            crc_errors: g(&self.crc_errors),
            reconnects: g(&self.reconnects),
            missed_cycles: g(&self.missed_cycles),
            reseeds: g(&self.reseeds),
            link_up: g(&self.link_up) != 0,
            cycles: g(&self.cycles),
            periods: self.periods.snapshot(),
            stale_events: g(&self.stale_events),
        }
    }
}

impl CommandState {
    pub fn new(table: Arc<DeviceTable>) -> Self {
        let thresholds = table.motion;
        Self {
            table,
            inner: Arc::new(Mutex::new(Inner {
                pending: None,
                pending_safe: None,
                active: Active::Idle,
                resolved: Vec::new(),
                last_seq: 0,
                last_tag: 0,
                motion: crate::motion::MotionDetector::new(thresholds),
                motion_targets: Vec::new(),
            })),
            counters: Arc::new(Counters::default()),
            measured: Arc::new(AtomicBool::new(false)),
        }
    }

    /// The device was measured (its state carries real positions from now on).
    pub fn mark_measured(&self) {
        self.measured.store(true, Ordering::Relaxed);
    }

    pub fn table(&self) -> &Arc<DeviceTable> {
        &self.table
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Accepts a client command (latest wins). It is checked now against the table
    /// ([`DeviceTable::check`]) so a bad command is refused immediately and nothing changes;
    /// it is resolved once, against the measured state, in [`Self::step`].
    pub fn submit(&self, cmd: HandCommand) -> Result<(), MappingError> {
        match self.table.checked(cmd.body) {
            Ok(body) => {
                self.submit_checked(cmd.seq, body, cmd.tag);
                Ok(())
            }
            Err(e) => {
                Counters::inc(&self.counters.rejected);
                Err(e)
            }
        }
    }

    /// Accepts a command already checked against this slot's table (latest wins), without
    /// checking it again. Joint targets replacing a pending command that set joint targets too
    /// keep the pending command's targets of the joints they leave out (latest wins per
    /// joint): two commands naming different joints of one device (a JointState client's
    /// subsets) within one device cycle move both sets of joints, as they would one cycle apart.
    pub fn submit_checked(&self, seq: u64, body: CheckedBody, tag: u32) {
        Counters::inc(&self.counters.commands);
        let mut g = self.lock();
        let body = match (g.pending.take(), body.into_body()) {
            (
                Some(HandCommand {
                    body: CommandBody::Joints(mut earlier),
                    ..
                }),
                CommandBody::Joints(now),
            ) => {
                earlier.retain(|(id, _)| !now.iter().any(|(n, _)| n == id));
                earlier.extend(now);
                CommandBody::Joints(earlier)
            }
            (_, body) => body,
        };
        if let CommandBody::Safe(a) = body {
            g.pending_safe = Some(a);
            g.pending = None;
        } else {
            g.pending = Some(HandCommand { seq, body, tag });
            g.pending_safe = None;
        }
    }

    /// Requests a safe state (watchdog, shutdown). Resolved once, against the measured state,
    /// in [`Self::step`]; a request for the safe state already in force changes nothing (a
    /// hold keeps the position it took when it began).
    pub fn request_safe(&self, action: SafeAction) {
        let mut g = self.lock();
        g.pending = None;
        g.pending_safe = Some(action);
    }

    /// Called when the link to the device comes back: whatever was in force is replaced by a
    /// hold at the first measured state; the client must command again to move.
    pub fn reseed(&self, measured: &[JointState]) {
        let mut g = self.lock();
        g.pending = None;
        if matches!(g.active, Active::Idle) {
            // Nothing was commanded: nothing to replay, nothing to hold.
            return;
        }
        Counters::inc(&self.counters.reseeds);
        g.active = Active::Safe(SafeAction::Hold, self.table.hold_measured(measured));
    }

    /// The device was measured for the first time: a hold requested before (resolved against
    /// no measurement, and kept silent by the device loop, `link::blind_hold`) takes its
    /// position now, once.
    pub fn first_measurement(&self, measured: &[JointState]) {
        let mut g = self.lock();
        if matches!(g.active, Active::Safe(SafeAction::Hold, _)) {
            g.active = Active::Safe(SafeAction::Hold, self.table.hold_measured(measured));
        }
    }

    /// One device-loop step: folds in the pending command or safe request, resolved against
    /// `measured`, and returns the targets in force.
    ///
    /// A hold takes the measured position once, when it begins, and keeps it until a client
    /// commands again: a request for the safe state already in force (a watchdog and a
    /// client's `hold` both, a client streaming `hold`) keeps the targets in force. Re-taken
    /// from the measurement, a hold would integrate whatever the measurement sags under a
    /// load, every cycle (docs/adapters.md, "Holds").
    pub fn step(&self, measured: &[JointState]) -> Active {
        let mut active = Active::Idle;
        self.step_into(measured, &mut active);
        active
    }

    /// [`Self::step`] into `active`, its buffer reused: a loop that keeps its `Active`
    /// steps without allocating (a safe request still builds its targets).
    pub fn step_into(&self, measured: &[JointState], active: &mut Active) {
        let mut guard = self.lock();
        let g = &mut *guard;
        if let Some(a) = g.pending_safe.take() {
            if !matches!(g.active, Active::Safe(now, _) if now == a) {
                g.active = Active::Safe(a, self.table.safe_targets(a, measured));
            }
        }
        if let Some(cmd) = g.pending.take() {
            let prev = match &g.active {
                Active::Command(t) | Active::Safe(_, t) => Some(t.as_slice()),
                Active::Idle => None,
            };
            if prev.is_none() && !self.measured.load(Ordering::Relaxed) && self.table.is_partial(&cmd.body) {
                // The joints this command leaves out would be held where they were measured,
                // and nothing was measured yet: it waits for the first measurement (never
                // hold a position that was never measured).
                g.pending = Some(cmd);
                active.clone_from(&g.active);
                return;
            }
            match self.table.resolve_into(&cmd.body, prev, measured, &mut g.resolved) {
                Ok(()) => {
                    let old = std::mem::replace(&mut g.active, Active::Command(std::mem::take(&mut g.resolved)));
                    if let Active::Command(t) | Active::Safe(_, t) = old {
                        g.resolved = t;
                    }
                    g.last_seq = cmd.seq;
                    g.last_tag = cmd.tag;
                }
                Err(_) => Counters::inc(&self.counters.rejected),
            }
        }
        active.clone_from(&g.active);
    }

    /// seq and tag of the last applied client command.
    pub fn applied(&self) -> (u64, u32) {
        let g = self.lock();
        (g.last_seq, g.last_tag)
    }

    /// The joint positions in force (canonical), `None` while nothing was commanded.
    pub fn targets(&self) -> Option<Vec<f32>> {
        match &self.lock().active {
            Active::Idle => None,
            Active::Command(t) | Active::Safe(_, t) => Some(t.iter().map(|c| c.q).collect()),
        }
    }

    /// Judges whether the device follows the targets in force, from the state about to be
    /// published, and writes the report into it (`st.motion`). Only a fresh measurement is
    /// judged (a stale or commanded-only state resets the detector); a limp device or one
    /// never commanded has no target to follow. A state republished without a new sample
    /// (same `measured_at`) is not a new observation.
    pub fn observe_motion(&self, st: &mut HandState) {
        let mut guard = self.lock();
        let g = &mut *guard;
        let at = match (st.freshness, st.measured_at) {
            (Freshness::Fresh, Some(at)) => at,
            _ => {
                g.motion.reset();
                st.motion.clone_from(g.motion.report());
                return;
            }
        };
        let targets = match &g.active {
            Active::Command(t) | Active::Safe(SafeAction::Hold | SafeAction::Open, t) => {
                g.motion_targets.clear();
                g.motion_targets.extend(t.iter().map(|c| c.q));
                Some(g.motion_targets.as_slice())
            }
            Active::Idle | Active::Safe(SafeAction::Limp, _) => None,
        };
        // Measured positions without a buffer of their own: at most a few dozen joints.
        let mut q = [0.0f32; MOTION_MAX_JOINTS];
        let n = st.joints.len().min(MOTION_MAX_JOINTS);
        for (d, j) in q.iter_mut().zip(&st.joints) {
            *d = j.q;
        }
        let th = g.motion.thresholds();
        let (joints, reported) = (&st.joints, &st.contact);
        let contact = |j: usize| {
            let effort = joints.get(j).map_or(0.0, |s| s.tau);
            th.in_contact(
                if effort.is_finite() { effort } else { 0.0 },
                reported.get(j).copied().unwrap_or(false),
            )
        };
        let report = g.motion.observe_with_contact(at, targets, &q[..n], contact);
        st.motion.clone_from(report);
    }

    /// Whether a safe state is in force.
    pub fn is_safe(&self) -> bool {
        matches!(self.lock().active, Active::Safe(..))
    }
}

/// A hold of positions that no command of this device sets (the other hand of a shared
/// message, a `limp` a kind can only send as a hold): the newest measurement, taken once when
/// the hold begins ([`Self::hold`]) and kept until it ends ([`Self::release`]). Re-taking it
/// every cycle would integrate whatever the measurement sags under a load (docs/adapters.md,
/// "Holds").
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MeasuredHold<T: Copy> {
    measured: Option<T>,
    held: Option<T>,
}

impl<T: Copy> MeasuredHold<T> {
    /// A new measurement (a hold in force keeps its position).
    pub fn measure(&mut self, m: T) {
        self.measured = Some(m);
    }

    /// The newest measurement, if any.
    pub fn measured(&self) -> Option<T> {
        self.measured
    }

    /// The position to hold: the one taken when the hold began, or, when it begins now, the
    /// newest measurement. `None` while nothing was measured: nothing to hold.
    pub fn hold(&mut self) -> Option<T> {
        if self.held.is_none() {
            self.held = self.measured;
        }
        self.held
    }

    /// The hold ends (the positions got targets of their own, the messages stopped, the link
    /// came back): the next [`Self::hold`] takes the newest measurement.
    pub fn release(&mut self) {
        self.held = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_measured_hold_takes_the_measurement_once_until_released() {
        let mut h = MeasuredHold::default();
        assert_eq!(h.hold(), None, "nothing measured: nothing to hold");
        h.measure(1.0);
        assert_eq!(h.hold(), Some(1.0));
        h.measure(0.9);
        h.measure(0.8);
        assert_eq!(h.hold(), Some(1.0), "kept while the measurement moves");
        assert_eq!(h.measured(), Some(0.8));
        h.release();
        assert_eq!(h.hold(), Some(0.8), "a new hold: the newest measurement");
    }

    /// Two partial joint commands that reach the slot within one device cycle both take
    /// effect (latest wins per joint), and the joints neither names keep their targets; a
    /// closure or a full command in between replaces what was pending, as before.
    #[test]
    fn partial_commands_within_one_cycle_each_keep_their_joints() {
        let table = Arc::new(DeviceKind::Dex3.table(Side::Left, &Default::default()).unwrap());
        let cmd = CommandState::new(table.clone());
        cmd.mark_measured();
        let measured = vec![JointState::default(); 7];
        let joint = |i: u8, q: f32| (JointId(i), JointCommand::hold(q, 1.0, 0.1));
        let q = |a: Active| match a {
            Active::Command(t) => t.iter().map(|c| c.q).collect::<Vec<f32>>(),
            a => panic!("{a:?}"),
        };
        cmd.submit(HandCommand::joints(1, (0..7).map(|i| joint(i, 0.0)).collect()))
            .unwrap();
        assert_eq!(q(cmd.step(&measured)), [0.0; 7]);
        let lim = |i: usize, v: f32| table.joints[i].limits.clamp(v);
        cmd.submit(HandCommand::joints(2, vec![joint(3, 0.4), joint(4, 0.4)]))
            .unwrap();
        cmd.submit(HandCommand::joints(3, vec![joint(4, 0.6), joint(5, 0.5)]))
            .unwrap();
        let got = q(cmd.step(&measured));
        assert_eq!(got[3], lim(3, 0.4), "{got:?}");
        assert_eq!(got[4], lim(4, 0.6), "latest wins: {got:?}");
        assert_eq!(got[5], lim(5, 0.5), "{got:?}");
        assert_eq!(
            [got[0], got[1], got[2], got[6]],
            [lim(0, 0.0), lim(1, 0.0), lim(2, 0.0), lim(6, 0.0)]
        );
        assert_eq!(cmd.applied().0, 3);
        // A closure pending replaces earlier joints, and joints after it replace the closure.
        cmd.submit(HandCommand::joints(4, vec![joint(3, 0.1)])).unwrap();
        cmd.submit(HandCommand::closure(5, 0.0)).unwrap();
        let open = table.closure_targets(0.0, None).unwrap();
        assert_eq!(q(cmd.step(&measured)), open.iter().map(|c| c.q).collect::<Vec<_>>());
    }

    /// On every device kind's table, joints a partial command leaves out keep the targets an
    /// earlier command gave them (every device kind's loop resolves commands through this slot).
    #[test]
    fn every_kind_keeps_the_targets_a_partial_command_leaves_out() {
        for kind in crate::kinds::KINDS {
            let table = Arc::new(kind.table(Side::Left, &Default::default()).unwrap());
            let n = table.joints.len();
            if n < 2 {
                continue; // one joint: every command names it
            }
            let cmd = CommandState::new(table.clone());
            cmd.mark_measured();
            let measured = vec![JointState::default(); n];
            // A point inside each joint's limits, different per joint.
            let at = |i: usize, f: f32| {
                let l = table.joints[i].limits;
                (JointId(i as u8), JointCommand::hold(l.min + l.span() * f, 1.0, 0.1))
            };
            cmd.submit(HandCommand::joints(1, (0..n).map(|i| at(i, 0.25)).collect()))
                .unwrap();
            let first = match cmd.step(&measured) {
                Active::Command(t) => t,
                a => panic!("{kind}: {a:?}"),
            };
            cmd.submit(HandCommand::joints(2, vec![at(1, 0.75)])).unwrap();
            let second = match cmd.step(&measured) {
                Active::Command(t) => t,
                a => panic!("{kind}: {a:?}"),
            };
            for i in 0..n {
                let want = if i == 1 { at(1, 0.75).1.q } else { first[i].q };
                assert!((second[i].q - want).abs() < 1e-5, "{kind} joint {i}: {second:?}");
            }
        }
    }

    /// Every hold is resolved once, when it begins: a repeated hold request, a client
    /// streaming `hold`, a hold after a reseed keep the position taken first, whatever the
    /// measurement does meanwhile (a joint that sags under a load); a client command ends it,
    /// and the next hold takes the measurement again.
    #[test]
    fn a_hold_takes_the_measured_position_once_and_keeps_it() {
        let table = Arc::new(DeviceKind::Dex3.table(Side::Left, &Default::default()).unwrap());
        let cmd = CommandState::new(table);
        cmd.mark_measured();
        let at = |q: f32| {
            vec![
                JointState {
                    q,
                    ..Default::default()
                };
                7
            ]
        };
        let held = |a: Active| match a {
            Active::Safe(SafeAction::Hold, t) => t[3].q,
            a => panic!("{a:?}"),
        };
        cmd.submit(HandCommand::closure(1, 0.5)).unwrap();
        assert!(matches!(cmd.step(&at(0.3)), Active::Command(_)));
        cmd.request_safe(SafeAction::Hold);
        assert_eq!(held(cmd.step(&at(0.30))), 0.30, "the hold begins: measured once");
        for (i, q) in [0.31, 0.32, 0.33].into_iter().enumerate() {
            cmd.request_safe(SafeAction::Hold);
            assert_eq!(held(cmd.step(&at(q))), 0.30, "a repeated request");
            cmd.submit(HandCommand {
                seq: 2 + i as u64,
                body: CommandBody::Safe(SafeAction::Hold),
                tag: 0,
            })
            .unwrap();
            assert_eq!(held(cmd.step(&at(q))), 0.30, "a client's hold");
            assert_eq!(held(cmd.step(&at(q + 0.005))), 0.30, "a cycle");
        }
        cmd.reseed(&at(0.4));
        assert_eq!(held(cmd.step(&at(0.4))), 0.4, "a reconnect: a new hold");
        cmd.request_safe(SafeAction::Hold);
        assert_eq!(held(cmd.step(&at(0.45))), 0.4, "the reseed's hold is kept");
        cmd.request_safe(SafeAction::Limp);
        assert!(matches!(cmd.step(&at(0.45)), Active::Safe(SafeAction::Limp, _)));
        cmd.request_safe(SafeAction::Hold);
        assert_eq!(held(cmd.step(&at(0.5))), 0.5, "limp, then a new hold");
        cmd.submit(HandCommand::closure(9, 0.5)).unwrap();
        assert!(matches!(cmd.step(&at(0.5)), Active::Command(_)));
        cmd.request_safe(SafeAction::Hold);
        assert_eq!(held(cmd.step(&at(0.6))), 0.6, "a command, then a new hold");
    }

    /// A hold requested before the first measurement (the loop keeps it silent) takes the
    /// first measured position, once.
    #[test]
    fn a_hold_requested_blind_takes_the_first_measurement() {
        let table = Arc::new(DeviceKind::Dex3.table(Side::Left, &Default::default()).unwrap());
        let cmd = CommandState::new(table);
        let at = |q: f32| {
            vec![
                JointState {
                    q,
                    ..Default::default()
                };
                7
            ]
        };
        cmd.submit(HandCommand::closure(1, 0.5)).unwrap();
        cmd.step(&[]);
        cmd.request_safe(SafeAction::Hold);
        cmd.step(&[]);
        cmd.first_measurement(&at(0.7));
        match cmd.step(&at(0.75)) {
            Active::Safe(SafeAction::Hold, t) => assert!((t[3].q - 0.7).abs() < 1e-6, "{t:?}"),
            a => panic!("{a:?}"),
        }
        // A command in force is not a hold: the first measurement leaves it.
        let cmd = CommandState::new(cmd.table().clone());
        cmd.submit(HandCommand::closure(1, 0.5)).unwrap();
        let before = cmd.step(&[]);
        cmd.first_measurement(&at(0.7));
        assert_eq!(cmd.step(&at(0.7)), before);
    }

    #[test]
    fn loop_periods_land_in_the_first_bucket_that_holds_them() {
        let p = LoopPeriods::default();
        let us = std::time::Duration::from_micros;
        for d in [us(1000), us(1000), us(1004), us(1007), us(2000), us(900_000)] {
            p.observe(d);
        }
        let s = p.snapshot();
        let at = |b: f64| PERIOD_BOUNDS_S.iter().position(|x| *x == b).unwrap();
        assert_eq!(s.counts[at(0.001005)], 3, "1000, 1000 and 1004 us: {s:?}");
        assert_eq!(s.counts[at(0.00101)], 1, "1007 us");
        assert_eq!(s.counts[at(0.00201)], 1, "2 ms");
        assert_eq!(s.counts[PERIOD_BOUNDS_S.len()], 1, "beyond the last bound: +Inf");
        assert_eq!(s.count(), 6);
        assert_eq!(
            s.sum_ns,
            1_000_000 * 2 + 1_004_000 + 1_007_000 + 2_000_000 + 900_000_000
        );
    }
    use crate::model::{DeviceKind, JointId, Side};

    /// A command naming only some joints, before anything was measured, waits for the first
    /// measurement: the joints it leaves out are held where they are measured, never at the
    /// zeros of a state that was never measured.
    #[test]
    fn a_partial_command_waits_for_the_first_measurement() {
        let table = Arc::new(DeviceKind::Dex3.table(Side::Left, &Default::default()).unwrap());
        let cmd = CommandState::new(table.clone());
        let one = |q: f32| JointCommand {
            q,
            kp: 1.0,
            kd: 0.1,
            ..Default::default()
        };
        cmd.submit(HandCommand {
            seq: 1,
            body: CommandBody::Joints(vec![(JointId(5), one(0.5))]),
            tag: 0,
        })
        .unwrap();
        let never = vec![JointState::default(); 7];
        assert_eq!(cmd.step(&never), Active::Idle, "nothing measured: nothing sent");
        cmd.mark_measured();
        let mut measured = vec![JointState::default(); 7];
        measured[3].q = 0.7; // middle_0 where it was measured (canonical: closing)
        match cmd.step(&measured) {
            Active::Command(t) => {
                assert_eq!(t[5].q, 0.5, "the named joint: {t:?}");
                assert!((t[3].q - 0.7).abs() < 1e-6, "the others held where measured: {t:?}");
            }
            a => panic!("{a:?}"),
        }
        // A whole-hand command (closure) needs no measurement.
        let cmd = CommandState::new(table);
        cmd.submit(HandCommand {
            seq: 1,
            body: CommandBody::Closure {
                closure: 0.5,
                stiffness: None,
            },
            tag: 0,
        })
        .unwrap();
        assert!(matches!(cmd.step(&never), Active::Command(_)));
    }
}
