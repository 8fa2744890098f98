//! Reading a recording back: every `*.mcap` file of a recording directory (or one file), in
//! file order, message by message. A file cut short by a crash is read up to its last
//! complete record (the rest is reported, not an error).

use std::path::{Path, PathBuf};

use crate::RecordError;

/// One recorded message.
#[derive(Debug, Clone)]
pub struct BagMessage {
    /// The DDS topic it was recorded from (`rt/dex3/left/cmd`).
    pub dds_topic: String,
    /// Its ROS 2 topic (`/dex3/left/cmd`).
    pub ros_topic: String,
    /// The DDS type name.
    pub dds_type: String,
    pub log_time: u64,
    pub publish_time: u64,
    /// CDR with its encapsulation header.
    pub data: Vec<u8>,
}

/// A recording opened for reading.
#[derive(Debug)]
pub struct Bag {
    pub files: Vec<PathBuf>,
    pub messages: Vec<BagMessage>,
    /// Files that ended in a damaged or missing record (cut short), with the reader's error.
    pub truncated: Vec<(PathBuf, String)>,
}

/// The `.mcap` files of `path` (a recording directory, in rollover order) or `path` itself.
pub fn files(path: &Path) -> Result<Vec<PathBuf>, RecordError> {
    if path.is_file() {
        return Ok(vec![path.to_path_buf()]);
    }
    let rd = std::fs::read_dir(path).map_err(|e| RecordError::Io(path.display().to_string(), e))?;
    let mut files: Vec<(u64, PathBuf)> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
        .map(|p| {
            let idx = p
                .file_stem()
                .and_then(|s| s.to_str())
                .and_then(|s| s.rsplit('_').next())
                .and_then(|n| n.parse().ok())
                .unwrap_or(u64::MAX);
            (idx, p)
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(RecordError::Invalid(format!("{}: no .mcap file", path.display())));
    }
    Ok(files.into_iter().map(|(_, p)| p).collect())
}

impl Bag {
    /// Reads every message of the recording at `path` (directory or file).
    pub fn open(path: &Path) -> Result<Self, RecordError> {
        let files = files(path)?;
        let mut messages = Vec::new();
        let mut truncated = Vec::new();
        for f in &files {
            let buf = std::fs::read(f).map_err(|e| RecordError::Io(f.display().to_string(), e))?;
            for m in mcap::MessageStream::new(&buf)? {
                let m = match m {
                    Ok(m) => m,
                    Err(e) => {
                        truncated.push((f.clone(), e.to_string()));
                        break;
                    }
                };
                let meta = &m.channel.metadata;
                let dds_type = match meta.get("handgate.dds_type") {
                    Some(t) => t.clone(),
                    None => m
                        .channel
                        .schema
                        .as_ref()
                        .and_then(|s| handgate_idl::ros2msg::by_ros_type(&s.name))
                        .map(|s| s.dds_type.to_string())
                        .unwrap_or_default(),
                };
                let dds_topic = meta
                    .get("handgate.dds_topic")
                    .cloned()
                    .unwrap_or_else(|| format!("rt{}", m.channel.topic));
                messages.push(BagMessage {
                    dds_topic,
                    ros_topic: m.channel.topic.clone(),
                    dds_type,
                    log_time: m.log_time,
                    publish_time: m.publish_time,
                    data: m.data.into_owned(),
                });
            }
        }
        Ok(Self {
            files,
            messages,
            truncated,
        })
    }

    /// The recorded topics (DDS name, type), in first-seen order; a topic recorded with two
    /// types (a Dex1 `auto` front's go and hg clients) is listed once per type.
    pub fn topics(&self) -> Vec<(String, String)> {
        let mut out: Vec<(String, String)> = Vec::new();
        for m in &self.messages {
            if !out.iter().any(|(t, ty)| *t == m.dds_topic && *ty == m.dds_type) {
                out.push((m.dds_topic.clone(), m.dds_type.clone()));
            }
        }
        out
    }
}
