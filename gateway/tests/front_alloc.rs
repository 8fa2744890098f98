//! No heap allocation of handgate's own on a device loop's thread when a front publishes from
//! it (issue #30: a front driven by its devices publishes the state from the device's loop,
//! `HandDevice::state_taps`). `adapters/tests/rt_alloc.rs` proves the loops themselves; this
//! test runs the gateway's runtime in-process on a profile with one emulated Dex3-1 and its
//! `dex3` front, and counts what the device loop's thread (`dex3-usb-loop`) allocates over
//! [`STATES`] published states after a warm-up, with the same counting allocator (this test
//! binary only).
//!
//! - With no client on the front's state topic, the front neither builds nor writes a message
//!   (`Writer::write_with`), and its views of the devices are on the stack: nothing at all.
//! - With a client, the front's kind builds each message (`FrontCodec::encode` returns an owned
//!   message, which cyclonedds-rs takes as an `Arc`): those allocations are measured and
//!   printed (docs/deployment.md, "Real-time"), not asserted away; the test asserts that the
//!   front's writes do run on the loop's thread, which is what makes the first half mean
//!   something.
//!
//! Counts are per published state, never per second: a busy machine makes the window longer.

#[path = "../../adapters/tests/support/counting.rs"]
mod counting;
mod support;

use std::time::Duration;

use counting::{thread_named, Counts};
use handgate_adapters::dds::{Node, Qos};
use handgate_gateway::runtime::Runtime;
use handgate_idl::unitree_hg::HandState_;

/// DDS domain (docs/development.md, "DDS domain ids for tests").
const DOMAIN: u32 = 65;
/// States published before counting: every buffer at its steady-state capacity.
const WARM_UP: u64 = 200;
/// States counted.
const STATES: u64 = 500;
/// Bound on any wait (a starved machine only makes it slower).
const DEADLINE: Duration = Duration::from_secs(60);

/// What the loop thread `tid` allocated while the device published `n` states after `skip`.
async fn window(
    tid: i32,
    rx: &mut tokio::sync::watch::Receiver<handgate_adapters::model::HandState>,
    skip: u64,
    n: u64,
) -> Counts {
    let states = async {
        for _ in 0..skip {
            rx.changed().await.unwrap();
        }
        let before = Counts::of(tid);
        for _ in 0..n {
            rx.changed().await.unwrap();
        }
        Counts::of(tid).since(before)
    };
    tokio::time::timeout(DEADLINE, states)
        .await
        .expect("the device published no states")
}

fn report(what: &str, c: &Counts) -> String {
    let (own, own_bytes) = c.own();
    format!(
        "{what}: {STATES} states: {own} allocations ({own_bytes} B) of handgate's own = {:.2}/state; \
         inside the front's DDS writes {} allocations ({} B) = {:.2}/state",
        own as f64 / STATES as f64,
        c.write_allocs,
        c.write_bytes,
        c.write_allocs as f64 / STATES as f64,
    )
}

#[test]
fn a_front_publishing_from_a_device_loop_allocates_nothing_there_without_a_client() {
    let _ = tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::new("info"))
        .with_writer(std::io::sink)
        .try_init();
    let plan = support::plan_of(
        "front-alloc.toml",
        &format!(
            r#"name = "front-alloc"
[dds]
domain = {DOMAIN}
[[devices]]
name = "hand"
kind = "dex3"
side = "left"
backend = "emulator"
[[fronts]]
kind = "dex3"
device = "hand"
"#
        ),
    );
    let state_topic = plan.fronts[0].state_topic().to_string();
    let rt = tokio::runtime::Runtime::new().unwrap();
    rt.block_on(async {
        let gw = Runtime::start(&plan).unwrap();
        let tid = thread_named("dex3-usb-loop", DEADLINE);
        let mut rx = gw.devices[0].device.state();

        // No client: nothing reads the front's state.
        let idle = window(tid, &mut rx, WARM_UP, STATES).await;
        println!("{}", report("no client", &idle));

        // A client on the front's state topic, once its first sample arrived.
        let node = Node::new(DOMAIN, None).unwrap();
        let reader = node.reader::<HandState_>(&state_topic, Qos::BestEffort).unwrap();
        tokio::time::timeout(DEADLINE, async {
            while reader.take().is_empty() {
                tokio::time::sleep(Duration::from_millis(1)).await;
            }
        })
        .await
        .expect("no state reached the client");
        let client = window(tid, &mut rx, WARM_UP, STATES).await;
        println!("{}", report("a client", &client));
        drop(reader);
        for (name, r) in gw.shutdown().await {
            r.unwrap_or_else(|e| panic!("{name}: {e}"));
        }

        // The front publishes from the device's loop: its writes were on this thread.
        assert!(
            client.write_allocs > 0,
            "with a client, no front write ran on the device loop's thread: {}",
            report("a client", &client)
        );
        let (own, _) = idle.own();
        assert_eq!(
            (own, idle.write_allocs),
            (0, 0),
            "with no client, the device loop's thread allocated while its front published: {}",
            report("no client", &idle)
        );
    });
}
