//! The writer thread: takes messages from a bounded queue and writes them into
//! `DIR/NAME_i.mcap` files (rolling over at a size or duration limit), then `metadata.yaml`.
//!
//! Crash safety: every [`RecordOptions::flush_every`] (and whenever a chunk is full) the
//! current chunk is closed and written out to the OS, so a crash or SIGKILL loses at most the
//! messages of the chunk being filled; the file up to the last closed chunk stays readable by
//! a streaming MCAP reader (its summary and footer are written only at the end).

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender, TrySendError};
use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::discovery::diagnose::ServedQos;
use handgate_adapters::discovery::{Durability, History, Reliability};
use handgate_idl::ros2msg;

use crate::types::wire_type;
use crate::RecordError;

/// Chunk compression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Compression {
    #[default]
    None,
    /// zstd (needs the crate feature `zstd`).
    Zstd,
}

/// How to write a recording.
#[derive(Debug, Clone)]
pub struct RecordOptions {
    /// The recording directory `NAME` (created; must not exist or be empty).
    pub dir: PathBuf,
    /// Start a new file when the current one holds this many bytes of messages.
    pub max_bytes: Option<u64>,
    /// Start a new file when the current one spans this long.
    pub max_duration: Option<Duration>,
    pub compression: Compression,
    /// Messages the queue to the writer thread holds; beyond it messages are dropped.
    pub queue: usize,
    /// Close the current chunk (and write it out) at least this often.
    pub flush_every: Duration,
    /// Uncompressed size at which a chunk is closed.
    pub chunk_bytes: u64,
}

impl RecordOptions {
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        Self {
            dir: dir.into(),
            max_bytes: None,
            max_duration: None,
            compression: Compression::None,
            queue: 8192,
            flush_every: Duration::from_secs(1),
            chunk_bytes: 1 << 20,
        }
    }

    /// The recording's name: the directory's last component.
    pub fn name(&self) -> String {
        self.dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "recording".into())
    }
}

/// One recorded topic.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelSpec {
    pub dds_topic: String,
    pub dds_type: String,
    /// The QoS its writers offer (as served by the gateway).
    pub qos: ServedQos,
}

/// One message on its way to the writer thread.
#[derive(Debug)]
pub struct QueuedMessage {
    /// Index into the channel list the writer was started with.
    pub channel: usize,
    /// Source timestamp, ns since the epoch.
    pub publish_time: u64,
    /// When the recorder took it, ns since the epoch.
    pub log_time: u64,
    pub data: Vec<u8>,
}

/// Counters of a running recording (shared with the status publisher).
#[derive(Debug, Default)]
pub struct RecordStats {
    pub written: AtomicU64,
    pub dropped: AtomicU64,
    pub bytes: AtomicU64,
    pub files: AtomicU64,
}

/// Puts messages on the writer's queue without ever blocking; a full queue drops the message
/// and counts it.
#[derive(Debug, Clone)]
pub struct MessageSender {
    tx: SyncSender<QueuedMessage>,
    stats: Arc<RecordStats>,
}

impl MessageSender {
    pub fn send(&self, m: QueuedMessage) {
        match self.tx.try_send(m) {
            Ok(()) => {}
            Err(TrySendError::Full(_)) | Err(TrySendError::Disconnected(_)) => {
                self.stats.dropped.fetch_add(1, Ordering::Relaxed);
            }
        }
    }
}

/// What a finished recording holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecordSummary {
    pub files: Vec<PathBuf>,
    pub messages: u64,
    pub dropped: u64,
    pub bytes: u64,
}

/// A running writer thread.
#[derive(Debug)]
pub struct BagWriter {
    sender: MessageSender,
    thread: std::thread::JoinHandle<Result<RecordSummary, RecordError>>,
}

/// ns since the epoch, now.
pub fn now_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0)
}

impl BagWriter {
    /// Creates the directory and its first file, and starts the writer thread.
    pub fn start(opts: RecordOptions, channels: Vec<ChannelSpec>) -> Result<Self, RecordError> {
        if opts.compression == Compression::Zstd && !cfg!(feature = "zstd") {
            return Err(RecordError::Invalid(
                "zstd compression needs handgate built with the `zstd` feature (cargo build --features zstd)".into(),
            ));
        }
        for c in &channels {
            if wire_type(&c.dds_type).is_none() {
                return Err(RecordError::Invalid(format!(
                    "topic {}: type {} has no ros2msg schema",
                    c.dds_topic, c.dds_type
                )));
            }
        }
        if opts.dir.exists()
            && std::fs::read_dir(&opts.dir)
                .map(|mut d| d.next().is_some())
                .unwrap_or(true)
        {
            return Err(RecordError::Invalid(format!(
                "{} exists and is not empty (choose a new recording name)",
                opts.dir.display()
            )));
        }
        std::fs::create_dir_all(&opts.dir).map_err(|e| RecordError::Io(opts.dir.display().to_string(), e))?;
        let stats = Arc::new(RecordStats::default());
        let (tx, rx) = mpsc::sync_channel(opts.queue.max(1));
        let file = FileWriter::create(&opts, &channels, 0)?;
        stats.files.store(1, Ordering::Relaxed);
        let st = stats.clone();
        let thread = std::thread::Builder::new()
            .name("handgate-record".into())
            .spawn(move || {
                let r = run(&opts, &channels, rx, &st, file);
                r.map(|files| RecordSummary {
                    files,
                    messages: st.written.load(Ordering::Relaxed),
                    dropped: st.dropped.load(Ordering::Relaxed),
                    bytes: st.bytes.load(Ordering::Relaxed),
                })
            })
            .map_err(|e| RecordError::Io("writer thread".into(), e))?;
        Ok(Self {
            sender: MessageSender { tx, stats },
            thread,
        })
    }

    pub fn sender(&self) -> MessageSender {
        self.sender.clone()
    }

    pub fn stats(&self) -> Arc<RecordStats> {
        self.sender.stats.clone()
    }

    /// Closes the queue, lets the writer write what it holds, finishes the files and writes
    /// `metadata.yaml`. Every [`MessageSender`] clone must be dropped first (or the writer
    /// waits for them).
    pub fn finish(self) -> Result<RecordSummary, RecordError> {
        drop(self.sender);
        self.thread
            .join()
            .map_err(|_| RecordError::Invalid("the writer thread panicked".into()))?
    }
}

/// Per-channel counts of one file (and of the whole recording).
#[derive(Debug, Default, Clone)]
struct Counts {
    per_channel: Vec<u64>,
    first: Option<u64>,
    last: u64,
    messages: u64,
}

impl Counts {
    fn add(&mut self, ch: usize, t: u64) {
        if self.per_channel.len() <= ch {
            self.per_channel.resize(ch + 1, 0);
        }
        self.per_channel[ch] += 1;
        self.first = Some(self.first.map_or(t, |f| f.min(t)));
        self.last = self.last.max(t);
        self.messages += 1;
    }
}

struct FileWriter {
    path: PathBuf,
    mcap: mcap::Writer<BufWriter<File>>,
    channel_ids: Vec<u16>,
    sequences: Vec<u32>,
    counts: Counts,
    bytes: u64,
    opened: Instant,
    last_flush: Instant,
}

/// The `offered_qos_profiles` string rosbag2 stores per topic (a YAML list of one profile,
/// rmw enum values: history 1 keep last / 2 keep all, reliability 1 reliable / 2 best effort,
/// durability 1 transient local / 2 volatile, liveliness 1 automatic; infinite durations as
/// rmw's max).
pub fn offered_qos_yaml(q: &ServedQos) -> String {
    let (history, depth) = match q.history {
        History::KeepLast(d) => (1, d.max(0)),
        History::KeepAll => (2, 0),
    };
    let reliability = match q.reliability {
        Reliability::Reliable => 1,
        Reliability::BestEffort => 2,
    };
    let durability = match q.durability {
        Durability::Volatile => 2,
        _ => 1,
    };
    let inf = "\n    sec: 2147483647\n    nsec: 4294967295";
    format!(
        "- history: {history}\n  depth: {depth}\n  reliability: {reliability}\n  durability: {durability}\n  \
         deadline:{inf}\n  lifespan:{inf}\n  liveliness: 1\n  liveliness_lease_duration:{inf}\n  \
         avoid_ros_namespace_conventions: false"
    )
}

impl FileWriter {
    fn create(opts: &RecordOptions, channels: &[ChannelSpec], index: usize) -> Result<Self, RecordError> {
        let path = opts.dir.join(format!("{}_{index}.mcap", opts.name()));
        let f = File::create(&path).map_err(|e| RecordError::Io(path.display().to_string(), e))?;
        let compression = match opts.compression {
            Compression::None => None,
            #[cfg(feature = "zstd")]
            Compression::Zstd => Some(mcap::Compression::Zstd),
            #[cfg(not(feature = "zstd"))]
            Compression::Zstd => None,
        };
        let mut mcap = mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("handgate ", env!("CARGO_PKG_VERSION")))
            .compression(compression)
            .chunk_size(Some(opts.chunk_bytes))
            .create(BufWriter::with_capacity(1 << 16, f))?;
        let mut schema_ids: BTreeMap<&str, u16> = BTreeMap::new();
        let mut channel_ids = Vec::with_capacity(channels.len());
        for c in channels {
            let wt = wire_type(&c.dds_type).expect("checked at start");
            let sid = match schema_ids.get(wt.schema.ros_type) {
                Some(id) => *id,
                None => {
                    let id = mcap.add_schema(wt.schema.ros_type, "ros2msg", wt.schema.text.as_bytes())?;
                    schema_ids.insert(wt.schema.ros_type, id);
                    id
                }
            };
            let mut meta = BTreeMap::new();
            meta.insert("offered_qos_profiles".to_string(), offered_qos_yaml(&c.qos));
            meta.insert("handgate.dds_topic".to_string(), c.dds_topic.clone());
            meta.insert("handgate.dds_type".to_string(), c.dds_type.clone());
            channel_ids.push(mcap.add_channel(sid, &ros2msg::ros_topic(&c.dds_topic), "cdr", &meta)?);
        }
        // Schemas and channels reach the disk before the first chunk.
        mcap.flush()?;
        Ok(Self {
            path,
            mcap,
            channel_ids,
            sequences: vec![0; channels.len()],
            counts: Counts::default(),
            bytes: 0,
            opened: Instant::now(),
            last_flush: Instant::now(),
        })
    }

    fn write(&mut self, m: &QueuedMessage) -> Result<(), RecordError> {
        let seq = &mut self.sequences[m.channel];
        *seq = seq.wrapping_add(1);
        self.mcap.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: self.channel_ids[m.channel],
                sequence: *seq,
                log_time: m.log_time,
                publish_time: m.publish_time,
            },
            &m.data,
        )?;
        self.counts.add(m.channel, m.log_time);
        self.bytes += m.data.len() as u64;
        Ok(())
    }

    /// Writes the handgate metadata record, the summary and the footer.
    fn finish(mut self, dropped: u64) -> Result<(PathBuf, Counts), RecordError> {
        let mut meta = BTreeMap::new();
        meta.insert("dropped_messages".to_string(), dropped.to_string());
        meta.insert("written_messages".to_string(), self.counts.messages.to_string());
        self.mcap.write_metadata(&mcap::records::Metadata {
            name: "handgate".into(),
            metadata: meta,
        })?;
        self.mcap.finish()?;
        Ok((self.path, self.counts))
    }
}

fn run(
    opts: &RecordOptions,
    channels: &[ChannelSpec],
    rx: Receiver<QueuedMessage>,
    stats: &RecordStats,
    first: FileWriter,
) -> Result<Vec<PathBuf>, RecordError> {
    let mut current = Some(first);
    let mut done: Vec<(PathBuf, Counts, u64)> = Vec::new();
    let mut index = 0;
    let result = loop {
        let file = current.as_mut().expect("a file is open while recording");
        match rx.recv_timeout(opts.flush_every) {
            Ok(m) => {
                if let Err(e) = file.write(&m) {
                    break Err(e);
                }
                stats.written.fetch_add(1, Ordering::Relaxed);
                stats.bytes.fetch_add(m.data.len() as u64, Ordering::Relaxed);
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break Ok(()),
        }
        let file = current.as_mut().expect("a file is open while recording");
        if file.last_flush.elapsed() >= opts.flush_every {
            if let Err(e) = file.mcap.flush() {
                break Err(e.into());
            }
            file.last_flush = Instant::now();
        }
        let full = opts.max_bytes.is_some_and(|b| file.bytes >= b)
            || opts.max_duration.is_some_and(|d| file.opened.elapsed() >= d);
        if full {
            index += 1;
            let next = match FileWriter::create(opts, channels, index) {
                Ok(f) => f,
                Err(e) => break Err(e),
            };
            stats.files.fetch_add(1, Ordering::Relaxed);
            let old = current.replace(next).expect("open");
            let dropped = stats.dropped.load(Ordering::Relaxed);
            match old.finish(dropped) {
                Ok((p, c)) => done.push((p, c, dropped)),
                Err(e) => break Err(e),
            }
            // metadata.yaml is kept current at every rollover.
            let _ = write_metadata_yaml(opts, channels, &done, stats);
        }
    };
    if let Some(f) = current.take() {
        let dropped = stats.dropped.load(Ordering::Relaxed);
        let (p, c) = f.finish(dropped)?;
        done.push((p, c, dropped));
    }
    write_metadata_yaml(opts, channels, &done, stats)?;
    result?;
    Ok(done.into_iter().map(|(p, _, _)| p).collect())
}

/// rosbag2's `metadata.yaml` (format version 5) for the files written so far.
fn write_metadata_yaml(
    opts: &RecordOptions,
    channels: &[ChannelSpec],
    files: &[(PathBuf, Counts, u64)],
    stats: &RecordStats,
) -> Result<(), RecordError> {
    let mut total = Counts::default();
    for (_, c, _) in files {
        for (ch, n) in c.per_channel.iter().enumerate() {
            if total.per_channel.len() <= ch {
                total.per_channel.resize(ch + 1, 0);
            }
            total.per_channel[ch] += n;
        }
        if let Some(f) = c.first {
            total.first = Some(total.first.map_or(f, |t| t.min(f)));
        }
        total.last = total.last.max(c.last);
        total.messages += c.messages;
    }
    let start = total.first.unwrap_or(0);
    let duration = total.last.saturating_sub(start);
    let mut y = String::new();
    y.push_str("rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: mcap\n");
    y.push_str(&format!("  duration:\n    nanoseconds: {duration}\n"));
    y.push_str(&format!("  starting_time:\n    nanoseconds_since_epoch: {start}\n"));
    y.push_str(&format!("  message_count: {}\n", total.messages));
    y.push_str("  topics_with_message_count:\n");
    for (i, c) in channels.iter().enumerate() {
        let wt = wire_type(&c.dds_type).expect("checked at start");
        let qos = offered_qos_yaml(&c.qos).replace('\n', "\\n");
        y.push_str(&format!(
            "    - topic_metadata:\n        name: {}\n        type: {}\n        serialization_format: cdr\n        \
             offered_qos_profiles: \"{qos}\"\n      message_count: {}\n",
            ros2msg::ros_topic(&c.dds_topic),
            wt.schema.ros_type,
            total.per_channel.get(i).copied().unwrap_or(0)
        ));
    }
    // rosbag2's own (file or message) compression is not used: zstd, when chosen, compresses
    // the MCAP chunks, which rosbag2 also reports as no compression here.
    y.push_str("  compression_format: \"\"\n  compression_mode: \"\"\n");
    y.push_str("  relative_file_paths:\n");
    for (p, _, _) in files {
        y.push_str(&format!("    - {}\n", file_name(p)));
    }
    y.push_str("  files:\n");
    for (p, c, _) in files {
        let s = c.first.unwrap_or(0);
        y.push_str(&format!(
            "    - path: {}\n      starting_time:\n        nanoseconds_since_epoch: {s}\n      duration:\n        \
             nanoseconds: {}\n      message_count: {}\n",
            file_name(p),
            c.last.saturating_sub(s),
            c.messages
        ));
    }
    y.push_str(&format!(
        "  custom_data:\n    handgate.dropped_messages: \"{}\"\n  ros_distro: \"\"\n",
        stats.dropped.load(Ordering::Relaxed)
    ));
    let path = opts.dir.join("metadata.yaml");
    std::fs::write(&path, y).map_err(|e| RecordError::Io(path.display().to_string(), e))
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bag::Bag;
    use handgate_adapters::dds::Qos;
    use handgate_idl::{to_cdr_le, unitree_hg, DdsTypeName};

    fn tmp(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("handgate-writer-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    fn channel() -> ChannelSpec {
        ChannelSpec {
            dds_topic: "rt/dex3/left/cmd".into(),
            dds_type: unitree_hg::HandCmd_::DDS_TYPE_NAME.into(),
            qos: Qos::Reliable { depth: 10 }.served(),
        }
    }

    fn cmd(q: f32) -> Vec<u8> {
        let mut c = unitree_hg::HandCmd_::sdk_default();
        c.motor_cmd[5].q = q;
        to_cdr_le(&c).unwrap()
    }

    #[test]
    fn messages_written_read_back_in_order_across_rollovers() {
        let dir = tmp("roll").join("roll");
        let mut o = RecordOptions::new(&dir);
        o.max_bytes = Some(20_000);
        let w = BagWriter::start(o, vec![channel()]).unwrap();
        let tx = w.sender();
        for k in 0..1000u64 {
            tx.send(QueuedMessage {
                channel: 0,
                publish_time: 1_000_000 + k,
                log_time: 2_000_000 + k,
                data: cmd(k as f32),
            });
        }
        drop(tx);
        let s = w.finish().unwrap();
        assert_eq!((s.messages, s.dropped), (1000, 0));
        assert!(s.files.len() > 1, "{:?}", s.files);
        let bag = Bag::open(&dir).unwrap();
        assert!(bag.truncated.is_empty(), "{:?}", bag.truncated);
        let qs: Vec<f32> = bag
            .messages
            .iter()
            .map(|m| {
                handgate_idl::from_cdr::<unitree_hg::HandCmd_>(&m.data)
                    .unwrap()
                    .motor_cmd[5]
                    .q
            })
            .collect();
        assert_eq!(qs, (0..1000).map(|k| k as f32).collect::<Vec<_>>());
        assert_eq!(bag.messages[3].publish_time, 1_000_003);
        assert_eq!(bag.messages[0].ros_topic, "/dex3/left/cmd");
        assert_eq!(bag.messages[0].dds_topic, "rt/dex3/left/cmd");
        let meta = std::fs::read_to_string(dir.join("metadata.yaml")).unwrap();
        assert!(meta.contains("message_count: 1000"), "{meta}");
        assert!(meta.contains("type: unitree_hg/msg/HandCmd"), "{meta}");
        assert!(meta.contains(&format!("- roll_{}.mcap", s.files.len() - 1)), "{meta}");
        // An existing, non-empty directory is refused.
        assert!(BagWriter::start(RecordOptions::new(&dir), vec![channel()]).is_err());
    }

    #[test]
    fn a_full_queue_drops_whole_messages_and_counts_them_in_the_file() {
        let dir = tmp("drop").join("drop");
        let mut o = RecordOptions::new(&dir);
        o.queue = 4;
        let w = BagWriter::start(o, vec![channel()]).unwrap();
        let tx = w.sender();
        let n = 20_000u64;
        for k in 0..n {
            tx.send(QueuedMessage {
                channel: 0,
                publish_time: k + 1,
                log_time: k + 1,
                data: cmd(k as f32),
            });
        }
        drop(tx);
        let s = w.finish().unwrap();
        assert_eq!(s.messages + s.dropped, n);
        let bag = Bag::open(&dir).unwrap();
        assert_eq!(bag.messages.len() as u64, s.messages);
        // Every message in the file is whole (decodes), in order.
        let mut last = -1.0;
        for m in &bag.messages {
            let q = handgate_idl::from_cdr::<unitree_hg::HandCmd_>(&m.data)
                .unwrap()
                .motor_cmd[5]
                .q;
            assert!(q > last);
            last = q;
        }
        let meta = std::fs::read_to_string(dir.join("metadata.yaml")).unwrap();
        assert!(
            meta.contains(&format!("handgate.dropped_messages: \"{}\"", s.dropped)),
            "{meta}"
        );
        let buf = std::fs::read(dir.join("drop_0.mcap")).unwrap();
        let summary = mcap::read::Summary::read(&buf).unwrap().unwrap();
        let idx = &summary.metadata_indexes[0];
        let m = mcap::read::metadata(&buf, idx).unwrap();
        assert_eq!(m.metadata["dropped_messages"], s.dropped.to_string());
    }

    #[test]
    fn a_sender_without_room_counts_instead_of_blocking() {
        let (tx, _rx) = mpsc::sync_channel(1);
        let stats = Arc::new(RecordStats::default());
        let s = MessageSender {
            tx,
            stats: stats.clone(),
        };
        for _ in 0..3 {
            s.send(QueuedMessage {
                channel: 0,
                publish_time: 0,
                log_time: 0,
                data: vec![],
            });
        }
        assert_eq!(stats.dropped.load(Ordering::Relaxed), 2);
    }

    #[test]
    fn offered_qos_is_rosbag2s_yaml() {
        let y = offered_qos_yaml(&Qos::BestEffort.served());
        assert!(
            y.starts_with("- history: 1\n  depth: 1\n  reliability: 2\n  durability: 2\n"),
            "{y}"
        );
        let y = offered_qos_yaml(&Qos::Reliable { depth: 10 }.served());
        assert!(y.contains("reliability: 1") && y.contains("depth: 10"), "{y}");
    }
}
