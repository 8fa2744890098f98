//! Pieces shared by the emulated peers: the hand side, a rate newtype, the emulator error
//! type, a configuration check, and the stoppable loop paced at a fixed rate that
//! [`crate::service_emulator`] runs every emulated DDS service on.

use std::time::{Duration, Instant};

use crate::dds::DdsError;

pub use crate::model::Side;

/// A frequency in hertz. Must be finite and > 0 to be used as a loop rate.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd)]
pub struct Hz(pub f64);

impl Hz {
    /// The period of one cycle, or an error for a rate that is not finite and positive.
    pub fn period(self) -> Result<Duration, EmulatorError> {
        if self.0.is_finite() && self.0 > 0.0 && self.0 <= 100_000.0 {
            Ok(Duration::from_secs_f64(1.0 / self.0))
        } else {
            Err(EmulatorError::InvalidConfig(format!(
                "rate {} Hz is not in (0, 100000]",
                self.0
            )))
        }
    }
}

/// Errors starting an emulator.
#[derive(Debug, thiserror::Error)]
pub enum EmulatorError {
    #[error(transparent)]
    Dds(#[from] DdsError),
    #[error("invalid emulator configuration: {0}")]
    InvalidConfig(String),
    #[error("could not spawn the emulator thread: {0}")]
    Spawn(#[from] std::io::Error),
}

/// A fault an emulated service injects (`handgate emulate <kind> --fault ...`, docs/adapters.md
/// "Motion"), so that a hand that reports but does not move can be reproduced: as given on the
/// command line, a joint by name.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FaultArg {
    /// `stuck=<joint>`: that joint stays where it is, whatever the command (canonical name, or
    /// the URDF name `rt/joint_states` publishes).
    Stuck(String),
    /// `frozen`: the service keeps publishing its last state, repeated.
    Frozen,
    /// `ignore-commands`: the state evolves as if no command came (noise continues).
    IgnoreCommands,
}

impl FaultArg {
    /// The forms `--fault` takes, as help and errors list them.
    pub const FORMS: &'static str = "stuck=<joint>, frozen or ignore-commands";

    /// The fault's form: `stuck`, `frozen` or `ignore-commands`.
    pub fn form(&self) -> &'static str {
        match self {
            FaultArg::Stuck(_) => "stuck",
            FaultArg::Frozen => "frozen",
            FaultArg::IgnoreCommands => "ignore-commands",
        }
    }

    /// The wire entry of the joint a `stuck` names, found in `table` (the emulated hand's).
    pub fn resolve(&self, table: &crate::mapping::DeviceTable) -> Result<Fault, EmulatorError> {
        Ok(match self {
            FaultArg::Frozen => Fault::Frozen,
            FaultArg::IgnoreCommands => Fault::IgnoreCommands,
            FaultArg::Stuck(name) => {
                let j = table
                    .joints
                    .iter()
                    .find(|j| j.name == name || j.urdf == *name)
                    .ok_or_else(|| {
                        let names: Vec<&str> = table.joints.iter().map(|j| j.name).collect();
                        EmulatorError::InvalidConfig(format!(
                            "--fault stuck={name}: no such joint on a {} {} (joints: {})",
                            table.side,
                            table.kind,
                            names.join(", ")
                        ))
                    })?;
                Fault::Stuck(j.wire_index)
            }
        })
    }
}

impl std::str::FromStr for FaultArg {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s.split_once('=') {
            Some(("stuck", j)) if !j.trim().is_empty() => Ok(FaultArg::Stuck(j.trim().to_string())),
            None if s == "frozen" => Ok(FaultArg::Frozen),
            None if s == "ignore-commands" => Ok(FaultArg::IgnoreCommands),
            _ => Err(format!("unknown fault {s:?} (expected {})", Self::FORMS)),
        }
    }
}

/// A fault as an emulated service runs it ([`crate::service_emulator::ServiceEmulator::inject`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// The motor at this wire entry stays where it is (the core's
    /// [`crate::service_emulator::ServiceCore::stick`]).
    Stuck(usize),
    /// The state message of the cycle the fault began is published again every cycle.
    Frozen,
    /// Commands are taken from the reader and dropped.
    IgnoreCommands,
}

/// The faults an emulator outside the service shell runs, added up (the Dex3 USB MCU, the
/// EZGripper bus; a service core keeps its own stuck flags, [`crate::service_emulator`]): `N`
/// wire entries that can be stuck.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Injected<const N: usize> {
    /// Per wire entry: held where it is, whatever the command.
    pub stuck: [bool; N],
    /// The positions reported when the fault began are reported again.
    pub frozen: bool,
    /// Commands are received (and answered) but not applied.
    pub ignore_commands: bool,
}

impl<const N: usize> Default for Injected<N> {
    fn default() -> Self {
        Self {
            stuck: [false; N],
            frozen: false,
            ignore_commands: false,
        }
    }
}

impl<const N: usize> Injected<N> {
    /// `fault` alone (`None`: none); a stuck entry `what` (e.g. "a Dex3-1") does not have is
    /// refused.
    pub fn of(fault: Option<Fault>, what: &str) -> Result<Self, EmulatorError> {
        let mut out = Self::default();
        match fault {
            Some(Fault::Stuck(entry)) => crate::service_emulator::stick_entry(&mut out.stuck, entry, what)?,
            Some(Fault::Frozen) => out.frozen = true,
            Some(Fault::IgnoreCommands) => out.ignore_commands = true,
            None => {}
        }
        Ok(out)
    }
}

/// `Err(InvalidConfig)` unless every value is finite (an array, or the values set of an
/// array of options: `objects.into_iter().flatten()`).
pub(crate) fn ensure_finite(what: &str, values: impl IntoIterator<Item = f32>) -> Result<(), EmulatorError> {
    match values.into_iter().find(|v| !v.is_finite()) {
        Some(v) => Err(EmulatorError::InvalidConfig(format!("{what} must be finite, got {v}"))),
        None => Ok(()),
    }
}

/// An emulated peer's control loop: `tick` at a fixed period until stopped (explicitly or on
/// drop), on the emulators' shared thread (crate::loops; its deadlines on the process-wide
/// grid, so that emulators of one rate wake together).
pub(crate) struct Worker {
    handle: crate::loops::Handle,
}

impl Worker {
    /// Starts calling `tick(now)` every `period` (absolute schedule: a late cycle is not made
    /// up by bursts, the schedule skips ahead instead); `name` names it in logs.
    pub(crate) fn spawn<F>(name: &str, period: Duration, tick: F) -> Result<Self, EmulatorError>
    where
        F: FnMut(Instant) + Send + 'static,
    {
        let first = crate::loops::first_deadline(period);
        let task = crate::loops::Periodic::new(period, first, tick);
        let handle = crate::loops::spawn(crate::loops::Class::Emulators, name, first, task)?;
        Ok(Self { handle })
    }

    /// Stops the loop: on return `tick` never runs again (idempotent).
    pub(crate) fn stop(&mut self) {
        self.handle.stop();
    }
}

/// Seconds elapsed between two loop ticks, bounded so a stalled thread (a loaded CI machine)
/// does not hand the joint model one huge step.
pub(crate) fn tick_dt(prev: Option<Instant>, now: Instant, nominal: Duration) -> f32 {
    let dt = match prev {
        Some(p) => now.saturating_duration_since(p),
        None => nominal,
    };
    dt.as_secs_f32().clamp(0.0, 0.01)
}

/// Test support: how long a DDS test waits for a condition before it fails (generous: a
/// loaded machine starves the emulator threads).
#[cfg(test)]
pub(crate) const TEST_WAIT: Duration = Duration::from_secs(20);

/// Test support: polls `cond` until it holds; panics after [`TEST_WAIT`].
#[cfg(test)]
pub(crate) fn wait_for(mut cond: impl FnMut() -> bool) {
    let deadline = Instant::now() + TEST_WAIT;
    while !cond() {
        assert!(Instant::now() < deadline, "condition not reached");
        std::thread::yield_now();
    }
}

/// Test support: makes DDS domain `id` private to this process.
///
/// The emulator tests own fixed domain ids; two runs of the same tests at once (two
/// worktrees, two engineers) would otherwise discover each other's emulators on the same
/// host. CycloneDDS's `Discovery/Tag` makes participants ignore remote participants without
/// the same tag; participants inside one process still match locally. Call it before any
/// `Node` on `id`. The domain is kept for the life of the process (deleting it under live
/// participants would make their deletion fail), and a second call for the same id is a no-op.
#[cfg(test)]
pub(crate) fn isolated_test_domain(id: u32) {
    use std::collections::HashSet;
    use std::sync::OnceLock;
    static CREATED: OnceLock<std::sync::Mutex<HashSet<u32>>> = OnceLock::new();
    let mut created = CREATED
        .get_or_init(Default::default)
        .lock()
        .unwrap_or_else(|e| e.into_inner());
    if created.insert(id) {
        let cfg = format!(
            "<CycloneDDS><Domain Id=\"any\"><Discovery><Tag>handgate-emu-test-{}-{id}</Tag></Discovery></Domain></CycloneDDS>",
            std::process::id()
        );
        let domain =
            cyclonedds_rs::dds_domain::DdsDomain::create(id, Some(&cfg)).expect("create an isolated test domain");
        std::mem::forget(domain);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::Ordering;
    use std::sync::Arc;

    #[test]
    fn faults_parse_and_name_their_joint() {
        assert_eq!("frozen".parse(), Ok(FaultArg::Frozen));
        assert_eq!("ignore-commands".parse(), Ok(FaultArg::IgnoreCommands));
        assert_eq!("stuck=thumb_1".parse(), Ok(FaultArg::Stuck("thumb_1".into())));
        assert!("stuck=".parse::<FaultArg>().is_err());
        assert!("slow".parse::<FaultArg>().unwrap_err().contains("stuck=<joint>"));
        let t = crate::model::DeviceKind::Dex3
            .table(Side::Right, &Default::default())
            .unwrap();
        let by_name = FaultArg::Stuck("index_0".into()).resolve(&t).unwrap();
        let urdf = t.joints[t.joint_by_name("index_0").unwrap().index()].urdf.clone();
        assert_eq!(FaultArg::Stuck(urdf).resolve(&t).unwrap(), by_name, "the URDF name too");
        let e = FaultArg::Stuck("pinky".into()).resolve(&t).unwrap_err().to_string();
        assert!(e.contains("thumb_0"), "{e}");
    }

    #[test]
    fn hz_period_validates() {
        assert_eq!(Hz(500.0).period().unwrap(), Duration::from_millis(2));
        assert!(Hz(0.0).period().is_err());
        assert!(Hz(-1.0).period().is_err());
        assert!(Hz(f64::NAN).period().is_err());
    }

    #[test]
    fn worker_runs_and_stops_on_drop() {
        let n = Arc::new(std::sync::atomic::AtomicU64::new(0));
        let n2 = n.clone();
        let w = Worker::spawn("t", Duration::from_millis(1), move |_| {
            n2.fetch_add(1, Ordering::Relaxed);
        })
        .unwrap();
        let deadline = Instant::now() + Duration::from_secs(10);
        while n.load(Ordering::Relaxed) < 5 {
            assert!(Instant::now() < deadline, "worker never ticked");
            std::thread::yield_now();
        }
        drop(w);
        let after = n.load(Ordering::Relaxed);
        // Stopped: the tick was dropped and the counter can no longer move.
        std::thread::yield_now();
        assert_eq!(n.load(Ordering::Relaxed), after);
    }

    #[test]
    fn tick_dt_is_bounded() {
        let t = Instant::now();
        assert_eq!(tick_dt(None, t, Duration::from_millis(2)), 0.002);
        assert_eq!(
            tick_dt(Some(t), t + Duration::from_secs(3), Duration::from_millis(2)),
            0.01
        );
    }
}
