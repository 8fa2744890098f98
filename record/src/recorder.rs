//! The recorder: subscribes topics as their wire types, polls them from a thread of its own
//! and hands each sample to the [`BagWriter`]'s bounded queue.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use handgate_adapters::dds::{Node, Qos};
use handgate_adapters::discovery::diagnose::ServedQos;

use crate::types::{wire_type, Source};
use crate::writer::{now_ns, BagWriter, ChannelSpec, QueuedMessage, RecordOptions, RecordStats, RecordSummary};
use crate::RecordError;

/// A topic to record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicSpec {
    pub dds_topic: String,
    pub dds_type: String,
    /// The QoS its writers offer.
    pub qos: ServedQos,
}

/// How often the recorder polls its readers; each reader keeps [`READER_DEPTH`] samples, so
/// a topic faster than `READER_DEPTH / POLL` (6.4 kHz; a 1 kHz topic leaves room for a 128 ms
/// stall of the poll thread) would lose samples in DDS. 20 ms, not 5: every poll takes from
/// every reader, and polling 4 times as often cost the default fleet's recording 6.7 % of a
/// core instead of the figure in docs/benchmarks.md.
pub const POLL: Duration = Duration::from_millis(20);
/// History depth of each recording reader.
pub const READER_DEPTH: i32 = 128;

/// A running recording.
#[derive(Debug)]
pub struct Recorder {
    writer: Option<BagWriter>,
    stop: Arc<AtomicBool>,
    poller: Option<std::thread::JoinHandle<()>>,
    /// The topics recorded (those of a known type).
    pub topics: Vec<TopicSpec>,
}

impl Recorder {
    /// Subscribes `topics` on `node` (topics of a type without a schema are skipped with a
    /// warning) and starts recording into `opts.dir`.
    pub fn start(node: &Node, topics: Vec<TopicSpec>, opts: RecordOptions) -> Result<Self, RecordError> {
        let mut specs = Vec::new();
        let mut sources: Vec<Box<dyn Source>> = Vec::new();
        for t in topics {
            if specs
                .iter()
                .any(|s: &TopicSpec| s.dds_topic == t.dds_topic && s.dds_type == t.dds_type)
            {
                continue;
            }
            let Some(wt) = wire_type(&t.dds_type) else {
                tracing::warn!(topic = %t.dds_topic, type_name = %t.dds_type, "not recorded: no ros2msg schema for this type");
                continue;
            };
            sources.push(wt.subscribe(node, &t.dds_topic, Qos::BestEffortDepth { depth: READER_DEPTH })?);
            specs.push(t);
        }
        if specs.is_empty() {
            return Err(RecordError::Invalid("no topic to record".into()));
        }
        let channels = specs
            .iter()
            .map(|t| ChannelSpec {
                dds_topic: t.dds_topic.clone(),
                dds_type: t.dds_type.clone(),
                qos: t.qos,
            })
            .collect();
        let writer = BagWriter::start(opts, channels)?;
        let sender = writer.sender();
        let stop = Arc::new(AtomicBool::new(false));
        let stop2 = stop.clone();
        let poller = std::thread::Builder::new()
            .name("handgate-record-poll".into())
            .spawn(move || {
                let mut buf = Vec::new();
                // Sources hold DDS readers: dropped on this thread when the loop ends.
                let mut sources = sources;
                loop {
                    let last = stop2.load(Ordering::Relaxed);
                    for (i, s) in sources.iter_mut().enumerate() {
                        buf.clear();
                        s.take(&mut buf);
                        if buf.is_empty() {
                            continue;
                        }
                        let log_time = now_ns();
                        for (stamp, data) in buf.drain(..) {
                            sender.send(QueuedMessage {
                                channel: i,
                                publish_time: u64::try_from(stamp).unwrap_or(log_time),
                                log_time,
                                data,
                            });
                        }
                    }
                    if last {
                        break;
                    }
                    std::thread::sleep(POLL);
                }
            })
            .map_err(|e| RecordError::Io("recorder thread".into(), e))?;
        Ok(Self {
            writer: Some(writer),
            stop,
            poller: Some(poller),
            topics: specs,
        })
    }

    pub fn stats(&self) -> Arc<RecordStats> {
        self.writer.as_ref().expect("running").stats()
    }

    /// Stops polling (after one last poll), writes what is queued and finishes the files.
    pub fn stop(mut self) -> Result<RecordSummary, RecordError> {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(p) = self.poller.take() {
            let _ = p.join();
        }
        self.writer.take().expect("running").finish()
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(p) = self.poller.take() {
            let _ = p.join();
        }
        if let Some(w) = self.writer.take() {
            let _ = w.finish();
        }
    }
}
