//! The health messages' writers (docs/fronts.md, "Health messages"): every new status snapshot
//! becomes a `/diagnostics` and a `<namespace>/hardware_status` sample, at the status rate.

use std::sync::Arc;

use handgate_adapters::dds::Node;
use handgate_adapters::ros::user_data;
use handgate_idl::handgate::GatewayStatus_;
use handgate_idl::ros2::{self, DiagnosticArray_, HardwareStatus_};
use tokio::sync::watch;
use tracing::warn;

use super::RuntimeError;
use crate::health::{HealthMessages, QOS};
use crate::plan::Plan;

pub(super) fn spawn_health(
    node: &Node,
    plan: &Plan,
    mut status: watch::Receiver<Arc<GatewayStatus_>>,
    mut shutdown: watch::Receiver<bool>,
) -> Result<tokio::task::JoinHandle<()>, RuntimeError> {
    let mut diagnostics =
        node.writer_with::<DiagnosticArray_>(ros2::DIAGNOSTICS_TOPIC, QOS, &user_data::<DiagnosticArray_>())?;
    let mut hardware = node.writer_with::<HardwareStatus_>(
        &crate::health::hardware_status_topic(plan),
        QOS,
        &user_data::<HardwareStatus_>(),
    )?;
    let health = HealthMessages::new(plan);
    Ok(tokio::spawn(async move {
        loop {
            tokio::select! {
                changed = status.changed() => {
                    if changed.is_err() {
                        break;
                    }
                    let s = status.borrow_and_update().clone();
                    let (diag, hw) = health.messages(&s, handgate_adapters::ros::time(std::time::SystemTime::now()));
                    if let Err(e) = diagnostics.write(diag) {
                        warn!("/diagnostics: {e}");
                    }
                    if let Err(e) = hardware.write(hw) {
                        warn!("hardware_status: {e}");
                    }
                }
                _ = shutdown.changed() => break,
            }
        }
    }))
}
