//! Replay: re-publishes a recording's messages on their DDS topics with their original
//! timing (source timestamps), scaled by a rate factor, optionally in a loop.

use std::time::{Duration, Instant};

use handgate_adapters::dds::{Node, Qos};

use crate::bag::Bag;
use crate::types::{wire_type, Sink};
use crate::{selected, RecordError};

/// How to replay.
#[derive(Debug, Clone)]
pub struct ReplayOptions {
    /// Speed factor (2.0: twice as fast).
    pub rate: f64,
    /// Start again from the beginning at the end (until `stop` says so).
    pub looped: bool,
    /// Topic globs (DDS or ROS 2 names); empty: every topic.
    pub topics: Vec<String>,
    /// How long to wait for every replayed topic to have `readers` matched readers before
    /// starting.
    pub wait_match: Duration,
    /// Matched readers to wait for on every replayed topic (at least 1).
    pub readers: u32,
    /// After the readers matched, how long to wait before the first message. A writer sees a
    /// reader matched as soon as it discovers it, but the reader may not have discovered the
    /// writer yet, and a best-effort reader (a recorder, a service's default) drops what it
    /// receives from a writer it does not know: without this pause a replay can lose its first
    /// messages to exactly the readers it waited for. There is no readiness signal for that
    /// side; 200 ms (the default of `handgate replay --settle-ms`) is a few discovery round
    /// trips on one host or a LAN.
    pub settle: Duration,
}

/// What a replay did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReplaySummary {
    pub topics: Vec<String>,
    pub published: u64,
    pub passes: u64,
    /// Topics that had fewer matched readers than asked for when the replay started.
    pub unmatched: Vec<String>,
}

/// Replays `bag` on `node` until it ends (or, looped, until `stop()` returns true).
pub fn replay(
    node: &Node,
    bag: &Bag,
    opts: &ReplayOptions,
    stop: impl Fn() -> bool,
) -> Result<ReplaySummary, RecordError> {
    if !(opts.rate.is_finite() && opts.rate > 0.0) {
        return Err(RecordError::Invalid(format!("--rate must be > 0, got {}", opts.rate)));
    }
    let mut topics: Vec<String> = Vec::new();
    let mut types: Vec<String> = Vec::new();
    let mut sinks: Vec<Box<dyn Sink>> = Vec::new();
    for (topic, ty) in bag.topics() {
        if !selected(&opts.topics, &topic) {
            continue;
        }
        let Some(wt) = wire_type(&ty) else {
            tracing::warn!(topic = %topic, type_name = %ty, "not replayed: unknown type");
            continue;
        };
        sinks.push(wt.publisher(node, &topic, Qos::Reliable { depth: 16 })?);
        topics.push(topic);
        types.push(ty);
    }
    if topics.is_empty() {
        return Err(RecordError::Invalid("no recorded topic matches --topics".into()));
    }
    let plan: Vec<(usize, u64, &[u8])> = {
        let mut v: Vec<(usize, u64, &[u8])> = bag
            .messages
            .iter()
            .filter_map(|m| {
                let i = topics
                    .iter()
                    .zip(&types)
                    .position(|(t, ty)| *t == m.dds_topic && *ty == m.dds_type)?;
                let t = if m.publish_time > 0 { m.publish_time } else { m.log_time };
                Some((i, t, m.data.as_slice()))
            })
            .collect();
        v.sort_by_key(|(_, t, _)| *t);
        v
    };
    let deadline = Instant::now() + opts.wait_match;
    let want = opts.readers.max(1);
    while sinks.iter().any(|s| s.matched() < want) && Instant::now() < deadline && !stop() {
        std::thread::sleep(Duration::from_millis(2));
    }
    // Let the matched readers discover the writers too (see `ReplayOptions::settle`).
    let settle_until = Instant::now() + opts.settle;
    while Instant::now() < settle_until && !stop() {
        std::thread::sleep(Duration::from_millis(5).min(settle_until.saturating_duration_since(Instant::now())));
    }
    let unmatched: Vec<String> = sinks
        .iter()
        .zip(&topics)
        .filter(|(s, _)| s.matched() < want)
        .map(|(_, t)| t.clone())
        .collect();
    let mut published = 0;
    let mut passes = 0;
    let Some(t0) = plan.first().map(|(_, t, _)| *t) else {
        return Ok(ReplaySummary {
            topics,
            published,
            passes,
            unmatched,
        });
    };
    'outer: loop {
        let start = Instant::now();
        for (i, t, data) in &plan {
            let due = start + Duration::from_secs_f64((t - t0) as f64 / 1e9 / opts.rate);
            loop {
                if stop() {
                    break 'outer;
                }
                let now = Instant::now();
                if now >= due {
                    break;
                }
                std::thread::sleep((due - now).min(Duration::from_millis(50)));
            }
            sinks[*i].publish(data)?;
            published += 1;
        }
        passes += 1;
        if !opts.looped || stop() {
            break;
        }
    }
    Ok(ReplaySummary {
        topics,
        published,
        passes,
        unmatched,
    })
}
