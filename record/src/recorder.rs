//! The recorder: a [`Tap`] on the topics to record (subscribed at start, polled by a thread of
//! its own) that hands each sample to the [`BagWriter`]'s bounded queue.

use std::sync::Arc;

use handgate_adapters::dds::Node;
use handgate_adapters::discovery::diagnose::ServedQos;

use crate::tap::{tappable, Subscribe, Tap};
use crate::writer::{BagWriter, ChannelSpec, QueuedMessage, RecordOptions, RecordStats, RecordSummary};
use crate::RecordError;

pub use crate::tap::{POLL, READER_DEPTH};

/// A topic to record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicSpec {
    pub dds_topic: String,
    pub dds_type: String,
    /// The QoS its writers offer.
    pub qos: ServedQos,
}

/// A running recording.
#[derive(Debug)]
pub struct Recorder {
    writer: Option<BagWriter>,
    tap: Option<Tap>,
    /// The topics recorded (those of a known type).
    pub topics: Vec<TopicSpec>,
}

impl Recorder {
    /// Subscribes `topics` on `node` (topics of a type without a schema are skipped with a
    /// warning) and starts recording into `opts.dir`.
    pub fn start(node: &Node, topics: Vec<TopicSpec>, opts: RecordOptions) -> Result<Self, RecordError> {
        let tapped = tappable(topics, "record");
        if tapped.is_empty() {
            return Err(RecordError::Invalid("no topic to record".into()));
        }
        let channels = tapped
            .iter()
            .map(|t| ChannelSpec {
                dds_topic: t.spec.dds_topic.clone(),
                dds_type: t.spec.dds_type.clone(),
                qos: t.spec.qos,
            })
            .collect();
        let writer = BagWriter::start(opts, channels)?;
        let sender = writer.sender();
        let tap = Tap::start(node, &tapped, Subscribe::All, "handgate-record-poll", move |s| {
            sender.send(QueuedMessage {
                channel: s.topic,
                publish_time: s.publish_time,
                log_time: s.log_time,
                data: s.data,
            });
        })?;
        Ok(Self {
            writer: Some(writer),
            tap: Some(tap),
            topics: tapped.into_iter().map(|t| t.spec).collect(),
        })
    }

    pub fn stats(&self) -> Arc<RecordStats> {
        self.writer.as_ref().expect("running").stats()
    }

    /// Stops polling (after one last poll), writes what is queued and finishes the files.
    pub fn stop(mut self) -> Result<RecordSummary, RecordError> {
        if let Some(t) = self.tap.take() {
            t.stop();
        }
        self.writer.take().expect("running").finish()
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        if let Some(t) = self.tap.take() {
            t.stop();
        }
        if let Some(w) = self.writer.take() {
            let _ = w.finish();
        }
    }
}
