//! handgate's ROS 2 node on `ros_discovery_info` (docs/fronts.md, "ROS 2"): published once
//! every front and the status writer are open, then again whenever the participant's readers
//! and writers change.

use std::time::Duration;

use handgate_adapters::dds::Node;
use handgate_adapters::ros::{Namespace, Presence};
use tokio::sync::watch;
use tracing::warn;

use super::RuntimeError;
use crate::ticker::Ticker;

/// How often the endpoint list is compared with what was published (a cheap lock and compare).
const CHECK_PERIOD: Duration = Duration::from_millis(200);

pub(super) fn spawn_presence(
    node: &Node,
    namespace: Namespace,
    mut shutdown: watch::Receiver<bool>,
) -> Result<tokio::task::JoinHandle<()>, RuntimeError> {
    let mut presence = Presence::new(node, namespace)?;
    presence.update()?;
    Ok(tokio::spawn(async move {
        let mut tick = Ticker::new(CHECK_PERIOD);
        loop {
            tokio::select! {
                _ = tick.tick() => {
                    if let Err(e) = presence.update() {
                        warn!("ros_discovery_info: {e}");
                    }
                }
                _ = shutdown.changed() => break,
            }
        }
    }))
}
