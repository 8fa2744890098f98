//! The shell of every emulated DDS service (the peers of the DDS-client kinds:
//! dex1_1_service, the G1's Dex3 service, ai_sport's `rt/hand_sdk` blend,
//! DFX_inspire_service, Inspire's FTP driver, brainco_hand_service). A kind supplies the
//! service's logic without DDS, its [`ServiceCore`] (configuration, topics and rate,
//! snapshot) and [`ServiceWire`] (commands in, time passes, messages out), which its unit
//! tests drive with synthetic time. [`ServiceEmulator`] runs that core on DDS:
//! one command reader, the writers of what it publishes, the core behind a lock, and its loop
//! on the emulators' shared thread ([`crate::emu_common::Worker`]), stopped by
//! [`ServiceEmulator::stop`] or on drop.
//!
//! One cycle, in this order: take the commands the reader holds (it keeps the newest: a
//! command written over before a cycle takes it is not seen); apply them in arrival order
//! ([`ServiceCore::receive`], all stamped with one instant taken after the take, so never
//! earlier than the sender's write); run the core's cycle ([`ServiceCore::cycle`]), which
//! returns the state message; publish it, then the extra message when one is due. The loop
//! is paced on an absolute schedule (a late cycle is skipped, not replayed) and the step it
//! hands the core is bounded ([`crate::emu_common::tick_dt`]).
//!
//! QoS: the command reader is best-effort (it matches reliable and best-effort writers
//! alike), the writers reliable keep-last-1 (they match reliable and best-effort readers
//! alike). The real services' QoS is not public.

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use cyclonedds_rs::TopicType;

use crate::dds::{DdsError, Node, Qos, Writer};
use crate::emu_common::{tick_dt, EmulatorError, Hz, Worker};

/// A service's logic without DDS (what differs between the emulated services): what it is
/// started with, where it runs, and what it reports. The messages it exchanges are its
/// [`ServiceWire`]: usually the core itself, several for a service with several wire
/// variants (dex1_1_service's `unitree_go` and `unitree_hg`).
pub trait ServiceCore: Sized + Send + 'static {
    /// What the service is started with (kept: [`ServiceEmulator::config`]).
    type Config: Send + Sync + 'static;
    /// What [`ServiceEmulator::snapshot`] returns.
    type Snapshot;

    /// The core for `config`, or why the configuration is refused.
    fn from_config(config: &Self::Config) -> Result<Self, EmulatorError>;

    /// Where and how fast the service runs for `config`.
    fn plan(config: &Self::Config) -> Result<ServicePlan, EmulatorError>;

    /// A consistent copy of the core's state, with what the emulator published.
    fn report(&self, published: Published) -> Self::Snapshot;

    /// Makes the motor at wire entry `entry` stay where it is, whatever the command
    /// ([`crate::emu_common::Fault::Stuck`]). The default: a service whose core cannot.
    fn stick(&mut self, entry: usize) -> Result<(), EmulatorError> {
        Err(EmulatorError::InvalidConfig(format!(
            "this emulated service cannot hold entry {entry} stuck (--fault frozen and ignore-commands work)"
        )))
    }
}

/// The messages core `C` exchanges on DDS, and what it does with them.
pub trait ServiceWire<C>: 'static {
    /// The command message the service subscribes.
    type Cmd: TopicType + Clone + Send + 'static;
    /// The state message it publishes each cycle ([`Silent`]: it publishes none).
    type State: Outlet;
    /// A second message on a topic of its own, each cycle or at a rate of its own ([`Silent`]:
    /// none).
    type Extra: Outlet;

    /// One command, received at `now`. A malformed one is the core's to ignore (and count).
    fn receive(core: &mut C, cmd: &Self::Cmd, now: Instant);

    /// One loop cycle after the commands were applied: time passes, and the state message to
    /// publish (`None`: nothing this cycle).
    fn cycle(core: &mut C, tick: Tick) -> Option<Self::State>;

    /// The extra message, when it is due, after [`Self::cycle`] returned `state`.
    fn extra(_core: &mut C, _state: &Self::State) -> Option<Self::Extra> {
        None
    }
}

/// A service's loop name, rate and topics, decided from its configuration at start.
#[derive(Debug, Clone, PartialEq)]
pub struct ServicePlan {
    /// Names the loop in logs.
    pub name: String,
    /// Loop and state rate.
    pub rate: Hz,
    pub cmd_topic: String,
    /// `None`: the service publishes no state.
    pub state_topic: Option<String>,
    /// The extra message's topic and rate (`None`: every cycle); `None`: no extra message.
    pub extra: Option<(String, Option<Hz>)>,
}

impl ServicePlan {
    /// The loop `name` at `rate`, reading `cmd_topic` and publishing on `state_topic`
    /// (`None`: no state), with no extra message.
    pub fn new(name: impl Into<String>, rate: Hz, cmd_topic: String, state_topic: Option<String>) -> Self {
        Self {
            name: name.into(),
            rate,
            cmd_topic,
            state_topic,
            extra: None,
        }
    }

    /// The loop of `kind`'s service for the hand on `side` at `rate` (named `{kind}-emu-{side}`):
    /// on `topics` when given, else on the side's `standard` pair (`None`, for center: refused).
    pub fn one_hand(
        kind: &str,
        side: crate::model::Side,
        rate: Hz,
        topics: Option<(String, String)>,
        standard: Option<(String, String)>,
    ) -> Result<Self, EmulatorError> {
        let Some((cmd, state)) = topics.or(standard) else {
            return Err(EmulatorError::InvalidConfig(format!("a {kind} hand is left or right")));
        };
        Ok(Self::new(format!("{kind}-emu-{side}"), rate, cmd, Some(state)))
    }

    /// The same with `extra`: a second message's topic and rate (`None`: every cycle), or
    /// `None` for none.
    pub fn with_extra(self, extra: Option<(String, Option<Hz>)>) -> Self {
        Self { extra, ..self }
    }
}

/// [`ServiceCore::stick`] for a core that keeps one flag per wire entry: sets `entry`'s, or
/// refuses an entry `what` (e.g. "a Dex3-1") does not have.
pub fn stick_entry(stuck: &mut [bool], entry: usize, what: &str) -> Result<(), EmulatorError> {
    let s = stuck
        .get_mut(entry)
        .ok_or_else(|| EmulatorError::InvalidConfig(format!("no entry {entry} on {what}")))?;
    *s = true;
    Ok(())
}

/// The time of one cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tick {
    /// When the cycle runs (taken after the commands were applied).
    pub now: Instant,
    /// Seconds since the previous cycle, bounded ([`crate::emu_common::tick_dt`]).
    pub dt: f32,
    /// The loop's nominal period.
    pub period: Duration,
}

/// Messages a service wrote successfully since it started.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Published {
    pub state: u64,
    pub extra: u64,
}

/// A message a service publishes: any DDS topic type, or [`Silent`]. `Clone`: a frozen
/// service publishes one message again ([`crate::emu_common::Fault::Frozen`]).
pub trait Outlet: Send + Clone + 'static {
    type Writer: Send + 'static;
    /// The writer on `topic` (reliable, keep last 1).
    fn open(node: &Node, topic: &str) -> Result<Self::Writer, DdsError>;
    /// Writes the message; whether it went out.
    fn write(self, writer: &mut Self::Writer) -> bool;
}

impl<T: TopicType + Clone + Send + 'static> Outlet for T {
    type Writer = Writer<T>;

    fn open(node: &Node, topic: &str) -> Result<Writer<T>, DdsError> {
        node.writer(topic, Qos::Reliable { depth: 1 })
    }

    fn write(self, writer: &mut Writer<T>) -> bool {
        writer.write(self).is_ok()
    }
}

/// No message: the outlet of a service that publishes nothing there (ai_sport's blend
/// publishes no state at all).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Silent {}

impl Outlet for Silent {
    type Writer = ();

    fn open(_node: &Node, _topic: &str) -> Result<(), DdsError> {
        Ok(())
    }

    fn write(self, _writer: &mut ()) -> bool {
        match self {}
    }
}

struct Shared<C> {
    core: C,
    published: Published,
    /// Faults injected ([`ServiceEmulator::inject`]).
    frozen: bool,
    ignore_commands: bool,
}

/// A running emulated service around the core `C`. Dropping it stops its loop.
pub struct ServiceEmulator<C: ServiceCore> {
    shared: Arc<Mutex<Shared<C>>>,
    worker: Worker,
    config: C::Config,
    name: String,
}

impl<C: ServiceCore> std::fmt::Debug for ServiceEmulator<C> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ServiceEmulator").field("name", &self.name).finish()
    }
}

impl<C: ServiceCore + ServiceWire<C>> ServiceEmulator<C> {
    /// Starts the service on `node`, on the core's own wire.
    pub fn start(node: &Node, config: C::Config) -> Result<Self, EmulatorError> {
        Self::start_on::<C>(node, config)
    }
}

impl<C: ServiceCore> ServiceEmulator<C> {
    /// Starts the service on `node` on wire `W`: its reader and writers, then its loop.
    pub fn start_on<W: ServiceWire<C>>(node: &Node, config: C::Config) -> Result<Self, EmulatorError> {
        let plan = C::plan(&config)?;
        let period = plan.rate.period()?;
        let extra_period = match &plan.extra {
            Some((_, Some(rate))) => Some(rate.period()?),
            _ => None,
        };
        let core = C::from_config(&config)?;
        let reader = node.reader::<W::Cmd>(&plan.cmd_topic, Qos::BestEffort)?;
        let mut state_w = plan
            .state_topic
            .as_deref()
            .map(|t| W::State::open(node, t))
            .transpose()?;
        let mut extra_w = plan.extra.as_ref().map(|(t, _)| W::Extra::open(node, t)).transpose()?;
        let shared = Arc::new(Mutex::new(Shared {
            core,
            published: Published::default(),
            frozen: false,
            ignore_commands: false,
        }));
        let sh = shared.clone();
        let mut prev = None;
        // The state a frozen service repeats: the one of the cycle the fault began.
        let mut repeat: Option<W::State> = None;
        let mut next_extra = Instant::now();
        let worker = Worker::spawn(&plan.name, period, move |now| {
            let cmds = reader.take();
            let dt = tick_dt(prev, now, period);
            prev = Some(now);
            let extra_due = extra_w.is_some()
                && match extra_period {
                    Some(_) => now >= next_extra,
                    None => true,
                };
            let (state, extra) = {
                let mut g = lock(&sh);
                let received = Instant::now();
                if !g.ignore_commands {
                    for c in &cmds {
                        W::receive(&mut g.core, c, received);
                    }
                }
                let tick = Tick {
                    now: Instant::now(),
                    dt,
                    period,
                };
                let mut state = W::cycle(&mut g.core, tick);
                if g.frozen {
                    match &repeat {
                        Some(r) => state = Some(r.clone()),
                        None => repeat = state.clone(),
                    }
                } else {
                    repeat = None;
                }
                let extra = match &state {
                    Some(s) if extra_due => W::extra(&mut g.core, s),
                    _ => None,
                };
                (state, extra)
            };
            if let (true, Some(p)) = (extra_due, extra_period) {
                next_extra = (next_extra + p).max(now);
            }
            let state_ok = match (state, state_w.as_mut()) {
                (Some(s), Some(w)) => Some(s.write(w)),
                _ => None,
            };
            let extra_ok = match (extra, extra_w.as_mut()) {
                (Some(x), Some(w)) => Some(x.write(w)),
                _ => None,
            };
            if state_ok.is_some() || extra_ok.is_some() {
                let mut g = lock(&sh);
                g.published.state += u64::from(state_ok == Some(true));
                g.published.extra += u64::from(extra_ok == Some(true));
            }
        })?;
        Ok(Self {
            shared,
            worker,
            config,
            name: plan.name,
        })
    }

    pub fn config(&self) -> &C::Config {
        &self.config
    }

    /// A consistent copy of the core's state and what was published.
    pub fn snapshot(&self) -> C::Snapshot {
        let g = lock(&self.shared);
        g.core.report(g.published)
    }

    /// Injects `fault` from the next cycle on (docs/adapters.md, "Motion"): a stuck motor
    /// (the core's [`ServiceCore::stick`]), a frozen state (the next state message is
    /// published again every cycle, the core running on unseen), or commands ignored (taken
    /// from the reader and dropped: the core runs as if none came). Faults add up.
    pub fn inject(&self, fault: crate::emu_common::Fault) -> Result<(), EmulatorError> {
        use crate::emu_common::Fault;
        let mut g = lock(&self.shared);
        match fault {
            Fault::Stuck(entry) => g.core.stick(entry)?,
            Fault::Frozen => g.frozen = true,
            Fault::IgnoreCommands => g.ignore_commands = true,
        }
        tracing::warn!(emulator = %self.name, ?fault, "fault injected");
        Ok(())
    }

    /// Runs `f` on the core between two cycles (a kind's inspection and set-up calls).
    pub fn with_core<R>(&self, f: impl FnOnce(&mut C) -> R) -> R {
        f(&mut lock(&self.shared).core)
    }

    /// Stops the loop (also done on drop).
    pub fn stop(mut self) {
        self.worker.stop();
    }
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A panic inside the loop leaves plain data behind: keep serving it.
    m.lock().unwrap_or_else(|e| e.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emu_common::{wait_for, TEST_WAIT as WAIT};
    use handgate_idl::unitree_go::{MotorCmd_, MotorCmds_, MotorStates_};

    /// Keeps the q of every command in arrival order; its state carries how many it kept.
    #[derive(Debug, Default)]
    struct Echo {
        received: Vec<(f32, Instant)>,
        cycles: u64,
    }

    /// (publish a state, extra message rate).
    type EchoConfig = (bool, Option<Hz>);

    impl ServiceCore for Echo {
        type Config = EchoConfig;
        type Snapshot = (Vec<(f32, Instant)>, u64, Published);

        fn from_config(_: &EchoConfig) -> Result<Self, EmulatorError> {
            Ok(Self::default())
        }

        fn plan(&(state, extra): &EchoConfig) -> Result<ServicePlan, EmulatorError> {
            let state_topic = state.then(|| "test/echo/state".into());
            let extra = extra.map(|r| ("test/echo/extra".to_string(), Some(r)));
            Ok(ServicePlan::new("echo-emu", Hz(500.0), "test/echo/cmd".into(), state_topic).with_extra(extra))
        }

        fn report(&self, published: Published) -> Self::Snapshot {
            (self.received.clone(), self.cycles, published)
        }
    }

    impl ServiceWire<Echo> for Echo {
        type Cmd = MotorCmds_;
        type State = MotorStates_;
        type Extra = MotorStates_;

        fn receive(core: &mut Echo, cmd: &MotorCmds_, now: Instant) {
            core.received.extend(cmd.cmds.iter().map(|c| (c.q, now)));
        }

        fn cycle(core: &mut Echo, tick: Tick) -> Option<MotorStates_> {
            assert!(tick.dt <= 0.01 && tick.period == Duration::from_millis(2));
            core.cycles += 1;
            Some(MotorStates_::with_len(core.received.len()))
        }

        fn extra(_core: &mut Echo, state: &MotorStates_) -> Option<MotorStates_> {
            Some(state.clone())
        }
    }

    #[test]
    fn dds_commands_in_arrival_order_state_every_cycle_extra_at_its_own_rate() {
        crate::emu_common::isolated_test_domain(65);
        let emu_node = Node::new(65, None).unwrap();
        let emu = ServiceEmulator::<Echo>::start(&emu_node, (true, Some(Hz(50.0)))).unwrap();
        let node = Node::new(65, None).unwrap();
        let mut w = node
            .writer::<MotorCmds_>("test/echo/cmd", Qos::Reliable { depth: 8 })
            .unwrap();
        let r = node.reader::<MotorStates_>("test/echo/state", Qos::BestEffort).unwrap();
        w.wait_matched(1, WAIT).unwrap();
        r.wait_matched(1, WAIT).unwrap();
        // One command per state that shows the previous one (the reader keeps the newest).
        let mut sent = Vec::new();
        for (k, q) in [1.0, 2.0, 3.0].into_iter().enumerate() {
            sent.push(Instant::now());
            let cmd = MotorCmds_ {
                cmds: vec![MotorCmd_ {
                    q,
                    ..Default::default()
                }],
            };
            w.write(cmd).unwrap();
            wait_for(|| r.take().iter().any(|s| s.states.len() == k + 1));
        }
        let (received, _, _) = emu.snapshot();
        assert_eq!(received.iter().map(|r| r.0).collect::<Vec<_>>(), [1.0, 2.0, 3.0]);
        assert!(
            received.iter().zip(&sent).all(|(r, t)| r.1 >= *t),
            "stamped after the take"
        );
        wait_for(|| emu.snapshot().2.extra >= 3);
        let (_, cycles, published) = emu.snapshot();
        assert!(
            published.state >= cycles - 1,
            "a state each cycle: {published:?} in {cycles}"
        );
        // 500 Hz against 50 Hz: the extra message at about a tenth of the state's count.
        assert!(published.extra * 5 < published.state, "{published:?}");
        assert_eq!(emu.with_core(|c| c.received.len()), 3);
        emu.stop();
    }

    #[test]
    fn dds_a_silent_service_cycles_and_publishes_nothing() {
        crate::emu_common::isolated_test_domain(65);
        let node = Node::new(65, None).unwrap();
        let emu = ServiceEmulator::<Echo>::start(&node, (false, None)).unwrap();
        wait_for(|| emu.snapshot().1 >= 10);
        assert_eq!(emu.snapshot().2, Published::default());
        let before = emu.snapshot().1;
        drop(emu);
        assert!(before >= 10);
    }

    #[test]
    fn a_bad_rate_is_refused_before_anything_starts() {
        struct Slow;
        impl ServiceCore for Slow {
            type Config = Hz;
            type Snapshot = ();
            fn from_config(_: &Hz) -> Result<Self, EmulatorError> {
                panic!("built before the rate was checked")
            }
            fn plan(rate: &Hz) -> Result<ServicePlan, EmulatorError> {
                Ok(ServicePlan::new("slow-emu", *rate, "test/slow/cmd".into(), None))
            }
            fn report(&self, _: Published) {}
        }
        impl ServiceWire<Slow> for Slow {
            type Cmd = MotorCmds_;
            type State = Silent;
            type Extra = Silent;
            fn receive(_: &mut Slow, _: &MotorCmds_, _: Instant) {}
            fn cycle(_: &mut Slow, _: Tick) -> Option<Silent> {
                None
            }
        }
        crate::emu_common::isolated_test_domain(65);
        let node = Node::new(65, None).unwrap();
        let err = ServiceEmulator::<Slow>::start(&node, Hz(0.0)).unwrap_err();
        assert!(matches!(err, EmulatorError::InvalidConfig(_)), "{err}");
    }
}
