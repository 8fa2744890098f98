//! Recording handgate's DDS traffic as a rosbag2-shaped MCAP directory (`NAME/NAME_0.mcap`
//! plus `metadata.yaml`, MCAP `ros2` profile: CDR messages, `ros2msg` schemas, chunk and
//! message indexes, a summary), replaying a recording onto DDS with its original timing, and
//! exporting a recording's hand streams as xr_teleoperate episode fields.
//!
//! The recorder never runs on a device path: its readers are polled by a thread of its own
//! ([`tap`], shared with the gateway's live Foxglove server; DDS only stores samples in their
//! history, as for any reader), the messages go through a
//! bounded queue to a writer thread, and when the disk is slower than the stream whole
//! messages are dropped and counted ([`RecordStats`]), in the file's metadata too.
//! docs/recording.md says how to use it.

pub mod bag;
pub mod export;
pub mod recorder;
pub mod replay;
pub mod tap;
pub mod types;
pub mod writer;

pub use recorder::{Recorder, TopicSpec};
pub use tap::{Sample, Subscribe, Tap, TapHandle, Tapped};
pub use writer::{Compression, RecordOptions, RecordStats};

/// Errors of recording, replay and export.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error("{0}: {1}")]
    Io(String, #[source] std::io::Error),
    #[error("MCAP: {0}")]
    Mcap(#[from] mcap::McapError),
    #[error(transparent)]
    Dds(#[from] handgate_adapters::dds::DdsError),
    #[error("topic {0}: cannot decode a recorded message: {1}")]
    Decode(String, String),
    #[error("{0}")]
    Invalid(String),
}

/// Whether `name` matches the glob `pattern` (`*` any run of characters, `?` one character).
pub fn glob_match(pattern: &str, name: &str) -> bool {
    let p: Vec<char> = pattern.chars().collect();
    let n: Vec<char> = name.chars().collect();
    let (mut pi, mut ni) = (0, 0);
    let (mut star, mut mark) = (None, 0);
    while ni < n.len() {
        if pi < p.len() && (p[pi] == '?' || p[pi] == n[ni]) {
            pi += 1;
            ni += 1;
        } else if pi < p.len() && p[pi] == '*' {
            star = Some(pi);
            mark = ni;
            pi += 1;
        } else if let Some(s) = star {
            pi = s + 1;
            mark += 1;
            ni = mark;
        } else {
            return false;
        }
    }
    while pi < p.len() && p[pi] == '*' {
        pi += 1;
    }
    pi == p.len()
}

/// Whether a topic (by its DDS or ROS 2 name) is selected by `globs` (none: every topic).
pub fn selected(globs: &[String], dds_topic: &str) -> bool {
    let ros = handgate_idl::ros2msg::ros_topic(dds_topic);
    globs.is_empty() || globs.iter().any(|g| glob_match(g, dds_topic) || glob_match(g, &ros))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn globs() {
        assert!(glob_match("*", "rt/dex3/left/state"));
        assert!(glob_match("/dex3/*/cmd", "/dex3/left/cmd"));
        assert!(!glob_match("/dex3/*/cmd", "/dex3/left/state"));
        assert!(glob_match("rt/dex?/left/*", "rt/dex1/left/state"));
        assert!(selected(&["/dex3/*".into()], "rt/dex3/left/state"));
        assert!(selected(&[], "anything"));
        assert!(!selected(&["/dex1/*".into()], "rt/dex3/left/state"));
    }
}
