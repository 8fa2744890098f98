//! A running front's wire side, for every front kind: its endpoints ([`FrontIo`]: the
//! command reader, decode through the routes bound at start, the state writers; or a
//! state-only [`StateIo`]), opened by its kind (`Front::open`; most through
//! [`super::endpoint::DdsFront`], every command front through [`commands`]).
//! The gateway's runtime drives them all through one front task (queue, silence, prompt
//! state, deadlines).

use std::any::Any;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use crate::dds::{DdsError, Node, Qos, Reader, WriterHandle, WriterInfo};
use crate::discovery::diagnose::Served;
use crate::discovery::Role;

use crate::model::{CommandBody, HandState, SafeAction};
use tokio::sync::mpsc;

use super::plan::FrontPlan;
use super::{FrontCommand, Rejection};
use crate::route::Route;

/// One device a running front drives, as its codec sees it: the route bound once, the
/// device's latest state.
#[derive(Debug)]
pub struct Bound<'a> {
    pub route: &'a Route,
    /// Element of the front's messages that carries this device.
    pub element: usize,
    /// The device's name (the canonical front's state names it).
    pub device: &'a str,
    /// The device's safe action (a canonical `safe` command).
    pub safe_action: SafeAction,
    /// Its latest state (borrowed from the device for one decode or publish).
    pub state: &'a HandState,
}

impl Bound<'_> {
    /// The device's state in the front's canonical joint order.
    pub fn routed_state(&self) -> Vec<crate::model::JointState> {
        self.route.state(&self.state.joints, self.state.closure)
    }
}

/// A command for one bound device: the body, the client's tag, whether it set the Dex3 RIS
/// timeout bit.
pub type Routed = (CommandBody, u32, bool);

/// A message a front's reader took, for that front's own decode.
pub type Message = Box<dyn Any + Send>;

/// A command sample as the front task receives it: the message and the writer that wrote it
/// (read once per writer, shared by its samples).
pub struct Incoming {
    pub writer: Arc<WriterInfo>,
    pub msg: Message,
    /// When the reader took it (a front task that falls behind still sees when each writer
    /// last spoke).
    pub taken: std::time::Instant,
    /// When its writer wrote it and when the reader took it, by the wall clocks (`None`: the
    /// sample carries no source timestamp, as a dashboard page's command).
    pub stamp: Option<Stamp>,
}

/// When a sample was written, by its writer's clock (the DDS source timestamp), and when the
/// reader took it, by this host's: ns since the UNIX epoch each. The front core orders a
/// writer's commands by the first and ages them by the difference (`max_command_age_ms`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stamp {
    pub written_ns: i64,
    pub taken_ns: i64,
}

impl Stamp {
    /// How long the sample took from its writer to the reader, ns, as the two clocks say (a
    /// negative age: the writer's clock is ahead of this host's).
    pub fn age_ns(&self) -> i64 {
        self.taken_ns.saturating_sub(self.written_ns)
    }
}

/// This host's wall clock, ns since the UNIX epoch (what a [`Stamp`] is taken by).
pub fn wall_ns() -> i64 {
    match std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH) {
        Ok(d) => i64::try_from(d.as_nanos()).unwrap_or(i64::MAX),
        Err(e) => -i64::try_from(e.duration().as_nanos()).unwrap_or(i64::MAX),
    }
}

/// Where a front's readers hand each command sample: to the front itself, on the reader's
/// DDS listener thread, once the runtime has set a [`Direct`] handler (the command path:
/// decode, check, ownership and the hand-off to the device run in the listener), or else to
/// the front task's queue.
#[derive(Clone)]
pub struct Queue {
    tx: mpsc::Sender<Incoming>,
    direct: Arc<std::sync::OnceLock<std::sync::Weak<dyn Direct>>>,
}

/// A running front taking its samples in its readers' listeners ([`Queue::set_direct`]). It
/// must never block on a device: it decides and hands off, or queues the sample for the
/// front's task (in order), and counts what it drops.
pub trait Direct: Send + Sync {
    /// Takes one sample; `false`: it was dropped (the front's queue was full).
    fn take(&self, sample: Incoming) -> bool;
}

impl Queue {
    /// A queue feeding `tx` until a [`Direct`] handler is set.
    pub fn new(tx: mpsc::Sender<Incoming>) -> Self {
        Self {
            tx,
            direct: Arc::default(),
        }
    }

    /// From now on, samples go to `front` (set once; held weakly, so a front that stopped
    /// is not kept alive by its readers: its samples go to the closed queue).
    pub fn set_direct(&self, front: std::sync::Weak<dyn Direct>) {
        let _ = self.direct.set(front);
    }

    /// Hands `sample` on; `false`: it was dropped.
    pub fn deliver(&self, sample: Incoming) -> bool {
        match self.direct.get().and_then(std::sync::Weak::upgrade) {
            Some(front) => front.take(sample),
            None => self.tx.try_send(sample).is_ok(),
        }
    }
}

/// The USER_DATA of a writer that takes a front over from its owner (`handgate send
/// --force`; docs/fronts.md, "One commanding client per front"). handgate's own marker, set
/// only by handgate's tools; no Unitree or DDS convention.
pub const FORCE_USER_DATA: &[u8] = b"handgate:control=force";

impl Incoming {
    /// Whether the writer asks to take the front over from its owner.
    pub fn force(&self) -> bool {
        self.writer.user_data == FORCE_USER_DATA
    }
}

/// Names a writer for a log line: its process, pid and host where discovery knows its
/// participant, and its GUID (or only the reader's handle when the writer had gone).
pub fn describe_writer(w: &WriterInfo, discovery: &crate::discovery::Snapshot) -> String {
    if let Some(label) = &w.label {
        return label.clone();
    }
    let Some(guid) = w.guid else {
        return format!("writer handle {:016x} (no longer matched)", w.handle);
    };
    let who = w.participant.and_then(|p| discovery.participant(&p)).map(|p| {
        let mut s = p.process_name.as_deref().unwrap_or("?").to_string();
        if let Some(pid) = p.pid {
            s.push_str(&format!(" pid {pid}"));
        }
        if let Some(h) = &p.hostname {
            s.push_str(&format!(" on {h}"));
        }
        s
    });
    match who {
        Some(who) => format!("{who} (writer {guid})"),
        None => format!("writer {guid}"),
    }
}

/// Writers a reader remembers at most; beyond, it forgets them all and reads each again.
const MAX_WRITERS: usize = 64;

/// A running front's wire side: its reader (kept alive), decoding and state writers. The
/// runtime's one front task (queue, silence, prompt state, deadlines) drives every front
/// kind through it.
pub trait FrontIo: Send {
    /// Decodes a message into commands per bound device (index into `bound`), or the reason
    /// it is rejected whole.
    fn decode(&self, bound: &[Bound<'_>], msg: &Message) -> Result<Vec<(usize, Routed)>, Rejection>;

    /// Publishes the bound devices' state (`lf`: the low-frequency copy, where there is one).
    fn publish(&mut self, bound: &[Bound<'_>], lf: bool);

    /// Rate of the low-frequency copy, Hz (0: none).
    fn lf_hz(&self) -> f64 {
        0.0
    }
}

/// One device a state-only front publishes: its name, table and latest state.
#[derive(Debug)]
pub struct Published<'a> {
    pub device: &'a str,
    pub table: &'a crate::mapping::DeviceTable,
    pub state: HandState,
}

/// A running state-only front's wire side (no command reader): its state writer.
pub trait StateIo: Send {
    /// Publishes one message over `devices`.
    fn publish(&mut self, devices: &[Published<'_>]);
}

/// A running front's endpoints, as its kind opened them.
pub enum Endpoints {
    /// A front taking commands, run by the runtime's front task.
    Commands(Box<dyn FrontIo>),
    /// A front publishing state only, run by the runtime's state-only task.
    StateOnly(Box<dyn StateIo>),
}

/// The QoS of every front's command reader ([`Inbox::reader`]).
pub const COMMAND_QOS: Qos = Qos::Reliable { depth: 16 };
/// The QoS of every front's state writers (state, low-frequency state, touch).
pub const STATE_QOS: Qos = Qos::BestEffort;

/// What a front serves on its command topic: a reader of `T` with [`COMMAND_QOS`].
pub fn served_command<T: handgate_idl::TopicType>(topic: &str) -> Served {
    Served::new(topic, crate::dds::type_name::<T>(), Role::Reader, COMMAND_QOS.served())
}

/// What a front serves on a state topic: a writer of `T` with [`STATE_QOS`].
pub fn served_state<T: handgate_idl::TopicType>(topic: &str) -> Served {
    Served::new(topic, crate::dds::type_name::<T>(), Role::Writer, STATE_QOS.served())
}

/// The queue of a front whose readers take messages of type `M`: the one place a typed
/// message becomes the runtime's [`Message`] (its readers, [`Inbox::reader`]), paired with the
/// one place it is read back ([`commands`]), so the front's decode sees `M` and nothing else.
pub struct Inbox<M> {
    tx: Queue,
    dropped: Arc<AtomicU64>,
    _msg: std::marker::PhantomData<fn(M)>,
}

impl<M> Clone for Inbox<M> {
    fn clone(&self) -> Self {
        Inbox {
            tx: self.tx.clone(),
            dropped: self.dropped.clone(),
            _msg: std::marker::PhantomData,
        }
    }
}

impl<M: Send + 'static> Inbox<M> {
    /// An inbox feeding `tx` (a front's own tests; a running front's comes from [`commands`]).
    pub fn for_tests(tx: Queue) -> Self {
        Inbox {
            tx,
            dropped: Arc::default(),
            _msg: std::marker::PhantomData,
        }
    }

    /// Hands `msg` from a client that is not a DDS endpoint (a stream front's connection,
    /// `writer` its identity: [`super::stream`]) to the front, taken now, with no source
    /// timestamp; `false`: the front's queue was full and it was dropped (counted).
    pub fn deliver(&self, writer: &Arc<WriterInfo>, msg: M) -> bool {
        let ok = self.tx.deliver(Incoming {
            writer: writer.clone(),
            msg: Box::new(msg),
            taken: std::time::Instant::now(),
            stamp: None,
        });
        if !ok {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
        ok
    }

    /// A command reader on `topic` handing every sample, as `wrap` makes it an `M`, to the
    /// front's task as an [`Incoming`] (the message and its writer, read from CycloneDDS once
    /// per new writer), in the reader's listener ([`Queue::deliver`]); a sample that finds the
    /// queue full is dropped and counted.
    pub fn reader<T: Clone + handgate_idl::TopicType + Send + 'static>(
        &self,
        node: &Node,
        topic: &str,
        wrap: fn(T) -> M,
    ) -> Result<Reader<T>, DdsError> {
        self.reader_with(node, topic, &crate::dds::EndpointOptions::default(), wrap)
    }

    /// [`Self::reader`] with USER_DATA from `opts` (a ROS-typed reader's type hash,
    /// `ros::user_data`).
    pub fn reader_with<T: Clone + handgate_idl::TopicType + Send + 'static>(
        &self,
        node: &Node,
        topic: &str,
        opts: &crate::dds::EndpointOptions,
        wrap: fn(T) -> M,
    ) -> Result<Reader<T>, DdsError> {
        let (tx, dropped) = (self.tx.clone(), self.dropped.clone());
        let mut writers: std::collections::HashMap<WriterHandle, Arc<WriterInfo>> = std::collections::HashMap::new();
        // The samples of one call, the buffer reused.
        let mut v = Vec::new();
        node.reader_with_callback_opts::<T, _>(topic, COMMAND_QOS, opts, move |h| {
            h.take_with_writers(&mut v);
            let taken = std::time::Instant::now();
            let taken_ns = wall_ns();
            for (s, w, written) in v.drain(..) {
                if writers.len() >= MAX_WRITERS && !writers.contains_key(&w) {
                    writers.clear();
                }
                let writer = writers
                    .entry(w)
                    .or_insert_with(|| Arc::new(h.matched_writer(w)))
                    .clone();
                let msg: Message = Box::new(wrap(s));
                let stamp = written.map(|written_ns| Stamp { written_ns, taken_ns });
                if !tx.deliver(Incoming {
                    writer,
                    msg,
                    taken,
                    stamp,
                }) {
                    dropped.fetch_add(1, Ordering::Relaxed);
                }
            }
        })
    }
}

/// A front's wire side, typed by the message its readers take ([`Inbox`]): decode, publish.
/// [`commands`] erases it into the runtime's [`FrontIo`].
pub trait TypedIo: Send + 'static {
    /// What the front's readers queue.
    type Msg: Send + 'static;
    /// Decodes a message into commands per bound device (index into `bound`), or the reason
    /// it is rejected whole.
    fn decode(&self, bound: &[Bound<'_>], msg: &Self::Msg) -> Result<Vec<(usize, Routed)>, Rejection>;
    /// Publishes the bound devices' state (`lf`: the low-frequency copy, where there is one).
    fn publish(&mut self, bound: &[Bound<'_>], lf: bool);
    /// Rate of the low-frequency copy, Hz (0: none).
    fn lf_hz(&self) -> f64 {
        0.0
    }
}

/// The endpoints of a front taking commands: `open` builds its typed wire side from the
/// front's [`Inbox`] (whose readers queue `T::Msg`, and nothing else reaches the queue), and
/// the result is erased here for the runtime.
pub fn commands<T: TypedIo>(
    tx: Queue,
    dropped: Arc<AtomicU64>,
    open: impl FnOnce(Inbox<T::Msg>) -> Result<T, DdsError>,
) -> Result<Endpoints, DdsError> {
    let inbox = Inbox {
        tx,
        dropped,
        _msg: std::marker::PhantomData,
    };
    Ok(Endpoints::Commands(Box::new(Erased(open(inbox)?))))
}

/// A [`TypedIo`] as the runtime drives it.
struct Erased<T>(T);

impl<T: TypedIo> FrontIo for Erased<T> {
    fn decode(&self, bound: &[Bound<'_>], msg: &Message) -> Result<Vec<(usize, Routed)>, Rejection> {
        match msg.downcast_ref::<T::Msg>() {
            Some(m) => self.0.decode(bound, m),
            None => Err(Rejection::WrongType(std::any::type_name::<T::Msg>())),
        }
    }
    fn publish(&mut self, bound: &[Bound<'_>], lf: bool) {
        self.0.publish(bound, lf)
    }
    fn lf_hz(&self) -> f64 {
        self.0.lf_hz()
    }
}

/// What a front kind opens its endpoints with: the gateway's participant and what discovery
/// sees on its domain (the latest snapshot; a front that follows its clients, or reports on
/// them, watches it from its own task).
#[derive(Clone)]
pub struct FrontEnv {
    pub node: Node,
    pub discovery: tokio::sync::watch::Receiver<Arc<crate::discovery::Snapshot>>,
    /// What the fronts of one runtime share (a front kind's own meeting point between its
    /// fronts, e.g. several fronts serving one topic together).
    pub shared: FrontShared,
}

/// Items the fronts of one runtime share, one per (type, key), created on first use.
#[derive(Clone, Default)]
pub struct FrontShared(Arc<std::sync::Mutex<SharedItems>>);

type SharedItems = std::collections::HashMap<(std::any::TypeId, &'static str), Arc<dyn Any + Send + Sync>>;

impl FrontShared {
    /// The item of type `T` under `key`, created with `T::default()` by the first caller.
    pub fn get<T: Any + Send + Sync + Default>(&self, key: &'static str) -> Arc<T> {
        let mut g = self.0.lock().unwrap_or_else(|p| p.into_inner());
        let item = g
            .entry((std::any::TypeId::of::<T>(), key))
            .or_insert_with(|| Arc::new(T::default()))
            .clone();
        item.downcast::<T>().expect("an entry keyed by T's TypeId holds a T")
    }
}

/// The endpoints of front `f`, opened by its kind.
pub fn open(env: &FrontEnv, f: &FrontPlan, tx: Queue, dropped: Arc<AtomicU64>) -> Result<Endpoints, DdsError> {
    f.open(env, tx, dropped)
}

/// (element, front table) of each bound device, in `bound`'s order: what the codec of a
/// message carrying several devices decodes against.
pub fn elements<'a>(bound: &'a [Bound<'_>]) -> Vec<(usize, &'a crate::mapping::DeviceTable)> {
    bound.iter().map(|b| (b.element, &*b.route.front)).collect()
}

/// One decoded command per bound device, in `bound`'s order, each routed to its device.
pub fn routed_each(bound: &[Bound<'_>], commands: Vec<FrontCommand>) -> Vec<(usize, Routed)> {
    commands
        .into_iter()
        .zip(bound)
        .enumerate()
        .map(|(i, (c, b))| (i, routed(b.route, c)))
        .collect()
}

/// A decoded front command routed to the device of `route`.
pub fn routed(route: &Route, c: FrontCommand) -> Routed {
    (route.command(&c.joints), c.tag, c.timeout_bit)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wire side reading `u32`s: each decodes to nothing but counts as read.
    struct Counting(std::sync::atomic::AtomicUsize);

    impl TypedIo for Counting {
        type Msg = u32;
        fn decode(&self, _bound: &[Bound<'_>], _msg: &u32) -> Result<Vec<(usize, Routed)>, Rejection> {
            self.0.fetch_add(1, Ordering::Relaxed);
            Ok(Vec::new())
        }
        fn publish(&mut self, _bound: &[Bound<'_>], _lf: bool) {}
    }

    #[test]
    fn the_erased_front_decodes_its_own_type_and_counts_another_as_a_rejection() {
        let (tx, _rx) = mpsc::channel(1);
        let Endpoints::Commands(io) = commands(Queue::new(tx), Arc::default(), |_inbox: Inbox<u32>| {
            Ok(Counting(Default::default()))
        })
        .unwrap() else {
            panic!("a front taking commands");
        };
        assert_eq!(io.decode(&[], &(Box::new(7u32) as Message)), Ok(Vec::new()));
        let other = io.decode(&[], &(Box::new("seven") as Message)).unwrap_err();
        assert_eq!(other, Rejection::WrongType("u32"));
        assert_eq!(other.reason(), "wrong_type");
        assert_eq!(io.lf_hz(), 0.0);
    }
}
