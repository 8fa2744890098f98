//! "Reports but does not move": the tracking error between the targets in force and the
//! measured positions, and a detector for a device whose state keeps arriving while it does
//! not follow its command (docs/adapters.md, "Motion").
//!
//! A plain state machine: [`MotionDetector::observe_with_contact`] takes one measured sample
//! with its time, the targets in force and each joint's contact, and returns the
//! [`MotionReport`]. Every device loop feeds
//! it through `link::stamp` (the one place each loop passes every state it publishes, with
//! the command state holding the targets), so the verdict is the same whatever the kind.
//!
//! Units: canonical radians (positive = closing), errors as `target - measured`.
//!
//! A joint is *demanded* while its error is above the tolerance. A demanded joint that has
//! not moved towards its target by half the tolerance for [`MotionThresholds::hold`] does
//! not follow. Then:
//!
//! - [`Verdict::Frozen`]: every joint's measurement has stayed the same (within
//!   [`FREEZE_EPS`]) for the hold time: the samples repeat one state;
//! - [`Verdict::JointStuck`]: another joint moved towards its target (or reached it) since
//!   the stuck joint's demand began: the hand moves, that joint does not;
//! - [`Verdict::NotFollowing`]: no joint moved: the state varies (noise) but the hand ignores
//!   the command.
//!
//! A joint that stops short of a **closing** target while its effort shows contact is not a
//! fault: it holds an object ([`Verdict::Holding`], like a Robotiq gripper's gOBJ "object
//! detected while closing"). What counts as contact is the kind's ([`Contact`]): its measured
//! effort in the closing direction (Dex3, Dex5 and Dex1 torque, BrainCo current, EZGripper
//! effort), what the device reports per joint (Inspire FTP: stopped at its force limit), or,
//! where a profile says so for a device that measures no effort (Inspire DFX through its
//! service), any closing joint stopped short. A joint stopped with no effort is still a fault, and so is a hand whose state
//! repeats ([`Verdict::Frozen`], checked first).
//!
//! A device with nothing commanded (or limp) is never judged; a sample that is not fresh
//! resets the detector (staleness is reported on its own). The hold time keeps a hand that
//! is moving normally, and noise (far below half the tolerance), from ever alarming; a fault
//! is reported one hold time after it appears (plus a sample period).

use std::time::{Duration, Instant};

/// The motion verdicts, as `DeviceStatus_::motion` carries them (idl/handgate.idl).
pub use handgate_idl::handgate::{MOTION_FROZEN, MOTION_HOLDING, MOTION_JOINT_STUCK, MOTION_NOT_FOLLOWING, MOTION_OK};

/// Two measurements of a joint closer than this (rad) are "the same": a repeated sample.
/// Far below every kind's measurement noise and resolution (docs/adapters.md "Emulators").
pub const FREEZE_EPS: f32 = 1.0e-6;

/// The fewest samples a window of no progress must hold before a joint is reported: a stream
/// slowed to a few samples a second (a starved peer) is not judged on a handful.
pub const MIN_SAMPLES: u32 = 10;

/// Whether a device follows its command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Verdict {
    /// Following, settled, or not commanded.
    #[default]
    Ok,
    /// The samples keep arriving, identical, while the device is commanded to move.
    Frozen,
    /// One joint does not follow while the others do.
    JointStuck,
    /// No joint follows, though the state still varies.
    NotFollowing,
    /// Every joint that stopped short of its target stopped closing on contact: the hand holds
    /// an object. Not a fault.
    Holding,
}

impl Verdict {
    /// The wire value (`DeviceStatus_::motion`).
    pub fn code(self) -> u8 {
        match self {
            Verdict::Ok => MOTION_OK,
            Verdict::Frozen => MOTION_FROZEN,
            Verdict::JointStuck => MOTION_JOINT_STUCK,
            Verdict::NotFollowing => MOTION_NOT_FOLLOWING,
            Verdict::Holding => MOTION_HOLDING,
        }
    }

    /// The word `handgate status`, `/metrics` and the dashboard use for `code`.
    pub fn word(code: u8) -> &'static str {
        match code {
            MOTION_OK => "ok",
            MOTION_FROZEN => "frozen",
            MOTION_JOINT_STUCK => "joint_stuck",
            MOTION_NOT_FOLLOWING => "not_following",
            MOTION_HOLDING => "holding",
            _ => "unknown",
        }
    }
}

/// What tells a joint stopped by an object from a stuck one, per kind (its table).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Contact {
    /// The joint's measured effort (`JointState::tau`, canonical: positive = closing, in the
    /// kind's own unit: N·m, A, the EZGripper's effort / 10) is at least this towards closing.
    /// Profile `[devices.motion] contact_effort`.
    Effort(f32),
    /// The device says so per joint (`HandState::contact`: an Inspire FTP actuator stopped at
    /// its force limit or reporting force).
    Reported,
    /// The device measures no effort (Inspire DFX through DFX_inspire_service, whose state
    /// carries only positions) and the profile chose to take a closing joint stopped short as
    /// holding (`[devices.motion] contact = "unmeasured"`): a stuck finger is then told only
    /// while opening (docs/adapters.md, "Motion").
    Unmeasured,
}

/// A kind's thresholds (its table: `DeviceTable::motion`; profile `[devices.motion]`). The
/// values are assumptions (no hardware here: docs/profiles.md, "Assumptions").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionThresholds {
    /// An error above this (rad) is a demand to move; a joint must move half of it towards
    /// its target within [`Self::hold`] to count as following.
    pub tolerance: f32,
    /// How long a demanded joint may make no progress (and the samples repeat) before it is
    /// reported.
    pub hold: Duration,
    /// What shows contact ([`Verdict::Holding`]).
    pub contact: Contact,
}

impl MotionThresholds {
    /// Fingers (Dex3, Dex5): 0.05 rad, 400 ms; contact at 0.05 N·m of closing torque (a Dex3
    /// joint's torque noise is 0.004 N·m; xr_teleoperate's kp 1.5 gives 0.075 N·m at the
    /// tolerance's error).
    pub const HAND: MotionThresholds = MotionThresholds {
        tolerance: 0.05,
        hold: Duration::from_millis(400),
        contact: Contact::Effort(0.05),
    };
    /// Parallel grippers (Dex1, EZGripper): a jaw of several radians moves slower and settles
    /// coarser: 0.15 rad, 500 ms; contact at 0.1 of closing effort (N·m on a Dex1; 1 % of the
    /// EZGripper's effort).
    pub const GRIPPER: MotionThresholds = MotionThresholds {
        tolerance: 0.15,
        hold: Duration::from_millis(500),
        contact: Contact::Effort(0.1),
    };

    /// These thresholds with contact told by `contact`.
    pub const fn with_contact(self, contact: Contact) -> Self {
        Self { contact, ..self }
    }

    /// Whether joint effort `effort` (canonical, positive = closing) or the device's own word
    /// `reported` shows contact while closing.
    pub fn in_contact(&self, effort: f32, reported: bool) -> bool {
        match self.contact {
            Contact::Effort(min) => effort >= min,
            Contact::Reported => reported,
            Contact::Unmeasured => true,
        }
    }
    /// Bounds a profile may set (`[devices.motion]`): tolerance in (0, 1] rad, hold in
    /// [50, 900] ms (a fault must be reported within a second).
    pub const TOLERANCE_MAX: f32 = 1.0;
    pub const HOLD_MS_RANGE: (u64, u64) = (50, 900);

    /// The movement towards the target (rad) that counts as progress.
    pub fn progress(&self) -> f32 {
        self.tolerance * 0.5
    }
}

/// What the detector says after a sample. `clone_from` reuses the errors' buffer (a device
/// loop copies its state every cycle).
#[derive(Debug, PartialEq, Default)]
pub struct MotionReport {
    pub verdict: Verdict,
    /// The joint the verdict names (canonical index): the non-following joint with the
    /// largest error.
    pub joint: Option<usize>,
    /// The largest |target - measured| over the joints, rad (0 while nothing is commanded).
    pub max_error: f32,
    /// Per joint `target - measured`, rad (canonical order); empty while nothing is commanded.
    pub errors: Vec<f32>,
}

impl Clone for MotionReport {
    fn clone(&self) -> Self {
        let mut c = Self::default();
        c.clone_from(self);
        c
    }

    fn clone_from(&mut self, src: &Self) {
        self.verdict = src.verdict;
        self.joint = src.joint;
        self.max_error = src.max_error;
        self.errors.clone_from(&src.errors);
    }
}

impl MotionReport {
    /// Nothing commanded: no error, no verdict.
    pub fn idle() -> Self {
        Self::default()
    }

    /// Whether a target is in force (the errors are measured).
    pub fn commanded(&self) -> bool {
        !self.errors.is_empty()
    }

    /// The largest error, NaN while nothing is commanded (what the status reports).
    pub fn tracking_error(&self) -> f32 {
        if self.commanded() {
            self.max_error
        } else {
            f32::NAN
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Track {
    /// When the current demand began (the error went above tolerance, or changed sign).
    demand_since: Instant,
    /// Where and when the joint last made progress (or the demand began).
    anchor_q: f32,
    anchor_t: Instant,
    /// Samples seen since the anchor.
    samples: u32,
    /// Reported as not following: it stays reported until it moves towards its target (or
    /// reaches it), whatever gaps the stream has meanwhile.
    reported: bool,
    /// The sign of the error the anchor is measured against.
    dir: f32,
    /// Reported, and stopped closing in contact: holding an object.
    holding: bool,
}

/// The per-device detector.
#[derive(Debug, Clone)]
pub struct MotionDetector {
    thresholds: MotionThresholds,
    tracks: Vec<Option<Track>>,
    /// When each joint last moved towards its target or reached it.
    progressed: Vec<Option<Instant>>,
    last_q: Vec<f32>,
    /// The time of the last sample that differed from the one before it (or the first):
    /// every sample since repeated it.
    last_change: Option<Instant>,
    /// The time of the last sample observed (a republished one is not a new sample).
    last_t: Option<Instant>,
    report: MotionReport,
}

impl MotionDetector {
    pub fn new(thresholds: MotionThresholds) -> Self {
        Self {
            thresholds,
            tracks: Vec::new(),
            progressed: Vec::new(),
            last_q: Vec::new(),
            last_change: None,
            last_t: None,
            report: MotionReport::idle(),
        }
    }

    pub fn thresholds(&self) -> MotionThresholds {
        self.thresholds
    }

    /// The last report.
    pub fn report(&self) -> &MotionReport {
        &self.report
    }

    /// Forgets everything (no sample, or the device went stale): no verdict until judged again.
    pub fn reset(&mut self) {
        self.tracks.clear();
        self.progressed.clear();
        self.last_q.clear();
        self.last_change = None;
        self.last_t = None;
        self.report = MotionReport::idle();
    }

    /// [`Self::observe_with_contact`] with no joint in contact (the tests of the verdicts
    /// that do not depend on it).
    #[cfg(test)]
    pub fn observe(&mut self, at: Instant, targets: Option<&[f32]>, measured: &[f32]) -> &MotionReport {
        self.observe_with_contact(at, targets, measured, |_| false)
    }

    /// One measured sample taken at `at`: `measured` positions against `targets` in force
    /// (`None`: nothing commanded, or a limp device), with each joint's contact (`contact(j)`:
    /// its effort or the device's word shows contact, [`MotionThresholds::in_contact`]): a
    /// joint that stopped short of a closing target in contact holds an object, not a fault.
    /// A sample whose time is not newer than the last one (the same state republished)
    /// changes nothing.
    pub fn observe_with_contact(
        &mut self,
        at: Instant,
        targets: Option<&[f32]>,
        measured: &[f32],
        contact: impl Fn(usize) -> bool,
    ) -> &MotionReport {
        if self.last_t.is_some_and(|t| at <= t) {
            return &self.report;
        }
        // The stream was interrupted (a stalled peer, a loaded machine): a joint not reported
        // yet is judged again from here (a stall is staleness's business, and a starved
        // emulator's joints move slower than the wall clock). One already reported stays so.
        let gap = self
            .last_t
            .is_some_and(|t| at.saturating_duration_since(t) > self.thresholds.hold / 4);
        self.last_t = Some(at);
        let n = measured.len();
        // Repeated samples: every joint where it was.
        let same = self.last_q.len() == n
            && self
                .last_q
                .iter()
                .zip(measured)
                .all(|(a, b)| (a - b).abs() <= FREEZE_EPS);
        if !same || self.last_change.is_none() {
            self.last_change = Some(at);
        }
        self.last_q.clear();
        self.last_q.extend_from_slice(measured);
        let Some(targets) = targets.filter(|t| t.len() == n) else {
            self.tracks.clear();
            self.progressed.clear();
            self.report = MotionReport::idle();
            return &self.report;
        };
        if self.tracks.len() != n {
            self.tracks = vec![None; n];
            self.progressed = vec![None; n];
        }
        let th = self.thresholds;
        let mut report = std::mem::take(&mut self.report);
        report.errors.clear();
        report.max_error = 0.0;
        let mut stuck: Option<(usize, f32)> = None;
        let mut stuck_since: Option<Instant> = None;
        let mut holding: Option<(usize, f32)> = None;
        for j in 0..n {
            let e = targets[j] - measured[j];
            report.errors.push(e);
            if e.is_finite() {
                report.max_error = report.max_error.max(e.abs());
            }
            // A NaN error (a non-finite measurement) is no demand.
            let demanded = e.abs() > th.tolerance;
            if !demanded {
                if self.tracks[j].take().is_some() {
                    self.progressed[j] = Some(at); // reached its target
                }
                continue;
            }
            let dir = e.signum();
            let t = match &mut self.tracks[j] {
                Some(t) if t.dir == dir => t,
                slot => slot.insert(Track {
                    demand_since: at,
                    anchor_q: measured[j],
                    anchor_t: at,
                    samples: 0,
                    reported: false,
                    dir,
                    holding: false,
                }),
            };
            if gap && !t.reported {
                t.anchor_q = measured[j];
                t.anchor_t = at;
                t.samples = 0;
            }
            t.samples = t.samples.saturating_add(1);
            if (measured[j] - t.anchor_q) * dir >= th.progress() {
                t.anchor_q = measured[j];
                t.anchor_t = at;
                t.samples = 0;
                t.reported = false;
                t.holding = false;
                self.progressed[j] = Some(at);
            } else if Self::no_progress(t, at, th) {
                t.reported = true;
                if dir > 0.0 && contact(j) {
                    // Stopped closing on something that pushes back: holding it.
                    t.holding = true;
                    if holding.map_or(true, |(_, best)| e.abs() > best) {
                        holding = Some((j, e.abs()));
                    }
                    continue;
                }
                t.holding = false;
                if stuck.map_or(true, |(_, best)| e.abs() > best) {
                    stuck = Some((j, e.abs()));
                }
                stuck_since = Some(stuck_since.map_or(t.demand_since, |s: Instant| s.min(t.demand_since)));
            }
        }
        // A hand whose samples repeat is frozen, whatever its joints' efforts say (the efforts
        // repeat too). Not while the device itself reports the contact it stopped on
        // (`Contact::Reported`: a Robotiq's gOBJ, an RH56's STATUS 3): a real gripper holding
        // an object reports the same integer position every cycle, and its own word that it
        // holds is a fresh fact each sample, not a replayed one.
        let frozen = self
            .last_change
            .is_some_and(|c| at.saturating_duration_since(c) >= th.hold)
            && !(th.contact == Contact::Reported && holding.is_some());
        if let (None, Some((j, _))) = (stuck, holding) {
            if !frozen {
                report.joint = Some(j);
                report.verdict = Verdict::Holding;
                self.report = report;
                return &self.report;
            }
            stuck = holding;
            stuck_since = self.tracks[j].as_ref().map(|t| t.demand_since);
        }
        report.joint = stuck.map(|(j, _)| j);
        report.verdict = match (stuck, stuck_since) {
            (Some((j, _)), Some(since)) => {
                let others_follow = self
                    .progressed
                    .iter()
                    .enumerate()
                    .any(|(k, p)| k != j && !self.is_stuck(k, at) && p.is_some_and(|p| p >= since));
                if frozen {
                    Verdict::Frozen
                } else if others_follow {
                    Verdict::JointStuck
                } else {
                    Verdict::NotFollowing
                }
            }
            _ => Verdict::Ok,
        };
        self.report = report;
        &self.report
    }

    /// Whether joint `k` is demanded and has made no progress for the hold time at `at`.
    fn is_stuck(&self, k: usize, at: Instant) -> bool {
        self.tracks[k]
            .as_ref()
            .is_some_and(|t| !t.holding && Self::no_progress(t, at, self.thresholds))
    }

    /// A demanded joint was reported, or has made no progress for the hold time over at least
    /// [`MIN_SAMPLES`] samples (a slow stream is not judged on a handful).
    fn no_progress(t: &Track, at: Instant, th: MotionThresholds) -> bool {
        t.reported || (at.saturating_duration_since(t.anchor_t) >= th.hold && t.samples >= MIN_SAMPLES)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::Prng;

    const N: usize = 3;
    const DT: Duration = Duration::from_millis(2);

    /// A hand of `N` joints sampled every 2 ms: each joint a first-order lag towards its
    /// target (time constant 80 ms) unless it is stuck, measured with noise.
    struct Hand {
        q: [f32; N],
        stuck: [bool; N],
        ignore: bool,
        frozen: Option<[f32; N]>,
        noise: f32,
        rng: Prng,
        t: Instant,
        det: MotionDetector,
    }

    impl Hand {
        fn new(noise: f32) -> Self {
            Self {
                q: [0.0; N],
                stuck: [false; N],
                ignore: false,
                frozen: None,
                noise,
                rng: Prng::new(7),
                t: Instant::now(),
                det: MotionDetector::new(MotionThresholds::HAND),
            }
        }

        /// Runs `ms` of samples towards `target`; returns every verdict seen and the time
        /// of the first non-OK one (ms from the start of this run).
        fn run(&mut self, target: Option<[f32; N]>, ms: u64) -> (Vec<Verdict>, Option<u64>, MotionReport) {
            let mut seen = Vec::new();
            let mut first = None;
            let start = self.t;
            for _ in 0..ms / 2 {
                self.t += DT;
                if let (Some(tg), false) = (target, self.ignore) {
                    for ((q, t), stuck) in self.q.iter_mut().zip(tg).zip(self.stuck) {
                        if !stuck {
                            *q += (t - *q) * (2.0 / 80.0);
                        }
                    }
                }
                let m: [f32; N] = match self.frozen {
                    Some(f) => f,
                    None => std::array::from_fn(|j| self.q[j] + self.noise * self.rng.normalish()),
                };
                let r = self.det.observe(self.t, target.as_ref().map(|t| &t[..]), &m);
                if r.verdict != Verdict::Ok && first.is_none() {
                    first = Some((self.t - start).as_millis() as u64);
                }
                if !seen.contains(&r.verdict) {
                    seen.push(r.verdict);
                }
            }
            (seen, first, self.det.report().clone())
        }
    }

    const CLOSE: [f32; N] = [1.0, 0.8, 1.2];

    #[test]
    fn a_normal_move_with_noise_never_alarms() {
        let mut h = Hand::new(0.002);
        let (seen, _, r) = h.run(Some(CLOSE), 3000);
        assert_eq!(seen, [Verdict::Ok]);
        assert!(r.max_error < 0.01, "{r:?}");
        // Moving back and forth, a new target every 300 ms.
        for k in 0..10 {
            let tg = if k % 2 == 0 { [0.0; N] } else { CLOSE };
            let (seen, _, _) = h.run(Some(tg), 300);
            assert_eq!(seen, [Verdict::Ok], "move {k}");
        }
        // A target streamed as a ramp the hand follows with lag.
        for k in 0..500 {
            let x = (k as f32 / 500.0) * 1.0;
            let (seen, _, _) = h.run(Some([x; N]), 2);
            assert_eq!(seen, [Verdict::Ok], "ramp {k}");
        }
    }

    #[test]
    fn a_frozen_stream_is_caught_within_a_second() {
        let mut h = Hand::new(0.002);
        h.run(Some([0.0; N]), 500);
        h.frozen = Some(h.q);
        let (seen, first, r) = h.run(Some(CLOSE), 1000);
        assert_eq!(seen, [Verdict::Ok, Verdict::Frozen]);
        let first = first.unwrap();
        assert!((400..=500).contains(&first), "{first} ms");
        assert_eq!(r.joint, Some(2), "the largest error: {r:?}");
        assert!((r.max_error - 1.2).abs() < 0.02, "{r:?}");
        // Recovery clears it.
        h.frozen = None;
        let (_, _, r) = h.run(Some(CLOSE), 1000);
        assert_eq!((r.verdict, r.joint), (Verdict::Ok, None), "{r:?}");
    }

    #[test]
    fn one_stuck_joint_is_named_while_the_others_follow() {
        let mut h = Hand::new(0.002);
        h.stuck[1] = true;
        let (seen, first, r) = h.run(Some(CLOSE), 2000);
        assert_eq!(seen, [Verdict::Ok, Verdict::JointStuck]);
        assert!(first.unwrap() <= 500, "{first:?}");
        assert_eq!(r.joint, Some(1));
        assert!((r.errors[1] - 0.8).abs() < 0.02 && r.errors[0].abs() < 0.02, "{r:?}");
        // Without noise, the others settled and identical: still reported (frozen or stuck),
        // never OK.
        let mut h = Hand::new(0.0);
        h.stuck[1] = true;
        let (_, _, r) = h.run(Some(CLOSE), 2000);
        assert_ne!(r.verdict, Verdict::Ok);
        assert_eq!(r.joint, Some(1));
        h.stuck[1] = false;
        let (_, _, r) = h.run(Some(CLOSE), 1000);
        assert_eq!(r.verdict, Verdict::Ok, "recovered: {r:?}");
    }

    #[test]
    fn a_hand_ignoring_commands_is_not_following() {
        let mut h = Hand::new(0.002);
        h.ignore = true;
        let (seen, first, r) = h.run(Some(CLOSE), 1500);
        assert_eq!(seen, [Verdict::Ok, Verdict::NotFollowing]);
        assert!(first.unwrap() <= 500, "{first:?}");
        assert_eq!(r.joint, Some(2));
        h.ignore = false;
        let (_, _, r) = h.run(Some(CLOSE), 1000);
        assert_eq!(r.verdict, Verdict::Ok);
    }

    #[test]
    fn a_device_not_commanded_never_alarms() {
        let mut h = Hand::new(0.002);
        h.frozen = Some([0.3; N]);
        let (seen, _, r) = h.run(None, 2000);
        assert_eq!(seen, [Verdict::Ok]);
        assert!(!r.commanded() && r.tracking_error().is_nan(), "{r:?}");
        // Commanded where it already is, frozen: nothing to follow.
        let (seen, _, _) = h.run(Some([0.3; N]), 2000);
        assert_eq!(seen, [Verdict::Ok]);
    }

    /// A stream with gaps longer than a quarter of the hold time is judged again after each;
    /// a slow stream needs [`MIN_SAMPLES`] samples of no progress.
    #[test]
    fn an_interrupted_or_slow_stream_is_judged_on_enough_samples() {
        let mut d = MotionDetector::new(MotionThresholds::HAND);
        let t0 = Instant::now();
        let tg = [1.0; N];
        let at = |ms: u64| t0 + Duration::from_millis(ms);
        // A sample every 150 ms, never moving: every gap restarts the window.
        for k in 0..20 {
            let m = [0.001 * (k % 2) as f32; N];
            assert_eq!(d.observe(at(150 * k), Some(&tg), &m).verdict, Verdict::Ok, "{k}");
        }
        // Every 60 ms: the hold time passes at the seventh sample, the verdict waits for the tenth.
        let mut d = MotionDetector::new(MotionThresholds::HAND);
        let mut first = None;
        for k in 0..20u64 {
            let m = [0.001 * (k % 2) as f32; N];
            if d.observe(at(60 * k), Some(&tg), &m).verdict != Verdict::Ok && first.is_none() {
                first = Some(60 * k);
            }
        }
        assert_eq!(first, Some(540), "the tenth sample, the first counted");
        // Reported, then a gap: still reported (only moving clears it).
        let r = d.observe(at(60 * 20 + 300), Some(&tg), &[0.0; N]);
        assert_eq!(r.verdict, Verdict::NotFollowing, "{r:?}");
        let r = d.observe(at(60 * 20 + 310), Some(&tg), &[0.9; N]);
        assert_eq!(r.verdict, Verdict::Ok, "moved: {r:?}");
    }

    /// A hand closing on an object: the blocked joints stop short with their effort showing
    /// contact: `Holding`, never a fault, whatever the hold time. The same stop with no effort
    /// (a stuck joint) is a fault; so is an opening joint that stops, and a frozen stream.
    #[test]
    fn a_grasp_is_holding_and_a_stop_without_effort_is_still_a_fault() {
        let t0 = Instant::now();
        let at = |ms: u64| t0 + Duration::from_millis(ms);
        let tg = [1.0f32, 1.0, 1.0];
        // Joints 0 and 1 blocked at 0.6, joint 2 reaches its target; noise on the positions.
        let run = |effort: f32, targets: [f32; 3], blocked: [f32; 3]| {
            let mut d = MotionDetector::new(MotionThresholds::HAND);
            let mut rng = Prng::new(3);
            let mut seen = Vec::new();
            for k in 0..1000u64 {
                let m: [f32; 3] = std::array::from_fn(|j| blocked[j] + 0.001 * rng.normalish());
                let th = d.thresholds();
                let v = d
                    .observe_with_contact(at(2 * k), Some(&targets), &m, |j| {
                        let e = if blocked[j] != targets[j] { effort } else { 0.0 };
                        th.in_contact(e, false)
                    })
                    .clone();
                if !seen.contains(&v.verdict) {
                    seen.push(v.verdict);
                }
            }
            (seen, d.report().clone())
        };
        let (seen, r) = run(0.6, tg, [0.6, 0.6, 1.0]);
        assert_eq!(seen, [Verdict::Ok, Verdict::Holding], "{r:?}");
        assert!(r.joint.is_some_and(|j| j < 2), "{r:?}");
        // No effort: the same stop is a fault.
        let (seen, _) = run(0.0, tg, [0.6, 0.6, 1.0]);
        let fault = |v: &Verdict| matches!(v, Verdict::JointStuck | Verdict::NotFollowing);
        assert!(seen.iter().any(fault) && !seen.contains(&Verdict::Holding), "{seen:?}");
        // Below the kind's contact effort: a fault too.
        let (seen, _) = run(0.02, tg, [0.6, 0.6, 1.0]);
        assert!(!seen.contains(&Verdict::Holding), "{seen:?}");
        // An opening target (0) stopped at 0.6 with effort: not a grasp.
        let (seen, _) = run(0.6, [0.0, 0.0, 1.0], [0.6, 0.6, 1.0]);
        assert!(!seen.contains(&Verdict::Holding), "{seen:?}");
        // One joint holding, another stuck without effort: the fault is reported.
        let mut d = MotionDetector::new(MotionThresholds::HAND);
        for k in 0..1000u64 {
            d.observe_with_contact(at(2 * k), Some(&tg), &[0.6 + 0.001 * (k % 3) as f32, 0.2, 1.0], |j| {
                j == 0
            });
        }
        let r = d.report();
        assert!(fault(&r.verdict) && r.joint == Some(1), "{r:?}");
        // A frozen stream of a holding hand is frozen where handgate infers the contact from
        // an effort (the effort repeats too)...
        let mut d = MotionDetector::new(MotionThresholds::HAND);
        for k in 0..1000u64 {
            d.observe_with_contact(at(2 * k), Some(&tg), &[0.6, 0.6, 1.0], |_| true);
        }
        assert_eq!(d.report().verdict, Verdict::Frozen);
        // ...but holds where the device reports it (a Robotiq's gOBJ 2 with gPO constant), and
        // a frozen stream without the device's word is still frozen.
        let reported = MotionThresholds::HAND.with_contact(Contact::Reported);
        let mut d = MotionDetector::new(reported);
        for k in 0..1000u64 {
            d.observe_with_contact(at(2 * k), Some(&tg), &[0.6, 0.6, 1.0], |_| true);
        }
        assert_eq!(d.report().verdict, Verdict::Holding);
        let mut d = MotionDetector::new(reported);
        for k in 0..1000u64 {
            d.observe_with_contact(at(2 * k), Some(&tg), &[0.6, 0.6, 1.0], |_| false);
        }
        assert_eq!(d.report().verdict, Verdict::Frozen);
        // A kind that measures no effort: a closing joint stopped short holds.
        let th = MotionThresholds::HAND.with_contact(Contact::Unmeasured);
        assert!(th.in_contact(0.0, false));
        assert!(MotionThresholds::HAND
            .with_contact(Contact::Reported)
            .in_contact(0.0, true));
        assert!(!MotionThresholds::HAND
            .with_contact(Contact::Reported)
            .in_contact(5.0, false));
    }

    #[test]
    fn a_republished_sample_is_not_a_new_one_and_reset_forgets() {
        let mut d = MotionDetector::new(MotionThresholds::HAND);
        let t0 = Instant::now();
        let tg = [1.0; N];
        // The same sample seen for 2 s (a loop republishing its last state) never ages.
        for k in 0..1000 {
            let r = d.observe(t0, Some(&tg), &[0.0; N]);
            assert_eq!(r.verdict, Verdict::Ok, "{k}");
        }
        for k in 1..=300 {
            d.observe(t0 + Duration::from_millis(2 * k), Some(&tg), &[0.0; N]);
        }
        assert_eq!(d.report().verdict, Verdict::Frozen);
        d.reset();
        assert_eq!(d.report().verdict, Verdict::Ok);
        assert!(!d.report().commanded());
    }
}
