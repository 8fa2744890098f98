//! Taking samples off DDS topics on a thread of its own: the one home of the subscription and
//! polling code the recorder ([`crate::Recorder`]) and the gateway's live Foxglove server share.
//!
//! A [`Tap`] holds one entry per topic (a [`TopicSpec`] of a type with a `ros2msg` schema).
//! Its thread polls the readers of the subscribed topics every [`POLL`] and hands each sample,
//! as little-endian CDR with its source timestamp, to a callback. A topic is subscribed at
//! start ([`Subscribe::All`], the recorder) or while someone asks for it
//! ([`Subscribe::OnDemand`], the live server: [`Tap::subscribe`] / [`Tap::unsubscribe`],
//! counted), so an idle tap holds no DDS reader and its thread sleeps until asked.

use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::time::{Duration, Instant};

use handgate_adapters::dds::{Node, Qos};

use crate::recorder::TopicSpec;
use crate::types::{wire_type, Source, WireType};
use crate::writer::now_ns;
use crate::RecordError;

/// How often a tap polls its readers; each reader keeps [`READER_DEPTH`] samples, so
/// a topic faster than `READER_DEPTH / POLL` (6.4 kHz; a 1 kHz topic leaves room for a 128 ms
/// stall of the poll thread) would lose samples in DDS. 20 ms, not 5: every poll takes from
/// every reader, and polling 4 times as often cost the default fleet's recording 6.7 % of a
/// core instead of the figure in docs/benchmarks.md.
pub const POLL: Duration = Duration::from_millis(20);
/// History depth of each tap reader.
pub const READER_DEPTH: i32 = 128;

/// The QoS of a tap reader: best effort, keep last [`READER_DEPTH`]; it matches reliable and
/// best-effort writers, and a writer's thread only stores the sample in its history.
pub const READER_QOS: Qos = Qos::BestEffortDepth { depth: READER_DEPTH };

/// A topic a tap can take: its spec and wire type.
#[derive(Debug, Clone)]
pub struct Tapped {
    pub spec: TopicSpec,
    pub wire: WireType,
}

/// The topics of `topics` a tap can take, each (topic, type) once; topics of a type without a
/// `ros2msg` schema are left out with a warning naming `user` (`record`, `foxglove`).
pub fn tappable(topics: Vec<TopicSpec>, user: &str) -> Vec<Tapped> {
    let mut out: Vec<Tapped> = Vec::new();
    for t in topics {
        if out
            .iter()
            .any(|o| o.spec.dds_topic == t.dds_topic && o.spec.dds_type == t.dds_type)
        {
            continue;
        }
        match wire_type(&t.dds_type) {
            Some(wire) => out.push(Tapped { spec: t, wire }),
            None => tracing::warn!(
                topic = %t.dds_topic,
                type_name = %t.dds_type,
                user,
                "left out: no ros2msg schema for this type"
            ),
        }
    }
    out
}

/// One sample taken from a topic.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Sample {
    /// The topic's index in the tap's list.
    pub topic: usize,
    /// The sample's DDS source timestamp, ns since the Unix epoch (the writer's clock; the
    /// poll time when the sample has none).
    pub publish_time: u64,
    /// When the tap took it, ns since the Unix epoch.
    pub log_time: u64,
    /// Little-endian CDR with its encapsulation header.
    pub data: Vec<u8>,
}

/// When a tap subscribes its topics.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Subscribe {
    /// Every topic at start, until the tap stops.
    All,
    /// Each topic while its [`Tap::subscribe`] calls outnumber its [`Tap::unsubscribe`] calls.
    OnDemand,
}

#[derive(Debug)]
enum Ctl {
    Subscribe(usize),
    Unsubscribe(usize),
    Stop,
}

/// Topics polled by a thread of its own; see the module documentation.
#[derive(Debug)]
pub struct Tap {
    ctl: Sender<Ctl>,
    poller: Option<std::thread::JoinHandle<()>>,
}

/// One topic as the poll thread holds it.
struct Slot {
    topic: String,
    wire: WireType,
    /// Subscriptions asked for (`Subscribe::All`: 1 from the start).
    wanted: usize,
    source: Option<Box<dyn Source>>,
}

impl Tap {
    /// Starts a tap on `topics` (their indexes are [`Sample::topic`]) whose thread `name`
    /// calls `deliver` for every sample. With [`Subscribe::All`] every reader is created
    /// before this returns (an error is returned); on demand, a reader that cannot be created
    /// is logged and its topic stays silent.
    pub fn start(
        node: &Node,
        topics: &[Tapped],
        subscribe: Subscribe,
        name: &str,
        deliver: impl FnMut(Sample) + Send + 'static,
    ) -> Result<Self, RecordError> {
        let mut slots = Vec::with_capacity(topics.len());
        for t in topics {
            let source = match subscribe {
                Subscribe::All => Some(t.wire.subscribe(node, &t.spec.dds_topic, READER_QOS)?),
                Subscribe::OnDemand => None,
            };
            slots.push(Slot {
                topic: t.spec.dds_topic.clone(),
                wire: t.wire,
                wanted: usize::from(subscribe == Subscribe::All),
                source,
            });
        }
        let (ctl, rx) = mpsc::channel();
        let node = node.clone();
        let poller = std::thread::Builder::new()
            .name(name.into())
            .spawn(move || poll_loop(&node, slots, &rx, deliver))
            .map_err(|e| RecordError::Io(format!("{name} thread"), e))?;
        Ok(Self {
            ctl,
            poller: Some(poller),
        })
    }

    /// Asks for topic `i` (one more subscription; the first creates its reader).
    pub fn subscribe(&self, i: usize) {
        let _ = self.ctl.send(Ctl::Subscribe(i));
    }

    /// Gives up one subscription of topic `i` (the last drops its reader).
    pub fn unsubscribe(&self, i: usize) {
        let _ = self.ctl.send(Ctl::Unsubscribe(i));
    }

    /// A handle that subscribes and unsubscribes from other threads (after the tap stopped,
    /// its requests are ignored).
    pub fn handle(&self) -> TapHandle {
        TapHandle { ctl: self.ctl.clone() }
    }

    /// Stops after one last poll and waits for the thread (its readers are dropped there).
    pub fn stop(mut self) {
        self.halt();
    }

    fn halt(&mut self) {
        let _ = self.ctl.send(Ctl::Stop);
        if let Some(p) = self.poller.take() {
            let _ = p.join();
        }
    }
}

/// Asks a [`Tap`] for topics from another thread ([`Tap::handle`]).
#[derive(Debug, Clone)]
pub struct TapHandle {
    ctl: Sender<Ctl>,
}

impl TapHandle {
    /// As [`Tap::subscribe`].
    pub fn subscribe(&self, i: usize) {
        let _ = self.ctl.send(Ctl::Subscribe(i));
    }

    /// As [`Tap::unsubscribe`].
    pub fn unsubscribe(&self, i: usize) {
        let _ = self.ctl.send(Ctl::Unsubscribe(i));
    }
}

impl Drop for Tap {
    fn drop(&mut self) {
        self.halt();
    }
}

/// The poll thread: applies subscription changes, takes every subscribed reader's samples
/// every [`POLL`], and sleeps on its control channel while nothing is subscribed.
fn poll_loop(node: &Node, mut slots: Vec<Slot>, rx: &Receiver<Ctl>, mut deliver: impl FnMut(Sample)) {
    let mut buf = Vec::new();
    let mut next = Instant::now();
    let mut stopping = false;
    loop {
        // Wait for the next poll, or (nothing subscribed) for a request.
        let active = slots.iter().any(|s| s.source.is_some());
        let first = if stopping {
            None
        } else if active {
            match rx.recv_timeout(next.saturating_duration_since(Instant::now())) {
                Ok(c) => Some(c),
                Err(RecvTimeoutError::Timeout) => None,
                Err(RecvTimeoutError::Disconnected) => Some(Ctl::Stop),
            }
        } else {
            Some(rx.recv().unwrap_or(Ctl::Stop))
        };
        for c in first.into_iter().chain(std::iter::from_fn(|| rx.try_recv().ok())) {
            match c {
                Ctl::Stop => stopping = true,
                Ctl::Subscribe(i) => {
                    let Some(s) = slots.get_mut(i) else { continue };
                    s.wanted += 1;
                    if s.source.is_none() {
                        match s.wire.subscribe(node, &s.topic, READER_QOS) {
                            Ok(src) => s.source = Some(src),
                            Err(e) => tracing::warn!(topic = %s.topic, error = %e, "tap: cannot subscribe"),
                        }
                    }
                }
                Ctl::Unsubscribe(i) => {
                    let Some(s) = slots.get_mut(i) else { continue };
                    s.wanted = s.wanted.saturating_sub(1);
                    if s.wanted == 0 {
                        s.source = None;
                    }
                }
            }
        }
        if Instant::now() >= next || stopping {
            for (i, s) in slots.iter_mut().enumerate() {
                let Some(src) = s.source.as_mut() else { continue };
                buf.clear();
                src.take(&mut buf);
                if buf.is_empty() {
                    continue;
                }
                let log_time = now_ns();
                for (stamp, data) in buf.drain(..) {
                    deliver(Sample {
                        topic: i,
                        publish_time: u64::try_from(stamp).unwrap_or(log_time),
                        log_time,
                        data,
                    });
                }
            }
            next = Instant::now() + POLL;
        }
        if stopping {
            // The readers are dropped on this thread.
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tappable_drops_duplicates_and_types_without_a_schema() {
        let spec = |topic: &str, ty: &str| TopicSpec {
            dds_topic: topic.into(),
            dds_type: ty.into(),
            qos: handgate_adapters::dds::Qos::BestEffort.served(),
        };
        let js = "sensor_msgs::msg::dds_::JointState_";
        let t = tappable(
            vec![
                spec("rt/joint_states", js),
                spec("rt/joint_states", js),
                spec("rt/other", "no::such::Type_"),
                spec("rt/joint_states_copy", js),
            ],
            "test",
        );
        let names: Vec<&str> = t.iter().map(|t| t.spec.dds_topic.as_str()).collect();
        assert_eq!(names, ["rt/joint_states", "rt/joint_states_copy"]);
        assert_eq!(t[0].wire.schema.ros_type, "sensor_msgs/msg/JointState");
    }

    /// On demand: no reader until asked, samples while asked (decoding to what was written),
    /// the reader kept while one of two subscriptions remains and dropped with the last.
    /// DDS domain 159 (docs/development.md).
    #[test]
    fn on_demand_readers_exist_while_subscribed() {
        use handgate_idl::ros2::JointState_;
        let node = Node::new(159, None).expect("participant");
        let js = <JointState_ as handgate_idl::DdsTypeName>::DDS_TYPE_NAME;
        let spec = |topic: &str| TopicSpec {
            dds_topic: topic.into(),
            dds_type: js.into(),
            qos: Qos::Reliable { depth: 10 }.served(),
        };
        let tapped = tappable(vec![spec("rt/tap_test_a"), spec("rt/tap_test_b")], "test");
        let mut wa = node
            .writer::<JointState_>("rt/tap_test_a", Qos::Reliable { depth: 10 })
            .unwrap();
        let wb = node
            .writer::<JointState_>("rt/tap_test_b", Qos::Reliable { depth: 10 })
            .unwrap();
        let (tx, rx) = mpsc::channel();
        let tap = Tap::start(&node, &tapped, Subscribe::OnDemand, "tap-test", move |s| {
            let _ = tx.send(s);
        })
        .unwrap();
        let wait = |what: &str, f: &dyn Fn() -> bool| {
            let deadline = Instant::now() + Duration::from_secs(10);
            while !f() {
                assert!(Instant::now() < deadline, "{what}");
                std::thread::sleep(Duration::from_millis(1));
            }
        };
        assert_eq!((wa.matched(), wb.matched()), (0, 0), "no reader before a subscription");

        tap.subscribe(0);
        wa.wait_matched(1, Duration::from_secs(10)).expect("the tap's reader");
        let msg = JointState_ {
            name: vec!["left_hand_zero_joint".into()],
            position: vec![0.25],
            ..Default::default()
        };
        let deadline = Instant::now() + Duration::from_secs(10);
        let got = loop {
            wa.write(msg.clone()).unwrap();
            if let Ok(s) = rx.recv_timeout(Duration::from_millis(50)) {
                break s;
            }
            assert!(Instant::now() < deadline, "no sample through the tap");
        };
        assert_eq!(got.topic, 0);
        let back: JointState_ = handgate_idl::from_cdr(&got.data).unwrap();
        assert_eq!((back.name, back.position), (msg.name.clone(), msg.position.clone()));

        // Two subscriptions, one given up: the reader stays. Topic b's subscription is a
        // barrier: the thread handles requests in order, so once b's reader matched, a's
        // unsubscribe was handled.
        tap.subscribe(0);
        tap.unsubscribe(0);
        tap.subscribe(1);
        wb.wait_matched(1, Duration::from_secs(10)).expect("b's reader");
        assert_eq!(wa.matched(), 1, "one of two subscriptions left: the reader stays");
        tap.unsubscribe(0);
        wait("a's reader dropped with its last subscription", &|| wa.matched() == 0);
        assert_eq!(wb.matched(), 1);
        tap.stop();
        wait("b's reader dropped when the tap stops", &|| wb.matched() == 0);
    }
}
