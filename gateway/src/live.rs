//! The Foxglove WebSocket live server (`[foxglove]`, docs/foxglove.md): the topics the
//! gateway serves as `foxglove.websocket.v1` channels, so Foxglove and PlotJuggler plot the
//! fleet with no ROS installed.
//!
//! The same topics, schemas and bytes as a recording: each (topic, type) of
//! [`crate::recording::live_topics`] is a channel named as the recorder names its MCAP
//! channel (the ROS 2 name, `rt/<x>/state` → `/<x>/state`), message encoding
//! `cdr` (little endian, with its encapsulation header), schema encoding `ros2msg` with the
//! record crate's `.msg` text. A topic served with several types (a front following its
//! clients' variant, `auto`) keeps
//! its name for its first type; each further type's channel is named `<name>/<package>`
//! (`/<x>/state/<package>`): Foxglove refuses two channels of one topic name.
//!
//! Never on a device path: the DDS readers exist only while a client subscribes to their
//! channel, polled by a [`Tap`] thread of their own; the server runs on a tokio runtime of its
//! own (one worker thread); a slow client loses its oldest messages (the foxglove crate's
//! per-client queue), nothing waits for it.

use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::Arc;

use foxglove::websocket::{ChannelView, Client, ServerListener};
use foxglove::{ChannelId, Context, PartialMetadata, RawChannel, Schema, WebSocketServer, WebSocketServerHandle};
use handgate_adapters::dds::Node;
use handgate_record::tap::{tappable, Subscribe, Tap, TapHandle, Tapped};

use crate::plan::{FoxglovePlan, Plan};

/// Why the live server did not start.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    #[error(
        "cannot listen on {addr}: {source} (another process has the port? set [foxglove] port \
         (0: any free port), or [foxglove] enabled = false)"
    )]
    Bind {
        addr: SocketAddr,
        #[source]
        source: foxglove::FoxgloveError,
    },
    #[error("{0}")]
    Channel(#[source] foxglove::FoxgloveError),
    #[error("no topic selected by [foxglove] topics {0:?}")]
    NoTopic(Vec<String>),
    #[error(transparent)]
    Tap(#[from] handgate_record::RecordError),
    #[error("its runtime: {0}")]
    Runtime(#[source] std::io::Error),
}

/// One live channel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LiveChannel {
    /// The channel's topic name.
    pub name: String,
    pub dds_topic: String,
    pub dds_type: String,
    /// Its schema name (`sensor_msgs/msg/JointState`).
    pub schema: &'static str,
}

/// The channels of `tapped`, in order (see the module documentation for the names).
pub fn channels(tapped: &[Tapped]) -> Vec<LiveChannel> {
    let mut out: Vec<LiveChannel> = Vec::with_capacity(tapped.len());
    for t in tapped {
        let ros = handgate_idl::ros2msg::ros_topic(&t.spec.dds_topic);
        let schema = t.wire.schema.ros_type;
        let name = if out.iter().any(|c| c.dds_topic == t.spec.dds_topic) {
            let package = schema.split('/').next().unwrap_or(schema);
            format!("{ros}/{package}")
        } else {
            ros
        };
        out.push(LiveChannel {
            name,
            dds_topic: t.spec.dds_topic.clone(),
            dds_type: t.spec.dds_type.clone(),
            schema,
        });
    }
    out
}

/// Subscriptions of the server's clients, handed to the tap: a channel's DDS reader exists
/// while at least one client subscribes to it.
struct Subscriptions {
    by_channel: HashMap<ChannelId, usize>,
    tap: TapHandle,
}

impl ServerListener for Subscriptions {
    fn on_subscribe(&self, _client: Client, channel: ChannelView) {
        if let Some(&i) = self.by_channel.get(&channel.id()) {
            tracing::debug!(topic = channel.topic(), "foxglove: subscribed");
            self.tap.subscribe(i);
        }
    }

    fn on_unsubscribe(&self, _client: Client, channel: ChannelView) {
        if let Some(&i) = self.by_channel.get(&channel.id()) {
            tracing::debug!(topic = channel.topic(), "foxglove: unsubscribed");
            self.tap.unsubscribe(i);
        }
    }
}

/// The running live server.
pub struct Live {
    /// Holds the channels: the server keeps only a weak reference.
    _context: Arc<Context>,
    tap: Option<Tap>,
    server: Option<WebSocketServerHandle>,
    runtime: Option<tokio::runtime::Runtime>,
    /// Where it listens (`ws://ADDR`).
    pub url: String,
    pub channels: Vec<LiveChannel>,
}

impl std::fmt::Debug for Live {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Live")
            .field("url", &self.url)
            .field("channels", &self.channels.len())
            .finish()
    }
}

impl Live {
    /// Advertises `plan`'s live topics ([`FoxglovePlan::topics`]) and listens on
    /// [`FoxglovePlan::addr`]. Blocks the calling thread until the server listens (or failed
    /// to), which may be inside the gateway's runtime: the server runs on its own.
    pub fn start(node: &Node, plan: &Plan, f: &FoxglovePlan) -> Result<Live, LiveError> {
        let tapped = tappable(crate::recording::live_topics(plan, &f.topics), "foxglove");
        if tapped.is_empty() {
            return Err(LiveError::NoTopic(f.topics.clone()));
        }
        let described = channels(&tapped);
        let ctx = Context::new();
        let mut raw: Vec<Arc<RawChannel>> = Vec::with_capacity(described.len());
        for (c, t) in described.iter().zip(&tapped) {
            let schema = Schema::new(c.schema, "ros2msg", t.wire.schema.text.as_bytes());
            raw.push(
                ctx.channel_builder(c.name.as_str())
                    .message_encoding("cdr")
                    .schema(schema)
                    .build_raw()
                    .map_err(LiveError::Channel)?,
            );
        }
        let by_channel = raw.iter().enumerate().map(|(i, c)| (c.id(), i)).collect();
        let sinks = raw.clone();
        // Message times are the samples' DDS source timestamps: the tap takes them every
        // 20 ms, and its poll time would give a 100 Hz topic's samples pairs of equal times.
        let tap = Tap::start(node, &tapped, Subscribe::OnDemand, "handgate-foxglove-poll", move |s| {
            if let Some(c) = sinks.get(s.topic) {
                c.log_with_meta(&s.data, PartialMetadata::with_log_time(s.publish_time));
            }
        })?;
        let listener = Arc::new(Subscriptions {
            by_channel,
            tap: tap.handle(),
        });
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("handgate-foxglove")
            .enable_all()
            .build()
            .map_err(LiveError::Runtime)?;
        // The foxglove crate joins HOST and PORT with a colon: an IPv6 host needs brackets.
        let host = match f.addr {
            SocketAddr::V4(a) => a.ip().to_string(),
            SocketAddr::V6(a) => format!("[{}]", a.ip()),
        };
        let server = WebSocketServer::new()
            .name(format!("handgate {}", plan.profile))
            .context(&ctx)
            .bind(host, f.addr.port())
            .listener(listener);
        let (tx, rx) = std::sync::mpsc::channel();
        runtime.spawn(async move {
            let _ = tx.send(server.start().await);
        });
        let handle = match rx.recv() {
            Ok(Ok(h)) => h,
            failed => {
                // Dropping a runtime blocks, which the gateway's own runtime forbids here.
                runtime.shutdown_background();
                return Err(match failed {
                    Ok(Err(source)) => LiveError::Bind { addr: f.addr, source },
                    _ => LiveError::Runtime(std::io::Error::other("the server task ended")),
                });
            }
        };
        let addr = SocketAddr::new(f.addr.ip(), handle.port());
        let url = format!("ws://{addr}");
        if addr.ip().is_loopback() {
            tracing::info!(url = %url, channels = raw.len(), "foxglove: listening");
        } else {
            tracing::warn!(
                url = %url,
                channels = raw.len(),
                "foxglove: listening on a non-loopback address ([foxglove] bind): every live \
                 topic is readable from the network, without authentication"
            );
        }
        Ok(Live {
            _context: ctx,
            tap: Some(tap),
            server: Some(handle),
            runtime: Some(runtime),
            url,
            channels: described,
        })
    }

    /// Closes the clients' connections and stops polling.
    pub async fn stop(mut self) {
        if let Some(h) = self.server.take() {
            h.stop().wait().await;
        }
        if let Some(t) = self.tap.take() {
            let _ = tokio::task::spawn_blocking(move || t.stop()).await;
        }
        if let Some(rt) = self.runtime.take() {
            rt.shutdown_background();
        }
    }
}

impl Drop for Live {
    fn drop(&mut self) {
        if let Some(h) = self.server.take() {
            h.stop().detach_all();
        }
        // The tap stops when dropped; a runtime dropped here may be inside another's context.
        if let Some(rt) = self.runtime.take() {
            rt.shutdown_background();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channels_of_the_default_fleet_are_ros_names_with_unique_names_per_type() {
        let plan = crate::resolve::default_plan();
        let c = channels(&tappable(crate::recording::live_topics(&plan, &[]), "test"));
        let find = |name: &str| {
            c.iter()
                .find(|c| c.name == name)
                .unwrap_or_else(|| panic!("no channel {name}: {c:#?}"))
        };
        assert_eq!(find("/joint_states").schema, "sensor_msgs/msg/JointState");
        assert_eq!(find("/dex3/left/state").schema, "unitree_hg/msg/HandState");
        assert_eq!(find("/handgate/dex3_left/state").schema, "handgate/msg/HandState");
        assert_eq!(find("/handgate/status").schema, "handgate/msg/GatewayStatus");
        // The Dex1 `auto` front's state: go first under the topic's name, hg beside it.
        assert_eq!(find("/dex1/left/state").schema, "unitree_go/msg/MotorStates");
        let hg = find("/dex1/left/state/unitree_hg");
        assert_eq!(
            (hg.dds_topic.as_str(), hg.schema),
            ("rt/dex1/left/state", "unitree_hg/msg/HandState")
        );
        let mut names: Vec<&str> = c.iter().map(|c| c.name.as_str()).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), c.len(), "channel names are unique: {c:#?}");
    }
}
