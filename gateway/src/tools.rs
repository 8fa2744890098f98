//! Bring-up tools behind the CLI: `handgate status` (a live table from the gateway's status
//! topic) and `handgate send` (one command in the canonical model to a named device).

use std::fmt::Write as _;
use std::time::Duration;

use handgate_adapters::dds::{DdsError, Node, Qos};
use handgate_idl::handgate as hg;

/// Renders one status sample as a table.
pub fn render_status(s: &hg::GatewayStatus_) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "profile {}  uptime {:.1} s",
        s.profile,
        s.uptime_ms as f64 / 1000.0
    );
    let _ = writeln!(
        out,
        "{:<16} {:<10} {:<9} {:<9} {:>5} {:>9} {:>9} {:>8} {:>6} {:>6} {:>6} {:>6} {:>9}",
        "device",
        "kind",
        "backend",
        "state",
        "safe",
        "cmd Hz",
        "state Hz",
        "age ms",
        "crc",
        "bad",
        "wdog",
        "recon",
        "missed"
    );
    for d in &s.devices {
        let fresh = match d.freshness {
            hg::FRESH => "fresh",
            hg::STALE => "STALE",
            hg::COMMANDED_ONLY => "cmd-only",
            _ => "?",
        };
        let _ = writeln!(
            out,
            "{:<16} {:<10} {:<9} {:<9} {:>5} {:>9.1} {:>9.1} {:>8.1} {:>6} {:>6} {:>6} {:>6} {:>9}",
            d.device,
            d.kind,
            d.backend,
            fresh,
            if d.safe { "yes" } else { "no" },
            d.cmd_rate_hz,
            d.state_rate_hz,
            d.age_ms,
            d.crc_errors,
            d.bad_input,
            d.watchdog_trips,
            d.reconnects,
            d.missed_cycles
        );
    }
    if s.record_messages > 0 || s.record_dropped > 0 {
        let _ = writeln!(
            out,
            "recording: {} message(s) written, {} dropped",
            s.record_messages, s.record_dropped
        );
    }
    out
}

/// Waits for one status sample.
pub fn status_once(node: &Node, topic: &str, timeout: Duration) -> Result<hg::GatewayStatus_, DdsError> {
    let r = node.reader::<hg::GatewayStatus_>(topic, Qos::Reliable { depth: 1 })?;
    let mut v = r.wait_take(timeout)?;
    Ok(v.pop().expect("wait_take returns at least one sample"))
}

/// Publishes a command to handgate's own interface `rt/handgate/{device}/cmd` after the gateway's reader has
/// matched, repeating it at 50 Hz for `hold` (the front's watchdog holds the device once the
/// stream stops). Returns how many samples were written.
pub fn send(node: &Node, device: &str, cmd: hg::HandCmd_, timeout: Duration, hold: Duration) -> Result<u64, DdsError> {
    let (topic, _) = handgate_adapters::fronts::own_topics(device);
    let mut w = node.writer::<hg::HandCmd_>(&topic, Qos::Reliable { depth: 1 })?;
    w.wait_matched(1, timeout)?;
    let start = std::time::Instant::now();
    let mut n: u64 = 0;
    loop {
        w.write(hg::HandCmd_ {
            seq: n + 1,
            ..cmd.clone()
        })?;
        n += 1;
        let next = start + Duration::from_millis(20) * n as u32;
        if next.duration_since(start) > hold {
            break;
        }
        std::thread::sleep(next.saturating_duration_since(std::time::Instant::now()));
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_a_row_per_device() {
        let s = hg::GatewayStatus_ {
            profile: "default".into(),
            uptime_ms: 1500,
            devices: vec![hg::DeviceStatus_ {
                device: "left_hand".into(),
                kind: handgate_adapters::kind::DeviceKind::default().as_str().into(),
                freshness: hg::STALE,
                ..Default::default()
            }],
            ..Default::default()
        };
        let t = render_status(&s);
        assert!(t.contains("left_hand") && t.contains("STALE") && t.contains("uptime 1.5 s"));
        assert!(!t.contains("recording"));
        let t = render_status(&hg::GatewayStatus_ {
            record_messages: 10,
            record_dropped: 2,
            ..s
        });
        assert!(t.contains("recording: 10 message(s) written, 2 dropped"), "{t}");
    }
}
