//! The decisions of a front that takes commands, as a plain state machine with no clock: which
//! writer owns the front (`control`), each writer's commands in order by their source
//! timestamps and no older than `max_command_age_ms` ([`Order`]), decode → check against the
//! device's table → command, the silence action per bound device (`silence`, the watchdog),
//! the prompt state publish and the rejection log's rate limit (docs/fronts.md). Every call
//! takes `now` (and a sample its wall-clock [`Stamp`]); the core never
//! sleeps, spawns or touches DDS, and says what to do as [`Action`]s, in order. The gateway's
//! front task (`handgate_gateway::runtime::fronts`) is one async loop around it that only
//! moves messages; a program using this crate as a library runs the same watchdog the same
//! way.
//!
//! # Running a front core
//!
//! Build it with [`FrontCore::new`] from a [`FrontId`] ([`FrontId::next`]), the front's
//! `control` and hold time, and per bound device its route and [`SilencePlan`] ([`Driven`]);
//! [`FrontCore::with_max_command_age`] sets the front's `max_command_age_ms`.
//! Give it the devices through [`Devices`]: [`OwnDevices`] when this front alone drives them,
//! or an implementation over state shared with the other fronts on a device (the gateway's
//! per-device counters). Then feed it, in one task:
//!
//! - **A command sample** (its writer, whether it asks to take over, when it was taken, its
//!   source timestamp: [`Sample`]): [`FrontCore::admit`]; when it returns [`Admitted`], decode
//!   the message (the front kind's codec, [`super::serve::FrontIo::decode`], over views built with
//!   [`FrontCore::route`]), wait for any silence action still running on a device the decoded
//!   commands go to (so the safe state never lands after a newer command), then
//!   [`FrontCore::decoded`], which checks each body against the device's table and hands it
//!   to [`Devices::command`].
//! - **A deadline**: sleep until [`FrontCore::next_deadline`] (the earliest silence deadline,
//!   or when the prompt publish stops waiting), then call [`FrontCore::deadline`]. Ask again
//!   after every call: any call may move it.
//! - **A device state** while [`FrontCore::awaiting`] says the device's is awaited:
//!   [`FrontCore::state`] with the `cmd_seq` it reflects ([`FrontCore::state_closed`] when
//!   the device's state channel closed).
//! - **The periodic state publish** (the front's own `state_hz` grid): publish, then
//!   [`FrontCore::published`] per device with the `cmd_seq` of the state that went out, and
//!   [`FrontCore::queue`] with the total of samples the front's queue dropped.
//!
//! And carry out each [`Action`] it pushes: bump a counter, publish the state now and restart
//! the periodic grid a full period from now ([`Action::Publish`]), move a device to its safe
//! action ([`HandDevice::safe_state`], off the loop so publishing keeps its deadlines;
//! [`Action::Safe`]), name who commands a device ([`Action::Owner`]), write a log line
//! ([`Log`]). `adapters/tests/front_core.rs` runs one against a Dex3 hand's in-process USB
//! emulator, with no gateway.

use std::collections::{HashMap, HashSet};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::config::{Control, Silence};
use super::plan::SilencePlan;
use super::serve::{Incoming, Routed, Stamp};
use super::Rejection;
use crate::dds::{WriterHandle, WriterInfo};
use crate::device::{DeviceError, HandDevice};
use crate::mapping::CheckedBody;
use crate::model::SafeAction;
use crate::route::Route;

/// How long a front waits for the state reflecting an accepted command before it stops
/// listening for it (the periodic state carries on regardless).
pub const PROMPT_STATE_WAIT: Duration = Duration::from_millis(100);

/// Identifies a front among the fronts of a process: which front's command a device took last
/// decides whose silence acts on it ([`Devices::is_last_front`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FrontId(u64);

static NEXT_FRONT_ID: AtomicU64 = AtomicU64::new(1);

impl FrontId {
    /// A new id, never given before in this process (never 0: a store of last fronts may keep
    /// 0 for "none").
    pub fn next() -> Self {
        Self(NEXT_FRONT_ID.fetch_add(1, Ordering::Relaxed))
    }

    /// The id as a number (to keep it in an atomic).
    pub fn get(self) -> u64 {
        self.0
    }
}

// ---------------------------------------------------------------------------------------------
// Who commands the front

/// Writers named in the log per owner at most (a flood of writers is not named forever).
const MAX_NAMED: usize = 256;

/// Whether a sample of a writer may go on to the front's decode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Admit {
    /// Yes: it may take or keep the front if it is accepted.
    Yes,
    /// No: another writer owns the front. `first`: the first refusal of this writer under
    /// this owner (to name it in the log once).
    Foreign { first: bool },
}

/// How the front changed hands after an accepted sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Change {
    /// The front was free (first owner).
    First,
    /// The previous owner had been silent for the hold time.
    AfterSilence { silent: Duration },
    /// Taken over from an owner that was not silent (`--force`).
    Forced,
}

#[derive(Debug, Clone, Copy)]
struct Owner {
    writer: WriterHandle,
    /// Its last accepted sample.
    last: Instant,
}

/// Who commands a front (`control`, docs/fronts.md "One commanding client per front").
///
/// `exclusive`: the first writer whose command is accepted owns the front; it keeps it while
/// its commands keep being accepted and until it has been silent for the front's hold time
/// (a writer that goes away counts as silent from its last accepted command: no instant
/// hand-over). Samples of other writers are refused whole until then, except a writer that
/// asks to take over (`handgate send --force`). `shared`: every writer is taken.
#[derive(Debug)]
pub struct Ownership {
    control: Control,
    hold: Duration,
    owner: Option<Owner>,
    /// Writers refused (and named) under the current owner.
    named: HashSet<WriterHandle>,
}

impl Ownership {
    pub fn new(control: Control, hold: Duration) -> Self {
        Self {
            control,
            hold,
            owner: None,
            named: HashSet::new(),
        }
    }

    /// The owner at `now`, if it has not been silent for the hold time.
    fn live_owner(&self, now: Instant) -> Option<Owner> {
        self.owner.filter(|o| now.saturating_duration_since(o.last) < self.hold)
    }

    /// Whether a sample of `writer` (`force`: it asks to take over) arriving at `now` may
    /// go on to decode. Changes nothing but the record of who was named.
    pub fn admit(&mut self, writer: WriterHandle, force: bool, now: Instant) -> Admit {
        if self.control == Control::Shared || force {
            return Admit::Yes;
        }
        match self.live_owner(now) {
            Some(o) if o.writer != writer => {
                let first = self.named.len() < MAX_NAMED && self.named.insert(writer);
                Admit::Foreign { first }
            }
            _ => Admit::Yes,
        }
    }

    /// A sample of `writer` was accepted (at least one device took it) at `now`: it owns
    /// the front from now. Returns how the front changed hands, if it did.
    pub fn accepted(&mut self, writer: WriterHandle, now: Instant) -> Option<Change> {
        if self.control == Control::Shared {
            return None;
        }
        let live = self.live_owner(now);
        let previous = self.owner.replace(Owner { writer, last: now });
        match previous {
            Some(p) if p.writer == writer => None,
            prev => {
                self.named.clear();
                Some(match (prev, live) {
                    (None, _) => Change::First,
                    (Some(_), Some(_)) => Change::Forced,
                    (Some(p), None) => Change::AfterSilence {
                        silent: now.saturating_duration_since(p.last),
                    },
                })
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Commands in order

/// Writers whose order a front keeps at most; beyond, the one heard from longest ago is
/// forgotten (its next sample starts its order afresh).
const MAX_ORDERED: usize = 64;

/// How far a writer's clock may run ahead of this host's before its samples' ages are not
/// trusted (`max_command_age_ms`): two hosts synchronised by chrony or PTP disagree by well
/// under a millisecond, and a sample is never taken before it was written.
pub const CLOCK_AHEAD_TOLERANCE: Duration = Duration::from_millis(5);

/// Why a sample was dropped before decode: its writer's order, or its age.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dropped {
    /// Its source timestamp equals that of the last sample accepted from its writer (a copy,
    /// as a bridge delivers twice).
    Duplicate,
    /// Its source timestamp is older than that of the last sample accepted from its writer,
    /// by `behind`.
    Reordered { behind: Duration },
    /// It was `age` old when the reader took it, older than the front's `max_command_age_ms`
    /// (`max`).
    Late { age: Duration, max: Duration },
}

impl Dropped {
    /// The log's key (rate-limited per key) and the counter's name.
    pub fn reason(&self) -> &'static str {
        match self {
            Dropped::Duplicate => "duplicate",
            Dropped::Reordered { .. } => "reordered",
            Dropped::Late { .. } => "late",
        }
    }

    /// The counter it is counted in, on every device of the front.
    pub fn counter(&self) -> Counter {
        match self {
            Dropped::Duplicate => Counter::Duplicate,
            Dropped::Reordered { .. } => Counter::Reordered,
            Dropped::Late { .. } => Counter::Late,
        }
    }
}

impl std::fmt::Display for Dropped {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Dropped::Duplicate => f.write_str("the same source timestamp as the last command accepted from its writer"),
            Dropped::Reordered { behind } => write!(
                f,
                "source timestamp {:.3} ms older than the last command accepted from its writer",
                behind.as_secs_f64() * 1e3
            ),
            Dropped::Late { age, max } => write!(
                f,
                "{:.3} ms old on arrival, older than max_command_age_ms = {}",
                age.as_secs_f64() * 1e3,
                max.as_millis()
            ),
        }
    }
}

/// What a front knows of one writer's order.
#[derive(Debug, Clone, Copy)]
struct Seen {
    /// Source timestamp of its last accepted sample (`None`: none yet, or it starts afresh).
    last: Option<i64>,
    /// When its last sample was taken (the writer heard from longest ago is forgotten first).
    at: Instant,
    /// Since its last accepted sample, its samples dropped as reordered in one stream (none
    /// a restart time after the one before): when the first and the latest were taken. A
    /// writer whose samples have all been behind for the restart time had its clock stepped
    /// back; a lone late copy long after its last is not that.
    behind: Option<(Instant, Instant)>,
    /// Its clock was seen ahead of this host's by more than [`CLOCK_AHEAD_TOLERANCE`]: its
    /// ages are not trusted, and none of its samples is late.
    ahead: bool,
    /// That was logged.
    named_ahead: bool,
}

/// Whether a sample goes on to decode ([`Order::check`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ordered {
    /// It goes on.
    Yes,
    /// It goes on, and its writer's order starts afresh from it: every sample of the writer
    /// had been dropped as older than its last accepted one (this one by `behind`) for the
    /// restart time, so its clock was stepped back.
    Restarted { behind: Duration },
    /// It is dropped (counted, rate-limited in the log).
    No(Dropped),
}

/// [`Order::check`]'s answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Checked {
    pub ordered: Ordered,
    /// The writer's clock runs ahead of this host's by this much: log it now (once per writer,
    /// at most one such line a second).
    pub ahead: Option<Duration>,
}

/// Commands that arrive in order (docs/fronts.md, "Commands in order").
///
/// Per writer (its DDS publication handle: a restarted client is a new writer, and a front's
/// new owner is judged by its own samples only), a sample whose source timestamp is not newer
/// than that of the last sample accepted from that writer is dropped: equal, a
/// [`Dropped::Duplicate`], older, [`Dropped::Reordered`]. With a maximum age, a sample older
/// than that when the reader took it (this host's clock against the writer's) is
/// [`Dropped::Late`], unless the writer's clock was ever seen ahead of this host's (then its
/// ages mean nothing: it is named once in the log and none of its samples is late). A sample
/// without a source timestamp (a dashboard page's) always goes on.
///
/// A writer whose clock is stepped back would have every sample dropped as reordered until
/// its clock passes its last accepted one; once its samples have all been dropped so, in one
/// stream (no gap of the restart time), for the restart time (the front's hold time, after
/// which its silence has acted and its ownership lapsed anyway), its order starts afresh. At most [`MAX_ORDERED`] writers are kept: the
/// core has no word of a writer going away, and a publication handle is never reused, so the
/// writer heard from longest ago is forgotten when a new one comes.
#[derive(Debug)]
pub struct Order {
    max_age: Option<Duration>,
    restart: Duration,
    writers: HashMap<WriterHandle, Seen>,
    /// At most one "clock ahead" line a second.
    ahead_log: RateLimit,
}

impl Order {
    /// Commands in order, and (`max_age`) no older than that on arrival; a writer whose
    /// samples have all been behind for `restart` starts afresh.
    pub fn new(max_age: Option<Duration>, restart: Duration) -> Self {
        Self {
            max_age,
            restart,
            writers: HashMap::new(),
            ahead_log: RateLimit::default(),
        }
    }

    /// Whether a sample of `writer` with `stamp`, taken at `now`, goes on to decode. Changes
    /// only what is known of the writer's clock; its order moves on once a sample is
    /// [`Self::accepted`].
    pub fn check(&mut self, writer: WriterHandle, stamp: Option<Stamp>, now: Instant) -> Checked {
        let mut checked = Checked {
            ordered: Ordered::Yes,
            ahead: None,
        };
        let Some(stamp) = stamp else {
            return checked;
        };
        if self.writers.len() >= MAX_ORDERED && !self.writers.contains_key(&writer) {
            if let Some(w) = self.writers.iter().min_by_key(|(_, s)| s.at).map(|(w, _)| *w) {
                self.writers.remove(&w);
            }
        }
        let e = self.writers.entry(writer).or_insert(Seen {
            last: None,
            at: now,
            behind: None,
            ahead: false,
            named_ahead: false,
        });
        e.at = now;
        let age = stamp.age_ns();
        if self.max_age.is_some() && age < -(CLOCK_AHEAD_TOLERANCE.as_nanos() as i64) {
            e.ahead = true;
            if !e.named_ahead && self.ahead_log.admit("clock_ahead", now).is_some() {
                e.named_ahead = true;
                checked.ahead = Some(Duration::from_nanos(age.unsigned_abs()));
            }
        }
        let mut restart = false;
        if let Some(last) = e.last {
            if stamp.written_ns == last {
                checked.ordered = Ordered::No(Dropped::Duplicate);
                return checked;
            }
            if stamp.written_ns < last {
                let behind = Duration::from_nanos(last.abs_diff(stamp.written_ns));
                let since = match e.behind {
                    Some((since, latest)) if now.saturating_duration_since(latest) < self.restart => since,
                    _ => now,
                };
                e.behind = Some((since, now));
                if now.saturating_duration_since(since) < self.restart {
                    checked.ordered = Ordered::No(Dropped::Reordered { behind });
                    return checked;
                }
                restart = true;
                checked.ordered = Ordered::Restarted { behind };
            }
        }
        if let Some(max) = self.max_age.filter(|_| !e.ahead) {
            if age > 0 && age.unsigned_abs() > max.as_nanos() as u64 {
                checked.ordered = Ordered::No(Dropped::Late {
                    age: Duration::from_nanos(age.unsigned_abs()),
                    max,
                });
                return checked;
            }
        }
        if restart {
            e.last = None;
            e.behind = None;
        }
        checked
    }

    /// A sample of `writer` with `stamp` was accepted (at least one device took it): the
    /// writer's order goes on from it.
    pub fn accepted(&mut self, writer: WriterHandle, stamp: Option<Stamp>) {
        let (Some(stamp), Some(e)) = (stamp, self.writers.get_mut(&writer)) else {
            return;
        };
        e.last = Some(stamp.written_ns);
        e.behind = None;
    }

    /// Number of writers whose order is kept.
    pub fn len(&self) -> usize {
        self.writers.len()
    }

    pub fn is_empty(&self) -> bool {
        self.writers.is_empty()
    }
}

// ---------------------------------------------------------------------------------------------
// The log's rate limit

/// At most one event per second per key is logged (a front's rejected commands by reason,
/// the dashboard's refused requests), with the count of those suppressed in between.
#[derive(Debug, Default)]
pub struct RateLimit {
    /// Per key: when one was last logged (`None`: never), and the events since.
    last: HashMap<&'static str, (Option<Instant>, u64)>,
}

impl RateLimit {
    /// Whether an event of `key` at `now` is logged: `Some(n)`, the number of events of `key`
    /// suppressed since the last one logged, when a second has passed since then (or none was
    /// logged yet); `None` otherwise.
    pub fn admit(&mut self, key: &'static str, now: Instant) -> Option<u64> {
        // Never `now - 2 s`: an Instant is time since boot, and a gateway started in its first
        // seconds (a systemd unit at boot) would panic on the subtraction.
        let e = self.last.entry(key).or_insert((None, 0));
        e.1 += 1;
        if e.0.map_or(true, |t| now.duration_since(t) >= Duration::from_secs(1)) {
            let suppressed = e.1 - 1;
            *e = (Some(now), 0);
            Some(suppressed)
        } else {
            None
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The periodic state publish

/// A state publish late by more than this many periods re-anchors the grid (the missed
/// publishes are dropped, never burst out).
const GRID_STALL_PERIODS: u32 = 5;

/// How long a front whose devices' states drive its periodic publish waits for the next
/// device state before it publishes on its own timer (a device loop that stopped: a USB hand
/// reconnecting); it also bounds how often that timer wakes while the devices drive.
pub const DEVICE_DRIVEN_GRACE: Duration = Duration::from_millis(50);

/// The most a prompt publish waits after the last publish ([`StateGrid::prompt`]): two samples
/// are never closer than this (or half a period on a grid faster than 500 Hz).
pub const PROMPT_MIN_SPACING: Duration = Duration::from_millis(1);

/// When a front publishes its periodic state (`state_hz`), on absolute deadlines: the k-th
/// publish is due at `start + k·period`, so a late one delays one sample, not the rate.
///
/// With `by_device` (decided once at bind time: every bound device tells its states on its
/// loop thread and measures at least `state_hz`), each device state is a chance to publish
/// ([`Self::at_state`]): the periodic state goes out from the device's thread, with no timer
/// woken for it, within a quarter period of its deadline. The front's own timer
/// ([`Self::deadline`], [`Self::due`]) then only stands in when no device state came for
/// [`DEVICE_DRIVEN_GRACE`] (and wakes at most that often while they come). Without it, the
/// timer publishes on every deadline, as a front always did.
///
/// A publish off the grid (the prompt state of a command, [`Self::prompt`]) is the one due in
/// its period, sent early: the grid does not move, so the topic keeps its rate whatever the
/// command traffic (one publish per period, as the services these fronts stand in for
/// publish at a fixed rate). It is refused when its period's publish already went out, or
/// when the last publish is less than [`PROMPT_MIN_SPACING`] (half a period on a faster grid)
/// old; the state then goes out at the period's deadline as usual.
#[derive(Debug, Clone)]
pub struct StateGrid {
    period: Duration,
    next: Instant,
    by_device: bool,
    /// The last device state told ([`Self::at_state`], [`Self::prompt`]).
    last_state: Option<Instant>,
    /// When the last publish went out (periodic or prompt).
    last_publish: Option<Instant>,
    /// Publishes dropped by re-anchoring after stalls.
    pub dropped: u64,
}

impl StateGrid {
    /// A grid of `period` starting at `now`, with a publish due at once (a client that starts
    /// with the front sees a state within a device cycle, not a period later).
    pub fn new(period: Duration, by_device: bool, now: Instant) -> Self {
        let period = period.max(Duration::from_micros(100));
        Self {
            period,
            next: now,
            by_device,
            last_state: None,
            last_publish: None,
            dropped: 0,
        }
    }

    /// Whether device states drive the periodic publish.
    pub fn by_device(&self) -> bool {
        self.by_device
    }

    /// A device state came at `now`: whether the periodic publish is due with it (always
    /// `false` unless `by_device`). When it is, the grid advanced.
    pub fn at_state(&mut self, now: Instant) -> bool {
        if !self.by_device {
            return false;
        }
        self.last_state = Some(now);
        if now + self.period / 4 >= self.next {
            self.advance(now);
            true
        } else {
            false
        }
    }

    /// When the front's timer must wake to publish: the next deadline, or with `by_device`
    /// while device states come, [`DEVICE_DRIVEN_GRACE`] after the last one.
    pub fn deadline(&self) -> Instant {
        match self.last_state.filter(|_| self.by_device) {
            Some(t) => self.next.max(t + DEVICE_DRIVEN_GRACE),
            None => self.next,
        }
    }

    /// The timer woke at `now`: whether it publishes (the grid advanced when it does).
    pub fn due(&mut self, now: Instant) -> bool {
        if now >= self.deadline() {
            self.advance(now);
            true
        } else {
            false
        }
    }

    /// The prompt state of a command is ready at `now` (on a device's loop thread, the state of
    /// a device this grid's devices drive, or on the front's task): whether it goes out now, as
    /// the publish of the period in progress. When it does, the grid advanced as for a
    /// periodic publish, so the next one is due at the next deadline of the same grid.
    pub fn prompt(&mut self, now: Instant) -> bool {
        if self.by_device {
            self.last_state = Some(now);
        }
        // The period in progress ends at `next`; a publish already sent for it moved `next` a
        // period further.
        let unsent = self.next <= now + self.period;
        let spaced = self
            .last_publish
            .map_or(true, |t| now.saturating_duration_since(t) >= self.prompt_spacing());
        if unsent && spaced {
            self.advance(now);
            true
        } else {
            false
        }
    }

    /// The least time between a publish and a prompt one: half a period, at most
    /// [`PROMPT_MIN_SPACING`] (a slow grid's prompt state still goes out at once).
    fn prompt_spacing(&self) -> Duration {
        (self.period / 2).min(PROMPT_MIN_SPACING)
    }

    fn advance(&mut self, now: Instant) {
        self.last_publish = Some(now);
        let late = now.saturating_duration_since(self.next);
        if late > self.period * GRID_STALL_PERIODS {
            self.dropped += (late.as_nanos() / self.period.as_nanos().max(1)) as u64;
            self.next = now + self.period;
        } else {
            self.next += self.period;
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The prompt publish

/// The prompt publish of one bound device: the state reflecting an accepted command goes out
/// at once, not at the next state deadline.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
struct Prompt {
    /// The state reflecting this accepted command (`cmd_seq`) is awaited.
    awaiting: Option<u64>,
    /// `cmd_seq` of the newest state seen while awaiting, and of the newest one published.
    /// A client streaming faster than the device applies never sees a state of its newest
    /// command; a state reflecting a newer command than the last published goes out at once.
    reflected: u64,
    published: u64,
}

impl Prompt {
    /// A state of the device reflecting command `cmd_seq` came: what was awaited has arrived
    /// once a state reflects it or a newer command.
    fn reflect(&mut self, cmd_seq: u64) {
        if self.awaiting.is_some_and(|a| cmd_seq >= a) {
            self.awaiting = None;
        }
        self.reflected = cmd_seq;
    }

    /// This device lets the front publish at once: nothing awaited, or its newest state
    /// reflects a newer command than the last one published.
    fn ready(&self) -> bool {
        self.awaiting.is_none() || self.reflected > self.published
    }

    /// The front published the newest state seen.
    fn mark_published(&mut self) {
        self.published = self.published.max(self.reflected);
    }
}

// ---------------------------------------------------------------------------------------------
// The core

/// The devices a front drives, as its core uses them: `device` is the index of the device
/// among the front's [`Driven`] devices. What the core reads of them is shared with every other
/// front on the same device (which front commanded it last, whether a silence action holds
/// it), so it is asked, not kept.
pub trait Devices {
    /// Hands device `device` a command already checked against its table (its
    /// [`HandDevice::command_checked`]); the error rejects it.
    fn command(&mut self, device: usize, seq: u64, body: CheckedBody, tag: u32) -> Result<(), DeviceError>;
    /// Whether the last command device `device` took came from front `front`.
    fn is_last_front(&self, device: usize, front: FrontId) -> bool;
    /// Records that device `device` took a command of front `front`; returns whether its
    /// previous command came from another front (or it had none).
    fn mark_last_front(&mut self, device: usize, front: FrontId) -> bool;
    /// Marks device `device` as held by a silence action (`true`) or commanded again
    /// (`false`); returns whether it was marked before.
    fn set_tripped(&mut self, device: usize, tripped: bool) -> bool;
}

/// [`Devices`] of a front that alone drives them (a program with one front over its
/// devices): the devices, and which front commanded each last and whether a silence action
/// holds it, kept here.
pub struct OwnDevices {
    devices: Vec<Arc<dyn HandDevice>>,
    /// Per device: the front whose command it took last, and whether a silence action holds it.
    marks: Vec<(Option<FrontId>, bool)>,
}

impl OwnDevices {
    pub fn new(devices: Vec<Arc<dyn HandDevice>>) -> Self {
        let marks = vec![(None, false); devices.len()];
        Self { devices, marks }
    }

    /// Device `device` (to run [`Action::Safe`] on it).
    pub fn device(&self, device: usize) -> &Arc<dyn HandDevice> {
        &self.devices[device]
    }

    /// Whether a silence action holds device `device` (until its next accepted command).
    pub fn tripped(&self, device: usize) -> bool {
        self.marks[device].1
    }
}

impl Devices for OwnDevices {
    fn command(&mut self, device: usize, seq: u64, body: CheckedBody, tag: u32) -> Result<(), DeviceError> {
        self.devices[device].command_checked(seq, body, tag)
    }

    fn is_last_front(&self, device: usize, front: FrontId) -> bool {
        self.marks[device].0 == Some(front)
    }

    fn mark_last_front(&mut self, device: usize, front: FrontId) -> bool {
        self.marks[device].0.replace(front) != Some(front)
    }

    fn set_tripped(&mut self, device: usize, tripped: bool) -> bool {
        std::mem::replace(&mut self.marks[device].1, tripped)
    }
}

/// One device a front drives, as its core decides for it: the route bound once (the device's
/// table checks every command) and what the front's silence does on it.
#[derive(Debug, Clone)]
pub struct Driven {
    pub route: Route,
    pub silence: SilencePlan,
}

/// A command sample as the core sees it: who wrote it, when it was written and when the
/// reader took it.
#[derive(Debug, Clone, Copy)]
pub struct Sample<'a> {
    pub writer: &'a Arc<WriterInfo>,
    /// The writer asks to take the front over ([`Incoming::force`]).
    pub force: bool,
    /// When the reader took it, not when the core sees it: a front task that fell behind
    /// must not see its owner as silent because of its own backlog.
    pub taken: Instant,
    /// Its source timestamp and the wall-clock time the reader took it (`None`: it carries
    /// none; never dropped by [`Order`]).
    pub stamp: Option<Stamp>,
}

impl<'a> Sample<'a> {
    /// The sample of what a front's reader queued.
    pub fn of(incoming: &'a Incoming) -> Self {
        Self {
            writer: &incoming.writer,
            force: incoming.force(),
            taken: incoming.taken,
            stamp: incoming.stamp,
        }
    }
}

/// A sample the core let through to decode ([`FrontCore::admit`]); [`FrontCore::decoded`]
/// takes it.
#[derive(Debug)]
pub struct Admitted(());

/// Per-device counters the core bumps (by one).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Counter {
    /// A command the device took (and when it was last accepted).
    Accepted,
    /// A command rejected: the whole sample as bad input (every device of the front), or the
    /// device's own check or command.
    Rejected,
    /// A sample refused whole because another writer owns the front.
    ForeignCmd,
    /// A silence action run on the device.
    WatchdogTrip,
    /// A sample dropped whole: the same source timestamp as its writer's last accepted one.
    Duplicate,
    /// A sample dropped whole: older than its writer's last accepted one.
    Reordered,
    /// A sample dropped whole: older than the front's `max_command_age_ms` on arrival.
    Late,
}

/// Why a command was rejected.
#[derive(Debug, thiserror::Error)]
pub enum Rejected {
    /// The front's decode rejected the sample whole (bad input).
    #[error(transparent)]
    Decode(Rejection),
    /// The device's table or the device itself refused its command.
    #[error(transparent)]
    Device(DeviceError),
}

impl Rejected {
    /// The log's key (rate-limited per key): the bad input's reason, or `device_rejected`.
    pub fn reason(&self) -> &'static str {
        match self {
            Rejected::Decode(r) => r.reason(),
            Rejected::Device(_) => "device_rejected",
        }
    }
}

/// A log line the core asks for, as data (the gateway's wording is in its front task).
#[derive(Debug)]
pub enum Log {
    /// A writer's samples are refused: `owner` commands the front (`None`: not known) until
    /// it has been silent for `hold`. Once per refused writer and owner.
    Refused {
        writer: Arc<WriterInfo>,
        owner: Option<Arc<WriterInfo>>,
        hold: Duration,
    },
    /// `writer` commands the front now, after `previous` (`None`: not known).
    Commands {
        writer: Arc<WriterInfo>,
        previous: Option<Arc<WriterInfo>>,
        change: Change,
    },
    /// A command was rejected; `suppressed` more of the same reason were not logged since the
    /// last line (at most one line per reason per second).
    Rejected { why: Rejected, suppressed: u64 },
    /// `writer`'s commands are rejected for a field it never sets
    /// ([`Rejection::once_per_client`]): said once per writer, with the fix.
    Advice { writer: Arc<WriterInfo>, why: Rejection },
    /// The front's silence moves `device` to its safe action: `after` without an accepted
    /// command, under silence `mode`.
    Silence {
        device: usize,
        mode: Silence,
        after: Duration,
        action: SafeAction,
    },
    /// A command was accepted on `device` while a silence action held it.
    Resumed { device: usize },
    /// The front's queue dropped `dropped` samples since the last report (`total` in all).
    QueueFull { dropped: u64, total: u64 },
    /// A sample of `writer` was dropped before decode ([`Order`]); `suppressed` more of the
    /// same reason were not logged since the last line (at most one line per reason per
    /// second).
    Dropped {
        writer: Arc<WriterInfo>,
        why: Dropped,
        suppressed: u64,
    },
    /// `writer`'s clock runs `ahead` of this host's: `max_command_age_ms` drops none of its
    /// samples as late. Once per writer.
    ClockAhead { writer: Arc<WriterInfo>, ahead: Duration },
    /// `writer`'s samples were all older than its last accepted one for `after` (this one by
    /// `behind`): its clock was stepped back; its order starts afresh from this sample.
    Restarted {
        writer: Arc<WriterInfo>,
        behind: Duration,
        after: Duration,
    },
}

/// What the caller does, in the order the core pushed them.
#[derive(Debug)]
pub enum Action {
    /// Bump `counter` of device `device`.
    Count { device: usize, counter: Counter },
    /// Publish the front's state now, and restart the periodic publish a full period from
    /// now (this publish stands in for the one due).
    Publish,
    /// Move device `device` to `action` ([`HandDevice::safe_state`]). A command for the
    /// device waits until it has finished.
    Safe { device: usize, action: SafeAction },
    /// `writer` commands `devices` now (they were commanded by another front, or the front
    /// changed hands).
    Owner {
        devices: Vec<usize>,
        writer: Arc<WriterInfo>,
    },
    /// Write this line.
    Log(Log),
}

/// One bound device's state in the core.
#[derive(Debug)]
struct Device {
    route: Route,
    silence: SilencePlan,
    /// Sequence number of the last command routed to it.
    seq: u64,
    /// When this front last had a command for the device accepted.
    last_valid: Option<Instant>,
    /// The silence action the last accepted command armed (timeout, action).
    armed: Option<(Duration, SafeAction)>,
    /// The silence action has run since the last accepted command.
    acted: bool,
    /// Which state this front publishes at once (the prompt publish).
    prompt: Prompt,
}

impl Device {
    /// When the armed silence action is due, unless it ran already.
    fn silence_due(&self) -> Option<(Instant, Duration, SafeAction)> {
        match (self.last_valid, self.armed, self.acted) {
            (Some(t), Some((after, action)), false) => Some((t + after, after, action)),
            _ => None,
        }
    }
}

/// The most writers a front remembers having told of a mistake they repeat
/// ([`Log::Advice`]).
pub const MAX_ADVISED: usize = 64;

/// The decisions of one front that takes commands (the module's doc says how to run it).
#[derive(Debug)]
pub struct FrontCore {
    id: FrontId,
    hold: Duration,
    ownership: Ownership,
    /// Each writer's commands in order, and their age.
    order: Order,
    /// The writer owning the front (`control = "exclusive"`), to name it in the log.
    owner: Option<Arc<WriterInfo>>,
    devices: Vec<Device>,
    /// When the last sample was accepted: the prompt publish waits [`PROMPT_STATE_WAIT`]
    /// from then.
    prompt_since: Option<Instant>,
    /// The rejection log's rate limit.
    rejections: RateLimit,
    /// Writers already told of a rejection [`Rejection::once_per_client`] (at most
    /// [`MAX_ADVISED`]; past that, such rejections fall back to the rate-limited log).
    advised: Vec<WriterHandle>,
    /// Samples the queue dropped as last reported, and when (`None`: never reported).
    dropped_reported: (u64, Option<Instant>),
}

impl FrontCore {
    /// The core of front `id`: who may command it (`control`, and how long a silent owner
    /// keeps it) and the devices it drives, in the order of the codec's device indices.
    pub fn new(id: FrontId, control: Control, hold: Duration, devices: Vec<Driven>) -> Self {
        Self {
            id,
            hold,
            ownership: Ownership::new(control, hold),
            order: Order::new(None, hold),
            owner: None,
            devices: devices
                .into_iter()
                .map(|d| Device {
                    route: d.route,
                    silence: d.silence,
                    seq: 0,
                    last_valid: None,
                    armed: None,
                    acted: false,
                    prompt: Prompt::default(),
                })
                .collect(),
            prompt_since: None,
            rejections: RateLimit::default(),
            advised: Vec::new(),
            dropped_reported: (0, None),
        }
    }

    /// This core, dropping commands older than `max` on arrival (the front's
    /// `max_command_age_ms`; `None`: no age limit, the default).
    pub fn with_max_command_age(mut self, max: Option<Duration>) -> Self {
        self.order = Order::new(max, self.hold);
        self
    }

    pub fn id(&self) -> FrontId {
        self.id
    }

    /// Number of devices the front drives.
    pub fn len(&self) -> usize {
        self.devices.len()
    }

    pub fn is_empty(&self) -> bool {
        self.devices.is_empty()
    }

    /// Device `device`'s route (the codec's view of it).
    pub fn route(&self, device: usize) -> &Route {
        &self.devices[device].route
    }

    /// Whether `sample` may go on to decode: `None` when another writer owns the front (the
    /// sample is refused whole and counted on every device; the writer is named once per
    /// owner), or when its writer's order or its age drops it ([`Order`]: counted on every
    /// device, logged at most once a second per reason). A refused or dropped sample
    /// refreshes nothing: not the silence, not the ownership.
    pub fn admit(&mut self, sample: &Sample<'_>, out: &mut Vec<Action>) -> Option<Admitted> {
        match self.ownership.admit(sample.writer.handle, sample.force, sample.taken) {
            Admit::Yes => self.ordered(sample, out),
            Admit::Foreign { first } => {
                out.extend((0..self.devices.len()).map(|device| Action::Count {
                    device,
                    counter: Counter::ForeignCmd,
                }));
                if first {
                    out.push(Action::Log(Log::Refused {
                        writer: sample.writer.clone(),
                        owner: self.owner.clone(),
                        hold: self.hold,
                    }));
                }
                None
            }
        }
    }

    /// [`Order`]'s word on a sample its ownership admits.
    fn ordered(&mut self, sample: &Sample<'_>, out: &mut Vec<Action>) -> Option<Admitted> {
        let checked = self.order.check(sample.writer.handle, sample.stamp, sample.taken);
        if let Some(ahead) = checked.ahead {
            out.push(Action::Log(Log::ClockAhead {
                writer: sample.writer.clone(),
                ahead,
            }));
        }
        match checked.ordered {
            Ordered::Yes => Some(Admitted(())),
            Ordered::Restarted { behind } => {
                out.push(Action::Log(Log::Restarted {
                    writer: sample.writer.clone(),
                    behind,
                    after: self.hold,
                }));
                Some(Admitted(()))
            }
            Ordered::No(why) => {
                out.extend((0..self.devices.len()).map(|device| Action::Count {
                    device,
                    counter: why.counter(),
                }));
                if let Some(suppressed) = self.rejections.admit(why.reason(), sample.taken) {
                    out.push(Action::Log(Log::Dropped {
                        writer: sample.writer.clone(),
                        why,
                        suppressed,
                    }));
                }
                None
            }
        }
    }

    /// The admitted `sample`, decoded at `now` into commands per device (or rejected whole):
    /// each command is checked against its device's table and handed to `devices`; a device
    /// that takes it arms its silence from `now` and awaits the state reflecting it. A sample
    /// at least one device took keeps or takes the front for its writer.
    ///
    /// Wait for a silence action still running on a device before handing its command here
    /// ([`Action::Safe`]).
    pub fn decoded(
        &mut self,
        _admitted: Admitted,
        now: Instant,
        sample: &Sample<'_>,
        decoded: Result<Vec<(usize, Routed)>, Rejection>,
        devices: &mut dyn Devices,
        out: &mut Vec<Action>,
    ) {
        let cmds = match decoded {
            Ok(cmds) => cmds,
            Err(r) => {
                out.extend((0..self.devices.len()).map(|device| Action::Count {
                    device,
                    counter: Counter::Rejected,
                }));
                if r.once_per_client() && self.advised.len() < MAX_ADVISED {
                    if !self.advised.contains(&sample.writer.handle) {
                        self.advised.push(sample.writer.handle);
                        out.push(Action::Log(Log::Advice {
                            writer: sample.writer.clone(),
                            why: r,
                        }));
                    }
                    return;
                }
                Self::reject(&mut self.rejections, now, Rejected::Decode(r), out);
                return;
            }
        };
        let mut any = false;
        // Devices this front now commands (another front did before).
        let mut new_commander: Vec<usize> = Vec::new();
        for (i, (body, tag, timeout_bit)) in cmds {
            let d = &mut self.devices[i];
            d.seq += 1;
            // Checked once, here, against the device's table; the device takes the checked
            // body as it is.
            let sent = d
                .route
                .device
                .checked(body)
                .map_err(DeviceError::from)
                .and_then(|body| devices.command(i, d.seq, body, tag));
            match sent {
                Ok(()) => {
                    any = true;
                    out.push(Action::Count {
                        device: i,
                        counter: Counter::Accepted,
                    });
                    if devices.mark_last_front(i, self.id) {
                        new_commander.push(i);
                    }
                    d.last_valid = Some(now);
                    d.armed = d.silence.armed(timeout_bit);
                    // No `mark_published` here: a state that came just before this command
                    // still reflects a newer command than the last published
                    // (`Prompt::ready`), and dropping it would hold it until the tick (a 1 kHz
                    // client lost one in two).
                    d.prompt.awaiting = Some(d.seq);
                    if devices.set_tripped(i, false) {
                        out.push(Action::Log(Log::Resumed { device: i }));
                    }
                    d.acted = false;
                }
                Err(e) => {
                    out.push(Action::Count {
                        device: i,
                        counter: Counter::Rejected,
                    });
                    Self::reject(&mut self.rejections, now, Rejected::Device(e), out);
                }
            }
        }
        if !any {
            return;
        }
        self.order.accepted(sample.writer.handle, sample.stamp);
        self.prompt_since = Some(now);
        if let Some(change) = self.ownership.accepted(sample.writer.handle, sample.taken) {
            out.push(Action::Log(Log::Commands {
                writer: sample.writer.clone(),
                previous: self.owner.replace(sample.writer.clone()),
                change,
            }));
            new_commander = (0..self.devices.len()).collect();
        }
        if !new_commander.is_empty() {
            out.push(Action::Owner {
                devices: new_commander,
                writer: sample.writer.clone(),
            });
        }
    }

    fn reject(log: &mut RateLimit, now: Instant, why: Rejected, out: &mut Vec<Action>) {
        if let Some(suppressed) = log.admit(why.reason(), now) {
            out.push(Action::Log(Log::Rejected { why, suppressed }));
        }
    }

    /// The earliest instant at which [`Self::deadline`] has something to do: a device's
    /// silence action, or the prompt publish giving up its wait. `None`: nothing is armed.
    pub fn next_deadline(&self) -> Option<Instant> {
        let silence = self.next_silence();
        let prompt = self
            .prompt_since
            .filter(|_| self.awaits_state())
            .map(|t| t + PROMPT_STATE_WAIT);
        silence.into_iter().chain(prompt).min()
    }

    /// The earliest silence action due (a device whose client went silent), without the
    /// prompt publish's wait: all a caller that feeds device states as they come (and so never
    /// needs the wait's end to stop listening) must wake for. `None`: nothing is armed.
    pub fn next_silence(&self) -> Option<Instant> {
        self.devices
            .iter()
            .filter_map(|d| d.silence_due().map(|(t, ..)| t))
            .min()
    }

    /// Runs what is due at `now`: each device whose client has been silent for its armed
    /// time goes to its silence action, once per silence (the next accepted command arms it
    /// again), unless another front commanded the device since (then its silence is that
    /// front's, not this one's); the prompt publish stops waiting [`PROMPT_STATE_WAIT`] after
    /// the last accepted sample.
    pub fn deadline(&mut self, now: Instant, devices: &mut dyn Devices, out: &mut Vec<Action>) {
        for (i, d) in self.devices.iter_mut().enumerate() {
            let Some((due, after, action)) = d.silence_due() else {
                continue;
            };
            if due > now {
                continue;
            }
            d.acted = true;
            // Another front commanded the device since: its silence, not ours.
            if !devices.is_last_front(i, self.id) {
                continue;
            }
            out.push(Action::Count {
                device: i,
                counter: Counter::WatchdogTrip,
            });
            devices.set_tripped(i, true);
            out.push(Action::Log(Log::Silence {
                device: i,
                mode: d.silence.mode,
                after,
                action,
            }));
            out.push(Action::Safe { device: i, action });
        }
        if self.prompt_expired(now) {
            self.stop_awaiting();
        }
    }

    /// Whether the state of device `device` is awaited (feed its states to [`Self::state`]).
    pub fn awaiting(&self, device: usize) -> bool {
        self.devices[device].prompt.awaiting.is_some()
    }

    /// Whether any device's state is awaited.
    pub fn awaits_state(&self) -> bool {
        self.devices.iter().any(|d| d.prompt.awaiting.is_some())
    }

    /// Device `device` has a new state, reflecting command `cmd_seq`, at `now`: once every
    /// device the last commands went to has a state reflecting them (or a newer command than
    /// the last published), publish at once ([`Action::Publish`]). A state of a device not
    /// awaited changes nothing.
    pub fn state(&mut self, now: Instant, device: usize, cmd_seq: u64, out: &mut Vec<Action>) {
        if !self.awaiting(device) {
            return;
        }
        self.devices[device].prompt.reflect(cmd_seq);
        if self.prompt_expired(now) {
            // Superseded by another front's command, or never applied.
            self.stop_awaiting();
        } else if self.devices.iter().all(|d| d.prompt.ready()) {
            for d in &mut self.devices {
                d.prompt.mark_published();
            }
            out.push(Action::Publish);
        }
    }

    /// A device's state channel closed: no state is awaited any more.
    pub fn state_closed(&mut self) {
        self.stop_awaiting();
    }

    /// The periodic publish went out with device `device`'s state reflecting `cmd_seq`.
    pub fn published(&mut self, device: usize, cmd_seq: u64) {
        self.devices[device].prompt.published = cmd_seq;
    }

    /// The front's queue has dropped `total` samples in all, seen at `now`: reported at most
    /// once a second, with the count since the last report.
    pub fn queue(&mut self, now: Instant, total: u64, out: &mut Vec<Action>) {
        let (reported, at) = self.dropped_reported;
        if total > reported && at.map_or(true, |t| now.saturating_duration_since(t) >= Duration::from_secs(1)) {
            out.push(Action::Log(Log::QueueFull {
                dropped: total - reported,
                total,
            }));
            self.dropped_reported = (total, Some(now));
        }
    }

    fn prompt_expired(&self, now: Instant) -> bool {
        self.prompt_since
            .is_some_and(|t| now.saturating_duration_since(t) >= PROMPT_STATE_WAIT)
    }

    fn stop_awaiting(&mut self) {
        for d in &mut self.devices {
            d.prompt.awaiting = None;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::{DeviceTable, TableOverrides};
    use crate::model::{CommandBody, DeviceKind, JointCommand, JointId, Side};

    const HOLD: Duration = Duration::from_millis(200);

    #[test]
    fn a_timer_grid_publishes_on_every_deadline_and_keeps_its_rate_when_late() {
        let t0 = Instant::now();
        let p = Duration::from_millis(2);
        let mut g = StateGrid::new(p, false, t0);
        assert!(!g.at_state(t0 + p), "device states never publish on a timer grid");
        assert_eq!(g.deadline(), t0, "the first publish is due at once");
        assert!(g.due(t0));
        assert_eq!(g.deadline(), t0 + p);
        assert!(!g.due(t0 + p / 2));
        assert!(g.due(t0 + p + p / 2), "late by half a period");
        assert_eq!(g.deadline(), t0 + 2 * p, "the grid holds");
        // A prompt publish a quarter period after the last one: too soon, the deadline
        // publishes it.
        assert!(!g.prompt(t0 + p + p / 2 + p / 4), "half a period between two publishes");
        assert_eq!(g.deadline(), t0 + 2 * p);
        // Half way through the period: it is that period's publish, sent early; the grid holds.
        assert!(g.prompt(t0 + 2 * p + p / 4));
        assert_eq!(g.deadline(), t0 + 3 * p, "a prompt publish stands in for the one due");
        assert!(!g.prompt(t0 + 2 * p + p / 2), "half a period between two publishes");
        // The publish due at 3p, a quarter period early: the 3p deadline then has nothing to do.
        assert!(g.prompt(t0 + 2 * p + 3 * p / 4));
        assert!(!g.prompt(t0 + 2 * p + 7 * p / 8), "one publish per deadline");
        assert!(!g.due(t0 + 3 * p), "its publish went out early");
        assert_eq!(g.deadline(), t0 + 4 * p, "the next deadline on the same grid");
        assert!(g.due(t0 + 20 * p), "a stall");
        assert_eq!(g.deadline(), t0 + 21 * p, "re-anchored, no burst");
        assert!(g.dropped > 0);
    }

    #[test]
    fn device_states_drive_the_grid_and_the_timer_stands_in_only_when_they_stop() {
        let t0 = Instant::now();
        let p = Duration::from_millis(2);
        let ms = Duration::from_millis(1);
        let mut g = StateGrid::new(p, true, t0);
        assert!(g.at_state(t0), "the first device state publishes at once");
        // A 1 kHz device with some jitter: one publish per 2 ms period.
        let states = [1.0, 1.9, 3.1, 3.9, 5.0, 6.05, 7.0, 7.95, 9.1, 10.0];
        let published: Vec<f64> = states
            .iter()
            .copied()
            .filter(|&ms_at| g.at_state(t0 + Duration::from_secs_f64(ms_at / 1e3)))
            .collect();
        assert_eq!(
            published,
            vec![1.9, 3.9, 6.05, 7.95, 10.0],
            "one per period, on the grid"
        );
        // While states come, the timer waits for the grace after the last one.
        assert_eq!(g.deadline(), t0 + 10 * ms + DEVICE_DRIVEN_GRACE);
        assert!(!g.due(t0 + 12 * ms), "the device drives: the timer does not publish");
        // The device stops: the timer publishes once the grace has passed, then every period.
        let stop = t0 + 10 * ms + DEVICE_DRIVEN_GRACE;
        assert!(g.due(stop));
        assert!(g.deadline() <= stop + p);
        let next = g.deadline();
        assert!(g.due(next));
        assert_eq!(g.deadline(), next + p);
        // It comes back: its states drive again.
        assert!(g.at_state(next + p));
        assert_eq!(g.deadline(), next + p + DEVICE_DRIVEN_GRACE);
    }
    /// On a slow grid (a front at 0.1 Hz) a command's state goes out at once, as that period's
    /// sample: a client never waits seconds for its command's effect.
    #[test]
    fn a_slow_grids_prompt_publish_goes_out_at_once_in_place_of_its_periods() {
        let t0 = Instant::now();
        let p = Duration::from_secs(10);
        let mut g = StateGrid::new(p, false, t0);
        assert!(g.due(t0), "the first at once");
        let s = Duration::from_secs(1);
        assert!(g.prompt(t0 + 2 * s), "2 s after the last sample");
        assert!(!g.prompt(t0 + 3 * s), "that period's sample went out");
        assert!(!g.due(t0 + p), "its deadline has nothing to do");
        assert!(g.prompt(t0 + p + s), "the next period's, early");
        assert!(
            !g.prompt(t0 + p + s + PROMPT_MIN_SPACING / 2),
            "never two within the spacing"
        );
    }

    /// Commands at any rate, each asking for a prompt publish when its state comes, never
    /// change the number of publishes: one per period (issue #37: a 100 Hz client took a
    /// 100 Hz topic to 196 Hz when each prompt publish re-anchored the grid).
    #[test]
    fn prompt_publishes_keep_the_rate_whatever_the_command_rate() {
        for (by_device, device_hz) in [(false, 0.0), (true, 500.0), (true, 1000.0)] {
            for (state_hz, cmd_hz) in [
                (100.0, 100.0),
                (100.0, 200.0),
                (500.0, 100.0),
                (500.0, 200.0),
                (500.0, 1000.0),
            ] {
                let p = Duration::from_secs_f64(1.0 / state_hz);
                let t0 = Instant::now();
                let mut g = StateGrid::new(p, by_device, t0);
                let mut published = 0u32;
                let mut spacing = Duration::MAX;
                let mut last: Option<Instant> = None;
                let mut note = |at: Instant, published: &mut u32| {
                    *published += 1;
                    if let Some(l) = last {
                        spacing = spacing.min(at - l);
                    }
                    last = Some(at);
                };
                // Events over 2 s in 10 us steps: device states, commands' prompt states (a
                // command's state arrives 0.3 ms after it), the front's timer.
                let step = Duration::from_micros(10);
                let every = |hz: f64| if hz > 0.0 { (1e5 / hz).round() as u64 } else { u64::MAX };
                let (dev_every, cmd_every) = (every(device_hz), every(cmd_hz));
                for k in 0..200_000u64 {
                    let now = t0 + step * k as u32;
                    let went = if k % cmd_every == 30 {
                        g.prompt(now)
                    } else if k % dev_every == 0 {
                        g.at_state(now)
                    } else {
                        false
                    };
                    if went || g.due(now) {
                        note(now, &mut published);
                    }
                }
                let want = (2.0 * state_hz) as u32;
                assert!(
                    published.abs_diff(want) <= 1,
                    "state {state_hz} Hz, commands {cmd_hz} Hz, device {device_hz} Hz: {published} in 2 s"
                );
                assert!(
                    spacing >= (p / 2).min(PROMPT_MIN_SPACING),
                    "{state_hz}/{cmd_hz}/{device_hz}: {spacing:?} between two publishes"
                );
            }
        }
    }

    const A: WriterHandle = 0xa;
    const B: WriterHandle = 0xb;
    const C: WriterHandle = 0xc;

    fn at(t0: Instant, ms: u64) -> Instant {
        t0 + Duration::from_millis(ms)
    }

    // -----------------------------------------------------------------------------------------
    // Ownership on its own

    #[test]
    fn the_first_accepted_writer_owns_the_front_and_others_are_refused_while_it_streams() {
        let t0 = Instant::now();
        let mut o = Ownership::new(Control::Exclusive, HOLD);
        assert_eq!(o.admit(A, false, t0), Admit::Yes);
        assert_eq!(o.accepted(A, t0), Some(Change::First));
        for k in 1..20u64 {
            let t = at(t0, 10 * k);
            assert_eq!(o.admit(A, false, t), Admit::Yes);
            assert_eq!(o.accepted(A, t), None, "the owner keeps the front");
            let first = k == 1;
            assert_eq!(o.admit(B, false, t), Admit::Foreign { first }, "at {k}");
        }
        assert_eq!(
            o.admit(C, false, at(t0, 195)),
            Admit::Foreign { first: true },
            "each refused writer is named once"
        );
    }

    #[test]
    fn a_writer_admitted_but_not_accepted_takes_nothing() {
        let t0 = Instant::now();
        let mut o = Ownership::new(Control::Exclusive, HOLD);
        // A's sample is admitted but rejected by decode: no owner yet.
        assert_eq!(o.admit(A, false, t0), Admit::Yes);
        assert_eq!(o.admit(B, false, at(t0, 1)), Admit::Yes);
        assert_eq!(o.accepted(B, at(t0, 1)), Some(Change::First));
        assert_eq!(o.admit(A, false, at(t0, 2)), Admit::Foreign { first: true });
    }

    #[test]
    fn the_front_is_free_once_the_owner_is_silent_for_the_hold_time_not_before() {
        let t0 = Instant::now();
        let mut o = Ownership::new(Control::Exclusive, HOLD);
        o.accepted(A, t0);
        assert!(matches!(o.admit(B, false, at(t0, 199)), Admit::Foreign { .. }));
        assert_eq!(o.admit(B, false, at(t0, 200)), Admit::Yes);
        assert_eq!(
            o.accepted(B, at(t0, 250)),
            Some(Change::AfterSilence {
                silent: Duration::from_millis(250)
            })
        );
        // A is now the foreign one, and named again (new owner).
        assert_eq!(o.admit(A, false, at(t0, 260)), Admit::Foreign { first: true });
        assert_eq!(o.admit(A, false, at(t0, 270)), Admit::Foreign { first: false });
    }

    #[test]
    fn the_owner_coming_back_after_its_silence_is_not_a_change() {
        let t0 = Instant::now();
        let mut o = Ownership::new(Control::Exclusive, HOLD);
        o.accepted(A, t0);
        assert_eq!(o.admit(A, false, at(t0, 5000)), Admit::Yes);
        assert_eq!(o.accepted(A, at(t0, 5000)), None);
    }

    #[test]
    fn a_forcing_writer_takes_over_a_streaming_owner() {
        let t0 = Instant::now();
        let mut o = Ownership::new(Control::Exclusive, HOLD);
        o.accepted(A, t0);
        assert_eq!(o.admit(C, true, at(t0, 10)), Admit::Yes);
        assert_eq!(o.accepted(C, at(t0, 10)), Some(Change::Forced));
        assert_eq!(o.admit(A, false, at(t0, 20)), Admit::Foreign { first: true });
        assert_eq!(o.accepted(C, at(t0, 20)), None);
    }

    #[test]
    fn shared_takes_every_writer_and_tracks_no_owner() {
        let t0 = Instant::now();
        let mut o = Ownership::new(Control::Shared, HOLD);
        for (k, w) in [A, B, A, C, B].into_iter().enumerate() {
            let t = at(t0, k as u64);
            assert_eq!(o.admit(w, false, t), Admit::Yes);
            assert_eq!(o.accepted(w, t), None);
        }
    }

    #[test]
    fn a_flood_of_writers_is_named_at_most_max_named_times() {
        let t0 = Instant::now();
        let mut o = Ownership::new(Control::Exclusive, HOLD);
        o.accepted(A, t0);
        let named = (1..=(MAX_NAMED as u64 + 50))
            .filter(|w| {
                matches!(
                    o.admit(0x1000 + w, false, at(t0, 1)),
                    Admit::Foreign { first: true, .. }
                )
            })
            .count();
        assert_eq!(named, MAX_NAMED);
    }

    // -----------------------------------------------------------------------------------------
    // The rate limit and the prompt rule on their own

    #[test]
    fn rejections_are_logged_once_per_second_per_reason_with_the_suppressed_count() {
        let mut log = RateLimit::default();
        let t0 = Instant::now();
        let ms = |n: u64| t0 + Duration::from_millis(n);
        assert_eq!(log.admit("non_finite", t0), Some(0), "the first one is logged");
        assert_eq!(log.admit("non_finite", ms(10)), None);
        assert_eq!(log.admit("non_finite", ms(999)), None);
        assert_eq!(
            log.admit("wrong_count", ms(500)),
            Some(0),
            "each reason has its own second"
        );
        assert_eq!(
            log.admit("non_finite", ms(1000)),
            Some(2),
            "a second later, with the two suppressed"
        );
        assert_eq!(log.admit("non_finite", ms(1500)), None);
        assert_eq!(log.admit("non_finite", ms(2100)), Some(1));
    }

    /// The prompt-publish rule on its own: a client streaming faster than the device applies
    /// (each state reflects an older command than the newest accepted) still gets each newer
    /// reflected command published at once, never the same one twice.
    #[test]
    fn a_state_of_a_newer_command_than_published_is_prompt_even_while_a_newer_one_is_awaited() {
        let mut p = Prompt::default();
        assert!(p.ready(), "nothing awaited");
        // A 1 kHz client: command 7 accepted while the device's states reflect older ones.
        p.awaiting = Some(7);
        p.reflect(5);
        assert!(p.ready(), "reflects 5, newer than the last published (0): at once");
        p.mark_published();
        assert!(!p.ready(), "5 is out: the same state again waits");
        p.reflect(5);
        assert!(!p.ready(), "still 5: waits for the tick");
        p.reflect(6);
        assert!(p.ready(), "6 is newer than 5");
        assert_eq!(p.awaiting, Some(7), "6 does not answer 7");
        p.mark_published();
        p.reflect(8);
        assert_eq!(
            p.awaiting, None,
            "a state of a newer command answers the awaited one too"
        );
        assert!(p.ready());
        // Awaiting 9 with nothing newer than published: not ready.
        p.mark_published();
        p.awaiting = Some(9);
        assert!(!p.ready());
        p.reflect(9);
        assert!(p.ready() && p.awaiting.is_none(), "the awaited command's own state");
    }

    // -----------------------------------------------------------------------------------------
    // The core, with a mock clock (a base Instant and offsets) and mock devices

    /// Devices as a test sees them: what each was sent, and the marks fronts share.
    #[derive(Default)]
    struct Mock {
        sent: Vec<(usize, u64, CommandBody, u32)>,
        last: Vec<Option<FrontId>>,
        tripped: Vec<bool>,
        /// Devices whose `command` fails.
        refuse: Vec<usize>,
    }

    impl Mock {
        fn new(n: usize) -> Self {
            Self {
                last: vec![None; n],
                tripped: vec![false; n],
                ..Default::default()
            }
        }
    }

    impl Devices for Mock {
        fn command(&mut self, device: usize, seq: u64, body: CheckedBody, tag: u32) -> Result<(), DeviceError> {
            if self.refuse.contains(&device) {
                return Err(DeviceError::Stopped);
            }
            self.sent.push((device, seq, body.into_body(), tag));
            Ok(())
        }
        fn is_last_front(&self, device: usize, front: FrontId) -> bool {
            self.last[device] == Some(front)
        }
        fn mark_last_front(&mut self, device: usize, front: FrontId) -> bool {
            self.last[device].replace(front) != Some(front)
        }
        fn set_tripped(&mut self, device: usize, tripped: bool) -> bool {
            std::mem::replace(&mut self.tripped[device], tripped)
        }
    }

    fn table() -> Arc<DeviceTable> {
        Arc::new(DeviceKind::Dex3.table(Side::Left, &TableOverrides::default()).unwrap())
    }

    /// A front over one device per silence plan, each front table the device's own.
    fn front(control: Control, silences: &[SilencePlan]) -> (FrontCore, Mock) {
        let t = table();
        let devices = silences
            .iter()
            .map(|s| Driven {
                route: Route::bind(t.clone(), t.clone()),
                silence: *s,
            })
            .collect();
        (
            FrontCore::new(FrontId::next(), control, HOLD, devices),
            Mock::new(silences.len()),
        )
    }

    /// The strict watchdog (`silence = "watchdog"`, the canonical front): `action` after `after`.
    fn watchdog(after: Duration, action: SafeAction) -> SilencePlan {
        SilencePlan::keeps_last_target(Silence::Watchdog, (after, action))
    }

    /// A service whose hand keeps its last target (Inspire's, BrainCo's).
    fn keeps_last_target() -> SilencePlan {
        SilencePlan::keeps_last_target(Silence::Service, (HOLD, SafeAction::Hold))
    }

    /// A service that keeps the last target unless the command set a timeout bit (the Dex3
    /// RIS bit 7: the motors go limp 1 s after it).
    fn service_with_timeout_bit() -> SilencePlan {
        SilencePlan {
            mode: Silence::Service,
            after: None,
            timeout_bit: Some((Duration::from_secs(1), SafeAction::Limp)),
        }
    }

    fn writer(handle: WriterHandle) -> Arc<WriterInfo> {
        Arc::new(WriterInfo {
            handle,
            ..WriterInfo::default()
        })
    }

    /// A command for joint 0 at `q` with `tag`, `bit`: the timeout bit.
    fn cmd(q: f32, tag: u32, bit: bool) -> Routed {
        (
            CommandBody::Joints(vec![(JointId(0), JointCommand::hold(q, 1.5, 0.1))]),
            tag,
            bit,
        )
    }

    /// One sample of `w` taken at `now` (`force`: it asks to take over), decoded as `decoded`.
    fn sample(
        core: &mut FrontCore,
        devs: &mut Mock,
        now: Instant,
        w: &Arc<WriterInfo>,
        force: bool,
        decoded: Result<Vec<(usize, Routed)>, Rejection>,
    ) -> Vec<Action> {
        let s = Sample {
            writer: w,
            force,
            taken: now,
            stamp: None,
        };
        feed(core, devs, &s, decoded)
    }

    /// Sample `s` through the core, decoded as `decoded`, at the time it was taken.
    fn feed(
        core: &mut FrontCore,
        devs: &mut Mock,
        s: &Sample<'_>,
        decoded: Result<Vec<(usize, Routed)>, Rejection>,
    ) -> Vec<Action> {
        let mut out = Vec::new();
        if let Some(admitted) = core.admit(s, &mut out) {
            core.decoded(admitted, s.taken, s, decoded, devs, &mut out);
        }
        out
    }

    /// [`sample`] of writer `w` with one command per listed device.
    fn send(core: &mut FrontCore, devs: &mut Mock, now: Instant, w: &Arc<WriterInfo>, to: &[usize]) -> Vec<Action> {
        let cmds = to.iter().map(|&i| (i, cmd(0.1, 0, false))).collect();
        sample(core, devs, now, w, false, Ok(cmds))
    }

    fn deadline(core: &mut FrontCore, devs: &mut Mock, now: Instant) -> Vec<Action> {
        let mut out = Vec::new();
        core.deadline(now, devs, &mut out);
        out
    }

    fn state(core: &mut FrontCore, now: Instant, device: usize, cmd_seq: u64) -> Vec<Action> {
        let mut out = Vec::new();
        core.state(now, device, cmd_seq, &mut out);
        out
    }

    /// The devices whose `counter` the actions bump, in order.
    fn counted(acts: &[Action], counter: Counter) -> Vec<usize> {
        acts.iter()
            .filter_map(|a| match a {
                Action::Count { device, counter: c } if *c == counter => Some(*device),
                _ => None,
            })
            .collect()
    }

    fn safes(acts: &[Action]) -> Vec<(usize, SafeAction)> {
        acts.iter()
            .filter_map(|a| match a {
                Action::Safe { device, action } => Some((*device, *action)),
                _ => None,
            })
            .collect()
    }

    fn logs(acts: &[Action]) -> Vec<&Log> {
        acts.iter()
            .filter_map(|a| match a {
                Action::Log(l) => Some(l),
                _ => None,
            })
            .collect()
    }

    fn publishes(acts: &[Action]) -> usize {
        acts.iter().filter(|a| matches!(a, Action::Publish)).count()
    }

    fn owners(acts: &[Action]) -> Vec<(Vec<usize>, WriterHandle)> {
        acts.iter()
            .filter_map(|a| match a {
                Action::Owner { devices, writer } => Some((devices.clone(), writer.handle)),
                _ => None,
            })
            .collect()
    }

    /// The device's state reflecting its last command arrives at once: the prompt publish is
    /// done, only silence deadlines remain.
    fn reflect_all(core: &mut FrontCore, now: Instant, devs: &Mock) {
        for i in 0..core.len() {
            let seq = devs.sent.iter().filter(|s| s.0 == i).map(|s| s.1).max().unwrap_or(0);
            core.state(now, i, seq, &mut Vec::new());
        }
    }

    /// safety_e2e's watchdog tests (hold, limp, open) and e2e_gateway's trip then resume, at
    /// unit level: the strict watchdog moves the device to its safe action once its client has
    /// been silent for the timeout, once per silence; the next accepted command resumes
    /// (logged, the device's trip mark cleared) and arms it again.
    #[test]
    fn the_watchdog_runs_the_devices_safe_action_once_per_silence_and_rearms_on_the_next_command() {
        for action in SafeAction::ALL {
            let (mut core, mut devs) = front(Control::Exclusive, &[watchdog(HOLD, action)]);
            let a = writer(A);
            let t0 = Instant::now();
            let acts = send(&mut core, &mut devs, t0, &a, &[0]);
            assert_eq!(counted(&acts, Counter::Accepted), vec![0]);
            assert_eq!(devs.sent.len(), 1, "the device took it");
            reflect_all(&mut core, at(t0, 1), &devs);
            assert_eq!(core.next_deadline(), Some(at(t0, 200)), "{action}");
            assert!(deadline(&mut core, &mut devs, at(t0, 199)).is_empty(), "not before");
            let acts = deadline(&mut core, &mut devs, at(t0, 200));
            assert_eq!(counted(&acts, Counter::WatchdogTrip), vec![0]);
            assert_eq!(safes(&acts), vec![(0, action)]);
            assert!(
                matches!(
                    logs(&acts)[..],
                    [Log::Silence { device: 0, mode: Silence::Watchdog, after, action: act }]
                        if *after == HOLD && *act == action
                ),
                "{acts:?}"
            );
            assert!(devs.tripped[0], "the device is marked held");
            // Once per silence.
            assert_eq!(core.next_deadline(), None);
            assert!(deadline(&mut core, &mut devs, at(t0, 5000)).is_empty());
            // Commands resume: logged once, the mark cleared, the watchdog armed again.
            let acts = send(&mut core, &mut devs, at(t0, 6000), &a, &[0]);
            assert!(matches!(logs(&acts)[..], [Log::Resumed { device: 0 }]), "{acts:?}");
            assert!(!devs.tripped[0]);
            reflect_all(&mut core, at(t0, 6001), &devs);
            assert_eq!(core.next_deadline(), Some(at(t0, 6200)));
            assert_eq!(safes(&deadline(&mut core, &mut devs, at(t0, 6200))), vec![(0, action)]);
        }
    }

    /// fronts_service's silence tests at unit level: a client sending its pose once per
    /// second trips the strict watchdog after every command, and never a service silence
    /// that keeps the last target (no action, no trip, the device never marked held).
    #[test]
    fn a_once_per_second_client_trips_the_watchdog_after_each_command_and_never_a_service_keeping_the_target() {
        for (plan, trips) in [(watchdog(HOLD, SafeAction::Hold), 5), (keeps_last_target(), 0)] {
            let (mut core, mut devs) = front(Control::Exclusive, &[plan]);
            let a = writer(A);
            let t0 = Instant::now();
            let mut acts = Vec::new();
            for k in 0..5 {
                let t = at(t0, 1000 * k);
                acts.extend(send(&mut core, &mut devs, t, &a, &[0]));
                reflect_all(&mut core, at(t0, 1000 * k + 2), &devs);
                // The task sleeps until each deadline the core names, up to the next command.
                while let Some(d) = core.next_deadline().filter(|d| *d < at(t0, 1000 * (k + 1))) {
                    acts.extend(deadline(&mut core, &mut devs, d));
                }
            }
            assert_eq!(counted(&acts, Counter::Accepted).len(), 5, "{}", plan);
            assert_eq!(counted(&acts, Counter::WatchdogTrip).len(), trips, "{}", plan);
            assert_eq!(safes(&acts).len(), trips, "{}", plan);
            let resumed = logs(&acts).iter().filter(|l| matches!(l, Log::Resumed { .. })).count();
            assert_eq!(resumed, trips.saturating_sub(1), "{}", plan);
            assert_eq!(devs.tripped[0], trips > 0, "{}", plan);
        }
    }

    /// A service that acts on silence itself (dex1_1_service brakes 1 s after the last
    /// command): `silence = "service"` with an action runs it, logged under `service`.
    #[test]
    fn a_service_that_brakes_on_silence_acts_after_its_own_time() {
        let brake = SilencePlan {
            mode: Silence::Service,
            after: Some((Duration::from_secs(1), SafeAction::Hold)),
            timeout_bit: None,
        };
        let (mut core, mut devs) = front(Control::Exclusive, &[brake]);
        let t0 = Instant::now();
        send(&mut core, &mut devs, t0, &writer(A), &[0]);
        reflect_all(&mut core, at(t0, 1), &devs);
        assert!(deadline(&mut core, &mut devs, at(t0, 999)).is_empty());
        let acts = deadline(&mut core, &mut devs, at(t0, 1000));
        assert_eq!(safes(&acts), vec![(0, SafeAction::Hold)]);
        assert!(matches!(
            logs(&acts)[..],
            [Log::Silence {
                mode: Silence::Service,
                ..
            }]
        ));
    }

    /// The Dex3 front in `service` mode: the last target is kept, except after a command that
    /// set the RIS timeout bit (limp 1 s later); a later command without the bit disarms it.
    #[test]
    fn a_service_timeout_bit_arms_its_action_only_after_a_command_that_set_it() {
        let (mut core, mut devs) = front(Control::Exclusive, &[service_with_timeout_bit()]);
        let a = writer(A);
        let t0 = Instant::now();
        sample(&mut core, &mut devs, t0, &a, false, Ok(vec![(0, cmd(0.1, 0, false))]));
        reflect_all(&mut core, at(t0, 1), &devs);
        assert_eq!(core.next_deadline(), None, "no bit: the last target is kept");
        assert!(deadline(&mut core, &mut devs, at(t0, 60_000)).is_empty());

        let t1 = at(t0, 100_000);
        sample(&mut core, &mut devs, t1, &a, false, Ok(vec![(0, cmd(0.1, 0, true))]));
        reflect_all(&mut core, at(t0, 100_001), &devs);
        assert_eq!(core.next_deadline(), Some(t1 + Duration::from_secs(1)));
        let acts = deadline(&mut core, &mut devs, t1 + Duration::from_secs(1));
        assert_eq!(safes(&acts), vec![(0, SafeAction::Limp)]);

        // With the bit, then without: disarmed.
        let t2 = at(t0, 200_000);
        sample(&mut core, &mut devs, t2, &a, false, Ok(vec![(0, cmd(0.1, 0, true))]));
        sample(
            &mut core,
            &mut devs,
            at(t0, 200_010),
            &a,
            false,
            Ok(vec![(0, cmd(0.1, 0, false))]),
        );
        reflect_all(&mut core, at(t0, 200_011), &devs);
        assert_eq!(core.next_deadline(), None);
        assert!(deadline(&mut core, &mut devs, at(t0, 300_000)).is_empty());
    }

    /// `SilencePlan::armed` through the core: the Dex3 front in `watchdog` mode takes the
    /// earlier of the watchdog and the timeout bit's action.
    #[test]
    fn the_watchdog_with_a_timeout_bit_takes_the_earlier_of_the_two() {
        let plan = SilencePlan {
            mode: Silence::Watchdog,
            after: Some((Duration::from_secs(2), SafeAction::Hold)),
            timeout_bit: Some((Duration::from_secs(1), SafeAction::Limp)),
        };
        for (bit, due, action) in [(true, 1000, SafeAction::Limp), (false, 2000, SafeAction::Hold)] {
            let (mut core, mut devs) = front(Control::Exclusive, &[plan]);
            let t0 = Instant::now();
            sample(
                &mut core,
                &mut devs,
                t0,
                &writer(A),
                false,
                Ok(vec![(0, cmd(0.1, 0, bit))]),
            );
            reflect_all(&mut core, at(t0, 1), &devs);
            assert_eq!(core.next_deadline(), Some(at(t0, due)), "bit {bit}");
            assert_eq!(safes(&deadline(&mut core, &mut devs, at(t0, due))), vec![(0, action)]);
        }
    }

    /// docs/fronts.md "Silence": a front acts only when the device's last command was its
    /// own. Another front that commanded the device since owns its silence: no action, no
    /// trip; this front's next command takes the device back and arms it again.
    #[test]
    fn another_front_commanding_the_device_since_owns_its_silence() {
        let (mut core, mut devs) = front(Control::Exclusive, &[watchdog(HOLD, SafeAction::Hold)]);
        let a = writer(A);
        let t0 = Instant::now();
        let acts = send(&mut core, &mut devs, t0, &a, &[0]);
        assert_eq!(owners(&acts), vec![(vec![0], A)], "first owner, named");
        reflect_all(&mut core, at(t0, 1), &devs);
        // Another front's command reaches the device.
        devs.last[0] = Some(FrontId::next());
        let acts = deadline(&mut core, &mut devs, at(t0, 200));
        assert!(acts.is_empty(), "{acts:?}");
        assert!(!devs.tripped[0]);
        assert_eq!(core.next_deadline(), None, "this silence is over for this front");
        // This front's next command: the device is its again (named), and armed.
        let acts = send(&mut core, &mut devs, at(t0, 1000), &a, &[0]);
        assert_eq!(owners(&acts), vec![(vec![0], A)]);
        reflect_all(&mut core, at(t0, 1001), &devs);
        assert_eq!(
            safes(&deadline(&mut core, &mut devs, at(t0, 1200))),
            vec![(0, SafeAction::Hold)]
        );
    }

    /// A silence action another front ran on the device ends with this front's accepted
    /// command: logged as resumed here, the mark cleared (status stops showing `safe`).
    #[test]
    fn a_command_resumes_a_device_another_fronts_silence_holds() {
        let (mut core, mut devs) = front(Control::Exclusive, &[keeps_last_target()]);
        devs.tripped[0] = true;
        let acts = send(&mut core, &mut devs, Instant::now(), &writer(A), &[0]);
        assert!(matches!(logs(&acts)[..], [Log::Resumed { device: 0 }, ..]), "{acts:?}");
        assert!(!devs.tripped[0]);
    }

    /// A front over two devices (the actuator Dex1 front): each has its own silence, timed
    /// from its own last command.
    #[test]
    fn each_device_of_a_front_has_its_own_silence() {
        let dog = watchdog(HOLD, SafeAction::Hold);
        let (mut core, mut devs) = front(Control::Exclusive, &[dog, dog]);
        let a = writer(A);
        let t0 = Instant::now();
        send(&mut core, &mut devs, t0, &a, &[0, 1]);
        send(&mut core, &mut devs, at(t0, 100), &a, &[0]);
        reflect_all(&mut core, at(t0, 101), &devs);
        assert_eq!(core.next_deadline(), Some(at(t0, 200)));
        assert_eq!(
            safes(&deadline(&mut core, &mut devs, at(t0, 200))),
            vec![(1, SafeAction::Hold)]
        );
        assert_eq!(core.next_deadline(), Some(at(t0, 300)));
        assert_eq!(
            safes(&deadline(&mut core, &mut devs, at(t0, 300))),
            vec![(0, SafeAction::Hold)]
        );
    }

    /// control_e2e's first test at unit level: the first writer owns the front (logged, named
    /// as who commands every device); another writer's samples are refused whole while it
    /// streams, counted on every device and named once with the owner, and refresh nothing;
    /// once the owner has been silent for the hold time the other takes over, logged with how
    /// long the owner was silent.
    #[test]
    fn the_first_writer_owns_the_front_and_another_is_refused_named_once_until_the_owner_is_silent() {
        let dog = watchdog(Duration::from_secs(5), SafeAction::Hold);
        let (mut core, mut devs) = front(Control::Exclusive, &[dog, dog]);
        let (a, b) = (writer(A), writer(B));
        let t0 = Instant::now();
        let acts = send(&mut core, &mut devs, t0, &a, &[0, 1]);
        assert!(
            matches!(logs(&acts)[..], [Log::Commands { writer, previous: None, change: Change::First }] if writer.handle == A),
            "{acts:?}"
        );
        assert_eq!(owners(&acts), vec![(vec![0, 1], A)]);
        let mut named = 0;
        for k in 1..10u64 {
            send(&mut core, &mut devs, at(t0, 20 * k), &a, &[0, 1]);
            let acts = send(&mut core, &mut devs, at(t0, 20 * k + 5), &b, &[0, 1]);
            assert_eq!(
                counted(&acts, Counter::ForeignCmd),
                vec![0, 1],
                "counted on every device"
            );
            assert_eq!(counted(&acts, Counter::Accepted), Vec::<usize>::new());
            for l in logs(&acts) {
                match l {
                    Log::Refused { writer, owner, hold } => {
                        assert_eq!(
                            (writer.handle, owner.as_ref().map(|o| o.handle), *hold),
                            (B, Some(A), HOLD)
                        );
                        named += 1;
                    }
                    other => panic!("{other:?}"),
                }
            }
        }
        assert_eq!(named, 1, "named once");
        assert_eq!(devs.sent.len(), 20, "only A's commands reached the devices");
        // A refused sample refreshes nothing: the silence still runs from A's last command.
        let last_a = at(t0, 180);
        reflect_all(&mut core, at(t0, 186), &devs);
        assert_eq!(core.next_deadline(), Some(last_a + Duration::from_secs(5)));
        // A stops; B takes over once A has been silent for the hold time, not before.
        let acts = send(&mut core, &mut devs, last_a + HOLD - Duration::from_millis(1), &b, &[0]);
        assert_eq!(counted(&acts, Counter::ForeignCmd), vec![0, 1]);
        let acts = send(&mut core, &mut devs, last_a + HOLD + Duration::from_millis(1), &b, &[0]);
        assert!(
            matches!(
                logs(&acts)[..],
                [Log::Commands { writer, previous: Some(p), change: Change::AfterSilence { silent } }]
                    if writer.handle == B && p.handle == A && *silent == HOLD + Duration::from_millis(1)
            ),
            "{acts:?}"
        );
        assert_eq!(
            owners(&acts),
            vec![(vec![0, 1], B)],
            "every device named, not only the commanded one"
        );
        // A is the refused one now, named again.
        let acts = send(
            &mut core,
            &mut devs,
            last_a + HOLD + Duration::from_millis(10),
            &a,
            &[0],
        );
        assert!(matches!(logs(&acts)[..], [Log::Refused { writer, .. }] if writer.handle == A));
    }

    /// control_e2e's `--force` test at unit level: a forcing writer is never refused and takes
    /// the front over from a streaming owner, which is refused from then on.
    #[test]
    fn a_forcing_writer_takes_the_front_over_from_a_streaming_owner() {
        let (mut core, mut devs) = front(Control::Exclusive, &[watchdog(HOLD, SafeAction::Hold)]);
        let (a, c) = (writer(A), writer(C));
        let t0 = Instant::now();
        send(&mut core, &mut devs, t0, &a, &[0]);
        let acts = sample(
            &mut core,
            &mut devs,
            at(t0, 10),
            &c,
            true,
            Ok(vec![(0, cmd(0.8, 0, false))]),
        );
        assert!(
            matches!(logs(&acts)[..], [Log::Commands { writer, previous: Some(p), change: Change::Forced }] if writer.handle == C && p.handle == A),
            "{acts:?}"
        );
        assert_eq!(owners(&acts), vec![(vec![0], C)]);
        let acts = send(&mut core, &mut devs, at(t0, 20), &a, &[0]);
        assert_eq!(counted(&acts, Counter::ForeignCmd), vec![0]);
    }

    /// control_e2e's shared test at unit level: every writer's commands reach the device, no
    /// one is refused, no hand-over is logged; the device is named once, when this front
    /// first commands it.
    #[test]
    fn shared_control_takes_every_writers_commands() {
        let (mut core, mut devs) = front(Control::Shared, &[watchdog(HOLD, SafeAction::Hold)]);
        let t0 = Instant::now();
        let mut acts = Vec::new();
        for (k, w) in [A, B, A, C, B].into_iter().enumerate() {
            acts.extend(send(&mut core, &mut devs, at(t0, k as u64), &writer(w), &[0]));
        }
        assert_eq!(counted(&acts, Counter::Accepted).len(), 5);
        assert_eq!(counted(&acts, Counter::ForeignCmd).len(), 0);
        assert!(logs(&acts).is_empty(), "{acts:?}");
        assert_eq!(owners(&acts), vec![(vec![0], A)]);
    }

    /// docs/fronts.md "Bad input" and safety_e2e's rejection: a sample the decode rejects is
    /// counted on every device, logged at most once a second per reason with the count of
    /// those suppressed, moves nothing and takes no ownership. A body the device's table
    /// refuses, or a device that refuses its command, is counted on that device and logged
    /// as `device_rejected`; the command's seq is used up.
    #[test]
    fn a_mistake_a_client_repeats_is_said_once_per_client_and_every_sample_counted() {
        let (mut core, mut devs) = front(Control::Exclusive, &[keeps_last_target()]);
        let (a, b) = (writer(A), writer(B));
        let t0 = Instant::now();
        let advised = |acts: &[Action]| -> Vec<WriterHandle> {
            logs(acts)
                .iter()
                .filter_map(|l| match l {
                    Log::Advice { writer, why } => {
                        assert_eq!(why.reason(), "mode_unset");
                        Some(writer.handle)
                    }
                    Log::Rejected { .. } => panic!("a repeated mistake is not in the per-second log"),
                    _ => None,
                })
                .collect()
        };
        let unset = || Err(Rejection::ModeUnset { index: 1 });
        let mut told = Vec::new();
        for k in 0..5000u64 {
            let w = if k % 2 == 0 { &a } else { &b };
            let acts = sample(&mut core, &mut devs, at(t0, k), w, false, unset());
            assert_eq!(counted(&acts, Counter::Rejected), vec![0], "every sample counted");
            told.extend(advised(&acts));
        }
        assert_eq!(told, vec![A, B], "once per client over 5 s");
        assert!(devs.sent.is_empty());
    }

    #[test]
    fn rejected_commands_are_counted_logged_once_a_second_per_reason_and_take_nothing() {
        let (mut core, mut devs) = front(Control::Exclusive, &[keeps_last_target(), keeps_last_target()]);
        let (a, b) = (writer(A), writer(B));
        let t0 = Instant::now();
        let rejected = |acts: &[Action]| -> Vec<(&'static str, u64)> {
            logs(acts)
                .iter()
                .filter_map(|l| match l {
                    Log::Rejected { why, suppressed } => Some((why.reason(), *suppressed)),
                    _ => None,
                })
                .collect()
        };
        let bad = |core: &mut FrontCore, devs: &mut Mock, ms: u64, r: Rejection| {
            sample(core, devs, at(t0, ms), &a, false, Err(r))
        };
        let acts = bad(&mut core, &mut devs, 0, Rejection::NonFinite(2));
        assert_eq!(counted(&acts, Counter::Rejected), vec![0, 1]);
        assert_eq!(rejected(&acts), vec![("non_finite", 0)]);
        assert_eq!(
            rejected(&bad(&mut core, &mut devs, 10, Rejection::NonFinite(2))),
            vec![]
        );
        assert_eq!(
            rejected(&bad(
                &mut core,
                &mut devs,
                20,
                Rejection::WrongCount { got: 3, want: 7 }
            )),
            vec![("wrong_count", 0)]
        );
        assert_eq!(
            rejected(&bad(&mut core, &mut devs, 1000, Rejection::NonFinite(0))),
            vec![("non_finite", 1)]
        );
        assert!(devs.sent.is_empty());
        assert_eq!(core.next_deadline(), None, "nothing accepted, nothing awaited");

        // The device's table refuses a non-finite closure; the device itself refuses too.
        let nan = (
            CommandBody::Closure {
                closure: f32::NAN,
                stiffness: None,
            },
            0,
            false,
        );
        let acts = sample(&mut core, &mut devs, at(t0, 1100), &a, false, Ok(vec![(0, nan)]));
        assert_eq!(counted(&acts, Counter::Rejected), vec![0]);
        assert_eq!(rejected(&acts), vec![("device_rejected", 0)]);
        devs.refuse = vec![1];
        let acts = send(&mut core, &mut devs, at(t0, 1200), &a, &[1]);
        assert_eq!(counted(&acts, Counter::Rejected), vec![1]);
        assert_eq!(rejected(&acts), vec![], "within the second of the last device_rejected");
        assert!(devs.sent.is_empty() && owners(&acts).is_empty());

        // Nothing was accepted: A owns nothing, B takes the front at once.
        devs.refuse.clear();
        let acts = send(&mut core, &mut devs, at(t0, 1300), &b, &[0]);
        assert!(matches!(
            logs(&acts)[..],
            [Log::Commands {
                change: Change::First,
                ..
            }]
        ));
        assert_eq!(devs.sent[0].1, 2, "seq 1 went to the refused closure");
    }

    /// safety_e2e's prompt tests at unit level: after an accepted command the state
    /// reflecting it is published at once (not at the next tick), on a front over two devices
    /// once BOTH reflect it; the periodic publish resets what was published.
    #[test]
    fn the_state_reflecting_an_accepted_command_is_published_at_once_once_every_device_reflects_it() {
        let (mut core, mut devs) = front(Control::Exclusive, &[keeps_last_target(), keeps_last_target()]);
        let t0 = Instant::now();
        assert!(!core.awaits_state());
        sample(
            &mut core,
            &mut devs,
            t0,
            &writer(A),
            false,
            Ok(vec![(0, cmd(0.5, 5151, false)), (1, cmd(0.5, 5151, false))]),
        );
        assert!(core.awaiting(0) && core.awaiting(1));
        assert_eq!(core.next_deadline(), Some(t0 + PROMPT_STATE_WAIT));
        assert_eq!(publishes(&state(&mut core, at(t0, 1), 0, 0)), 0, "an older state");
        assert_eq!(publishes(&state(&mut core, at(t0, 2), 0, 1)), 0, "one hand reflects it");
        assert!(!core.awaiting(0) && core.awaiting(1));
        assert_eq!(publishes(&state(&mut core, at(t0, 3), 1, 1)), 1, "both do");
        assert!(!core.awaits_state());
        assert_eq!(core.next_deadline(), None);
        assert!(
            state(&mut core, at(t0, 4), 1, 1).is_empty(),
            "nothing awaited: nothing more"
        );

        // The periodic publish went out with the state of command 1; command 2's state is
        // prompt again.
        core.published(0, 1);
        core.published(1, 1);
        send(&mut core, &mut devs, at(t0, 10), &writer(A), &[0]);
        assert_eq!(publishes(&state(&mut core, at(t0, 11), 0, 1)), 0, "1 is out already");
        assert_eq!(publishes(&state(&mut core, at(t0, 12), 0, 2)), 1);
    }

    /// The 1 kHz client through the core: commands every millisecond, the device applying
    /// each 3 ms late. Every state that reflects a newer command than the last published goes
    /// out at once, none twice.
    #[test]
    fn a_client_streaming_faster_than_the_device_applies_sees_each_newer_state_at_once() {
        let (mut core, mut devs) = front(Control::Exclusive, &[keeps_last_target()]);
        let a = writer(A);
        let t0 = Instant::now();
        let mut published = 0;
        for k in 1..=50u64 {
            send(&mut core, &mut devs, at(t0, k), &a, &[0]);
            // The device's state of command k - 3 arrives, twice (its own rate is higher).
            for _ in 0..2 {
                if core.awaiting(0) && k > 3 {
                    published += publishes(&state(&mut core, at(t0, k), 0, k - 3));
                }
            }
        }
        assert_eq!(published, 47, "commands 1..=47 reflected, each published once");
    }

    /// The prompt publish gives up PROMPT_STATE_WAIT after the accepted sample (superseded by
    /// another front's command, or never applied): at its deadline, or when a late state
    /// comes first.
    #[test]
    fn the_prompt_publish_stops_waiting_after_prompt_state_wait() {
        let (mut core, mut devs) = front(Control::Exclusive, &[keeps_last_target()]);
        let a = writer(A);
        let t0 = Instant::now();
        send(&mut core, &mut devs, t0, &a, &[0]);
        assert_eq!(core.next_deadline(), Some(t0 + PROMPT_STATE_WAIT));
        assert!(deadline(&mut core, &mut devs, t0 + PROMPT_STATE_WAIT - Duration::from_millis(1)).is_empty());
        assert!(core.awaiting(0));
        assert!(deadline(&mut core, &mut devs, t0 + PROMPT_STATE_WAIT).is_empty());
        assert!(!core.awaiting(0), "given up at the deadline");
        assert_eq!(core.next_deadline(), None);
        assert!(state(&mut core, at(t0, 150), 0, 1).is_empty());

        // A late state before the deadline was handled: given up, nothing published.
        let t1 = at(t0, 1000);
        send(&mut core, &mut devs, t1, &a, &[0]);
        let acts = state(&mut core, t1 + PROMPT_STATE_WAIT + Duration::from_millis(20), 0, 2);
        assert_eq!(publishes(&acts), 0);
        assert!(!core.awaits_state());

        // A device's state channel closed: nothing awaited.
        send(&mut core, &mut devs, at(t0, 2000), &a, &[0]);
        core.state_closed();
        assert!(!core.awaits_state());
    }

    /// The next deadline is the earliest of every device's silence and the prompt's wait.
    #[test]
    fn the_next_deadline_is_the_earliest_silence_or_prompt_wait() {
        let (mut core, mut devs) = front(
            Control::Exclusive,
            &[
                watchdog(Duration::from_millis(300), SafeAction::Hold),
                watchdog(Duration::from_millis(50), SafeAction::Hold),
            ],
        );
        let t0 = Instant::now();
        assert_eq!(core.next_deadline(), None);
        send(&mut core, &mut devs, t0, &writer(A), &[0]);
        assert_eq!(core.next_deadline(), Some(t0 + PROMPT_STATE_WAIT));
        send(&mut core, &mut devs, at(t0, 10), &writer(A), &[1]);
        assert_eq!(core.next_deadline(), Some(at(t0, 60)));
        reflect_all(&mut core, at(t0, 11), &devs);
        assert_eq!(core.next_deadline(), Some(at(t0, 60)));
        deadline(&mut core, &mut devs, at(t0, 60));
        assert_eq!(core.next_deadline(), Some(at(t0, 300)));
    }

    /// "front queue full" at most once a second, with the samples dropped since the last
    /// report and the total.
    #[test]
    fn a_full_queue_is_reported_at_most_once_a_second_with_the_count_since() {
        let (mut core, _) = front(Control::Exclusive, &[keeps_last_target()]);
        let t0 = Instant::now();
        let q = |core: &mut FrontCore, ms, total| {
            let mut out = Vec::new();
            core.queue(at(t0, ms), total, &mut out);
            logs(&out)
                .iter()
                .map(|l| match l {
                    Log::QueueFull { dropped, total } => (*dropped, *total),
                    other => panic!("{other:?}"),
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(q(&mut core, 0, 0), vec![], "nothing dropped");
        assert_eq!(q(&mut core, 10, 3), vec![(3, 3)]);
        assert_eq!(q(&mut core, 500, 5), vec![]);
        assert_eq!(q(&mut core, 1010, 5), vec![(2, 5)]);
        assert_eq!(q(&mut core, 3000, 5), vec![], "nothing new");
        assert_eq!(q(&mut core, 3001, 6), vec![(1, 6)]);
    }

    // -----------------------------------------------------------------------------------------
    // Commands in order: a mock wall clock (ns since the epoch) beside the mock Instant clock

    /// The mock wall clock's origin, ns since the UNIX epoch (2027-01-15): `t0` of a test is
    /// this instant by this host's clock.
    const WALL: i64 = 1_800_000_000_000_000_000;
    const MS: i64 = 1_000_000;

    /// A sample written at `written` ms by its writer's clock, taken at `taken` ms by ours.
    fn stamp(written: i64, taken: u64) -> Option<Stamp> {
        Some(Stamp {
            written_ns: WALL + written * MS,
            taken_ns: WALL + taken as i64 * MS,
        })
    }

    /// One sample of `w` commanding device 0 to `q`, written at `written` ms by its clock and
    /// taken at `t0 + taken` ms (`stamp`: `None` for a sample without a source timestamp).
    fn stamped(
        core: &mut FrontCore,
        devs: &mut Mock,
        t0: Instant,
        w: &Arc<WriterInfo>,
        stamp: Option<Stamp>,
        taken: u64,
        q: f32,
    ) -> Vec<Action> {
        let s = Sample {
            writer: w,
            force: false,
            taken: at(t0, taken),
            stamp,
        };
        feed(core, devs, &s, Ok(vec![(0, cmd(q, 0, false))]))
    }

    /// The targets the devices took, in order (joint 0's q of each command).
    fn taken_q(devs: &Mock) -> Vec<f32> {
        devs.sent
            .iter()
            .map(|(_, _, body, _)| match body {
                CommandBody::Joints(j) => j[0].1.q,
                other => panic!("{other:?}"),
            })
            .collect()
    }

    fn dropped(acts: &[Action]) -> Vec<(WriterHandle, Dropped, u64)> {
        logs(acts)
            .iter()
            .filter_map(|l| match l {
                Log::Dropped {
                    writer,
                    why,
                    suppressed,
                } => Some((writer.handle, *why, *suppressed)),
                _ => None,
            })
            .collect()
    }

    /// Per writer, a command whose source timestamp is not newer than the last one accepted
    /// from it is dropped whole: equal, a duplicate; older, reordered. Counted on every device
    /// of the front, logged at most once a second per reason; it moves nothing and refreshes
    /// nothing (the silence still runs from the last accepted command). The hand ends at the
    /// newest target.
    #[test]
    fn in_order_commands_are_taken_and_duplicates_and_reordered_ones_dropped_counted_and_logged() {
        let dog = watchdog(HOLD, SafeAction::Hold);
        let (mut core, mut devs) = front(Control::Exclusive, &[dog, dog]);
        let a = writer(A);
        let t0 = Instant::now();
        let mut send =
            |written: i64, taken: u64, q: f32| stamped(&mut core, &mut devs, t0, &a, stamp(written, taken), taken, q);
        assert_eq!(counted(&send(10, 11, 0.1), Counter::Accepted), vec![0]);
        assert_eq!(counted(&send(30, 31, 0.3), Counter::Accepted), vec![0]);
        let acts = send(20, 32, 0.2);
        assert_eq!(counted(&acts, Counter::Reordered), vec![0, 1], "on every device");
        assert_eq!(counted(&acts, Counter::Accepted), Vec::<usize>::new());
        assert_eq!(
            dropped(&acts),
            vec![(
                A,
                Dropped::Reordered {
                    behind: Duration::from_millis(10)
                },
                0
            )]
        );
        let acts = send(30, 33, 0.9);
        assert_eq!(counted(&acts, Counter::Duplicate), vec![0, 1]);
        assert_eq!(dropped(&acts), vec![(A, Dropped::Duplicate, 0)]);
        assert_eq!(counted(&send(40, 34, 0.4), Counter::Accepted), vec![0]);
        // Within the second: counted, not logged; a second later, logged with the suppressed.
        for k in 0..3 {
            let acts = send(40, 40 + k, 0.9);
            assert_eq!(counted(&acts, Counter::Duplicate), vec![0, 1]);
            assert!(dropped(&acts).is_empty(), "{acts:?}");
        }
        assert!(
            dropped(&send(39, 60, 0.9)).is_empty(),
            "within the second of the last reordered"
        );
        // A lone old copy long after: still reordered (not a clock stepped back).
        assert_eq!(dropped(&send(40, 1040, 0.9)), vec![(A, Dropped::Duplicate, 3)]);
        assert_eq!(
            dropped(&send(39, 1041, 0.9)),
            vec![(
                A,
                Dropped::Reordered {
                    behind: Duration::from_millis(1)
                },
                1
            )]
        );
        assert_eq!(taken_q(&devs), vec![0.1, 0.3, 0.4], "the newest target last");
        // Nothing dropped refreshes the silence (a front of its own: the silence runs from the
        // command taken at 0 ms, through a copy at 150 ms and an older one at 160 ms).
        let (mut core, mut devs) = front(Control::Exclusive, &[dog, dog]);
        stamped(&mut core, &mut devs, t0, &a, stamp(10, 0), 0, 0.1);
        reflect_all(&mut core, at(t0, 1), &devs);
        stamped(&mut core, &mut devs, t0, &a, stamp(10, 150), 150, 0.2);
        stamped(&mut core, &mut devs, t0, &a, stamp(5, 160), 160, 0.2);
        assert_eq!(core.next_deadline(), Some(at(t0, 200)));
        assert_eq!(
            safes(&deadline(&mut core, &mut devs, at(t0, 200))),
            vec![(0, SafeAction::Hold)]
        );
    }

    /// Each writer has its own order: two writers interleaved on a shared front, each in
    /// order by its own clock (B's a second behind A's), are all taken; each one's copies are
    /// dropped against its own last.
    #[test]
    fn two_writers_interleaved_each_in_order_are_all_taken() {
        let (mut core, mut devs) = front(Control::Shared, &[keeps_last_target()]);
        let (a, b) = (writer(A), writer(B));
        let t0 = Instant::now();
        let mut acts = Vec::new();
        for k in 0..5u64 {
            let ms = 10 * k as i64;
            acts.extend(stamped(
                &mut core,
                &mut devs,
                t0,
                &a,
                stamp(1000 + ms, 2 * k),
                2 * k,
                0.1,
            ));
            acts.extend(stamped(
                &mut core,
                &mut devs,
                t0,
                &b,
                stamp(ms, 2 * k + 1),
                2 * k + 1,
                0.2,
            ));
        }
        assert_eq!(counted(&acts, Counter::Accepted).len(), 10, "{acts:?}");
        assert!(dropped(&acts).is_empty());
        let acts = stamped(&mut core, &mut devs, t0, &b, stamp(40, 20), 20, 0.2);
        assert_eq!(counted(&acts, Counter::Duplicate), vec![0]);
        let acts = stamped(&mut core, &mut devs, t0, &a, stamp(1039, 21), 21, 0.1);
        assert_eq!(counted(&acts, Counter::Reordered), vec![0]);
    }

    /// Owner hand-over: a new owner is judged by its own stamps only (its clock far behind the
    /// old owner's), so its first command is taken; the old owner's samples meanwhile are
    /// foreign, not out of order; once the new owner is silent, the old one's next newer
    /// command is taken, and one older than its own last is still dropped.
    #[test]
    fn a_new_owners_first_command_is_taken_whatever_the_old_owners_stamps() {
        let (mut core, mut devs) = front(Control::Exclusive, &[keeps_last_target()]);
        let (a, b) = (writer(A), writer(B));
        let t0 = Instant::now();
        for k in 0..5u64 {
            stamped(
                &mut core,
                &mut devs,
                t0,
                &a,
                stamp(60_000 + 10 * k as i64, 10 * k),
                10 * k,
                0.1,
            );
        }
        // A silent from 40 ms; B, its clock a minute behind A's, after the hold time.
        let acts = stamped(&mut core, &mut devs, t0, &b, stamp(300, 300), 300, 0.2);
        assert_eq!(counted(&acts, Counter::Accepted), vec![0]);
        assert!(
            matches!(
                logs(&acts)[..],
                [Log::Commands {
                    change: Change::AfterSilence { .. },
                    ..
                }]
            ),
            "{acts:?}"
        );
        stamped(&mut core, &mut devs, t0, &b, stamp(310, 310), 310, 0.3);
        let acts = stamped(&mut core, &mut devs, t0, &a, stamp(60_050, 315), 315, 0.9);
        assert_eq!(counted(&acts, Counter::ForeignCmd), vec![0]);
        assert_eq!(counted(&acts, Counter::Reordered), Vec::<usize>::new());
        // B silent from 310 ms: A again, newer than its own last, then older.
        let acts = stamped(&mut core, &mut devs, t0, &a, stamp(60_600, 600), 600, 0.4);
        assert_eq!(counted(&acts, Counter::Accepted), vec![0]);
        let acts = stamped(&mut core, &mut devs, t0, &a, stamp(60_030, 601), 601, 0.9);
        assert_eq!(counted(&acts, Counter::Reordered), vec![0]);
        assert_eq!(taken_q(&devs), vec![0.1, 0.1, 0.1, 0.1, 0.1, 0.2, 0.3, 0.4]);
    }

    /// A client that restarts has a new publication handle: a new writer, whose stamps are
    /// not compared with the old one's (here its first repeats the old writer's last).
    #[test]
    fn a_restarted_writer_is_a_new_writer() {
        let (mut core, mut devs) = front(Control::Exclusive, &[keeps_last_target()]);
        let (old, new) = (writer(A), writer(0xd));
        let t0 = Instant::now();
        stamped(&mut core, &mut devs, t0, &old, stamp(500, 0), 0, 0.1);
        stamped(&mut core, &mut devs, t0, &old, stamp(510, 10), 10, 0.2);
        let acts = stamped(&mut core, &mut devs, t0, &new, stamp(510, 400), 400, 0.3);
        assert_eq!(counted(&acts, Counter::Accepted), vec![0], "{acts:?}");
        let acts = stamped(&mut core, &mut devs, t0, &new, stamp(510, 401), 401, 0.9);
        assert_eq!(counted(&acts, Counter::Duplicate), vec![0], "its own copy is one");
        assert_eq!(taken_q(&devs), vec![0.1, 0.2, 0.3]);
    }

    /// `max_command_age_ms`: a command older than that on arrival is dropped and counted
    /// late (logged with its age); one exactly that old is taken. Without the key, the same
    /// command is taken.
    #[test]
    fn a_command_older_than_max_command_age_is_dropped_as_late_only_with_the_key() {
        let t0 = Instant::now();
        let a = writer(A);
        let max = Duration::from_millis(100);
        let (core, mut devs) = front(Control::Exclusive, &[keeps_last_target(), keeps_last_target()]);
        let mut core = core.with_max_command_age(Some(max));
        let acts = stamped(&mut core, &mut devs, t0, &a, stamp(0, 50), 50, 0.1);
        assert_eq!(counted(&acts, Counter::Accepted), vec![0]);
        let acts = stamped(&mut core, &mut devs, t0, &a, stamp(100, 200), 200, 0.2);
        assert_eq!(counted(&acts, Counter::Accepted), vec![0], "exactly max old: taken");
        let acts = stamped(&mut core, &mut devs, t0, &a, stamp(110, 261), 261, 0.9);
        assert_eq!(counted(&acts, Counter::Late), vec![0, 1], "on every device");
        assert_eq!(
            dropped(&acts),
            vec![(
                A,
                Dropped::Late {
                    age: Duration::from_millis(151),
                    max
                },
                0
            )]
        );
        assert_eq!(taken_q(&devs), vec![0.1, 0.2]);
        // A late command is not the writer's last: a newer, fresh one is taken.
        let acts = stamped(&mut core, &mut devs, t0, &a, stamp(105, 262), 262, 0.3);
        assert_eq!(counted(&acts, Counter::Late), vec![0, 1]);
        let acts = stamped(&mut core, &mut devs, t0, &a, stamp(250, 263), 263, 0.4);
        assert_eq!(counted(&acts, Counter::Accepted), vec![0]);

        let (mut core, mut devs) = front(Control::Exclusive, &[keeps_last_target()]);
        let acts = stamped(&mut core, &mut devs, t0, &a, stamp(110, 10_000), 10_000, 0.9);
        assert_eq!(counted(&acts, Counter::Accepted), vec![0], "no key: no age limit");
        assert!(logs(&acts).iter().all(|l| !matches!(l, Log::ClockAhead { .. })));
    }

    /// A writer whose clock runs ahead of ours (a negative age beyond the tolerance): named
    /// once in the log (at most one such line a second over all writers), none of its
    /// commands dropped as late, even one whose age later comes out past the maximum. A
    /// writer within the tolerance is neither named nor spared. Without the key, nothing is
    /// named.
    #[test]
    fn a_writer_whose_clock_runs_ahead_is_named_once_and_never_late() {
        let t0 = Instant::now();
        let (a, b, c) = (writer(A), writer(B), writer(C));
        let max = Duration::from_millis(100);
        let (core, mut devs) = front(Control::Shared, &[keeps_last_target()]);
        let mut core = core.with_max_command_age(Some(max));
        let ahead = |acts: &[Action]| -> Vec<(WriterHandle, Duration)> {
            logs(acts)
                .iter()
                .filter_map(|l| match l {
                    Log::ClockAhead { writer, ahead } => Some((writer.handle, *ahead)),
                    _ => None,
                })
                .collect()
        };
        let acts = stamped(&mut core, &mut devs, t0, &a, stamp(60, 10), 10, 0.1);
        assert_eq!(counted(&acts, Counter::Accepted), vec![0]);
        assert_eq!(ahead(&acts), vec![(A, Duration::from_millis(50))]);
        let acts = stamped(&mut core, &mut devs, t0, &a, stamp(70, 20), 20, 0.2);
        assert!(ahead(&acts).is_empty(), "once per writer");
        // C, also ahead, within the same second: not named yet, but spared at once.
        let acts = stamped(&mut core, &mut devs, t0, &c, stamp(90, 30), 30, 0.3);
        assert!(ahead(&acts).is_empty());
        assert_eq!(counted(&acts, Counter::Accepted), vec![0]);
        let acts = stamped(&mut core, &mut devs, t0, &c, stamp(1000, 1010), 1010, 0.3);
        assert_eq!(ahead(&acts), vec![], "C's age is positive now");
        let acts = stamped(&mut core, &mut devs, t0, &c, stamp(1100, 1020), 1020, 0.3);
        assert_eq!(ahead(&acts), vec![(C, Duration::from_millis(80))], "a second later");
        // A's age past the maximum: not late (its ages mean nothing).
        let acts = stamped(&mut core, &mut devs, t0, &a, stamp(100, 2000), 2000, 0.4);
        assert_eq!(counted(&acts, Counter::Accepted), vec![0], "{acts:?}");
        // B within the tolerance: not named, and late as anyone.
        let acts = stamped(&mut core, &mut devs, t0, &b, stamp(2004, 2000), 2000, 0.5);
        assert!(ahead(&acts).is_empty());
        assert_eq!(counted(&acts, Counter::Accepted), vec![0]);
        let acts = stamped(&mut core, &mut devs, t0, &b, stamp(2010, 2200), 2200, 0.9);
        assert_eq!(counted(&acts, Counter::Late), vec![0]);

        let (mut core, mut devs) = front(Control::Shared, &[keeps_last_target()]);
        let acts = stamped(&mut core, &mut devs, t0, &a, stamp(600, 10), 10, 0.1);
        assert!(ahead(&acts).is_empty(), "no key: clocks are not compared");
    }

    /// A writer whose clock is stepped back: its commands are dropped as reordered (the
    /// front's silence acts meanwhile) until they have all been behind for the hold time;
    /// then its order starts afresh (logged) and its commands are taken again. Copies of its
    /// last command never start it afresh, however long they come.
    #[test]
    fn a_writer_whose_clock_steps_back_starts_afresh_after_the_hold_time() {
        let (mut core, mut devs) = front(Control::Exclusive, &[watchdog(HOLD, SafeAction::Hold)]);
        let a = writer(A);
        let t0 = Instant::now();
        stamped(&mut core, &mut devs, t0, &a, stamp(5000, 0), 0, 0.1);
        stamped(&mut core, &mut devs, t0, &a, stamp(5010, 10), 10, 0.2);
        reflect_all(&mut core, at(t0, 11), &devs);
        // The clock steps back 4 s at 20 ms; the client streams every 10 ms.
        let mut acts = Vec::new();
        let mut k = 0;
        while counted(&acts, Counter::Accepted).is_empty() {
            let taken = 20 + 10 * k;
            acts.extend(stamped(
                &mut core,
                &mut devs,
                t0,
                &a,
                stamp(1000 + 10 * k as i64, taken),
                taken,
                0.3,
            ));
            while let Some(d) = core.next_deadline().filter(|d| *d <= at(t0, taken)) {
                acts.extend(deadline(&mut core, &mut devs, d));
            }
            k += 1;
        }
        assert_eq!(
            k, 21,
            "dropped from 20 ms, taken at 220 ms: the hold time after the first"
        );
        assert_eq!(counted(&acts, Counter::Reordered).len(), 20);
        assert_eq!(safes(&acts), vec![(0, SafeAction::Hold)], "the silence acted meanwhile");
        assert!(
            logs(&acts)
                .iter()
                .any(|l| matches!(l, Log::Restarted { writer, behind, after }
                if writer.handle == A && *behind == Duration::from_millis(3810) && *after == HOLD)),
            "{acts:?}"
        );
        let acts = stamped(&mut core, &mut devs, t0, &a, stamp(1210, 230), 230, 0.4);
        assert_eq!(counted(&acts, Counter::Accepted), vec![0], "in order from there");
        assert_eq!(taken_q(&devs), vec![0.1, 0.2, 0.3, 0.4]);

        // Copies of the last command for longer than the hold time stay copies.
        for taken in (240..1000).step_by(10) {
            let acts = stamped(&mut core, &mut devs, t0, &a, stamp(1210, taken), taken, 0.9);
            assert_eq!(counted(&acts, Counter::Duplicate), vec![0]);
        }
        assert_eq!(taken_q(&devs).len(), 4);
    }

    /// A sample without a source timestamp (a dashboard page's command) is never dropped by
    /// the order rule, whatever came before it.
    #[test]
    fn a_sample_without_a_source_timestamp_is_never_dropped_as_out_of_order() {
        let (core, mut devs) = front(Control::Exclusive, &[keeps_last_target()]);
        let mut core = core.with_max_command_age(Some(Duration::from_millis(10)));
        let a = writer(A);
        let t0 = Instant::now();
        stamped(&mut core, &mut devs, t0, &a, stamp(100, 100), 100, 0.1);
        for k in 0..3 {
            let acts = stamped(&mut core, &mut devs, t0, &a, None, 101 + k, 0.2);
            assert_eq!(counted(&acts, Counter::Accepted), vec![0]);
        }
        let acts = stamped(&mut core, &mut devs, t0, &a, stamp(100, 110), 110, 0.9);
        assert_eq!(counted(&acts, Counter::Duplicate), vec![0], "the stamped order holds");
    }

    /// At most MAX_ORDERED writers are kept: a new one forgets the one heard from longest
    /// ago, whose next copy is then taken; the others' copies are still dropped.
    #[test]
    fn the_order_keeps_at_most_max_ordered_writers_forgetting_the_longest_silent() {
        let t0 = Instant::now();
        let mut o = Order::new(None, HOLD);
        let n = MAX_ORDERED as u64;
        for w in 0..=n {
            let t = at(t0, w);
            assert_eq!(o.check(w, stamp(7, w), t).ordered, Ordered::Yes);
            o.accepted(w, stamp(7, w));
            assert!(o.len() <= MAX_ORDERED);
        }
        assert_eq!(o.len(), MAX_ORDERED);
        let again = at(t0, 1000);
        assert_eq!(
            o.check(0, stamp(7, 1000), again).ordered,
            Ordered::Yes,
            "writer 0 forgotten"
        );
        assert_eq!(
            o.check(n, stamp(7, 1000), again).ordered,
            Ordered::No(Dropped::Duplicate),
            "the newest is kept"
        );
    }
}
