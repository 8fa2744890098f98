//! A DDS-client device dropped while its state reader's listener runs (docs/reliability.md,
//! "Teardown"). The listener takes the sample a forwarded command awaits through the device
//! loop (`Wake::inline` upgrades the loop's weak handle for the call). If the device stops its
//! loop meanwhile, that listener call holds the last reference to the loop, and the loop (its
//! command writer with it) would be dropped inside the listener: deleting a writer from a
//! listener that CycloneDDS runs on a thread it counts as awake (an in-process writer's own
//! thread, delivering locally) waits for CycloneDDS's garbage collector, which waits for that
//! same thread. The listener never returns, and the device's drop, deleting the reader, waits
//! for it forever (seen as a hung `adapters/tests/forwarding.rs`). Domain 44.

#[path = "support/dex1_client.rs"]
mod dex1_client;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::Arc;
use std::time::Duration;

use handgate_adapters::dds::{Node, Qos};
use handgate_adapters::dds_device::{DdsDevice, Forwarding};
use handgate_adapters::device::HandDevice;
use handgate_adapters::model::HandCommand;
use handgate_idl::unitree_go::{MotorState_, MotorStates_};

const DOMAIN: u32 = 44;
/// The service thread's name: a state tap running on it runs inside the device's listener.
const SERVICE: &str = "state-service";
/// How long the listener is held once inside (a listener thread preempted there, or a slow
/// tap): long enough for the drop to stop the loop meanwhile.
const HELD: Duration = Duration::from_millis(200);
/// Far above what a drop takes (the listener's hold, then the reader's deletion).
const DROP_DEADLINE: Duration = Duration::from_secs(20);

fn device(node: &Node) -> DdsDevice {
    dex1_client::dex1_client(node, 2.0, Forwarding::default_for(2.0))
}

/// A service in this process publishes state samples back to back from its own thread, so each
/// is delivered locally, the device's listener running on that thread. The device forwards a
/// command; the sample it awaits is taken in the listener through the loop, and a state tap
/// holds the listener there while the device is dropped. The drop must return.
#[test]
fn a_device_dropped_while_its_listener_holds_the_loop_returns() {
    let node = Node::new(DOMAIN, None).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let service = {
        let (node, stop) = (node.clone(), stop.clone());
        std::thread::Builder::new()
            .name(SERVICE.into())
            .spawn(move || {
                let mut w = node
                    .writer::<MotorStates_>("rt/dex1/right/state", Qos::BestEffort)
                    .unwrap();
                let mut q = 0.0f32;
                while !stop.load(Ordering::Relaxed) {
                    q = (q + 0.001) % 5.0;
                    let s = MotorStates_ {
                        states: vec![MotorState_ {
                            q,
                            ..Default::default()
                        }],
                    };
                    w.write(s).unwrap();
                    std::thread::yield_now();
                }
            })
            .unwrap()
    };

    let dev = device(&node);
    let (inside_tx, inside_rx) = mpsc::channel();
    let held = Arc::new(AtomicBool::new(false));
    let h = held.clone();
    dev.state_taps()
        .expect("a DDS device has state taps")
        .add(Box::new(move |_| {
            if std::thread::current().name() == Some(SERVICE) && !h.swap(true, Ordering::AcqRel) {
                let _ = inside_tx.send(());
                std::thread::sleep(HELD);
            }
        }));
    // Forwarded on arrival: the next sample is awaited, and taken in the listener, unless the
    // loop happened to be running then (the sample is then taken by the loop, on its own
    // thread): a new command awaits a new sample, until one is taken in the listener.
    let mut inside = false;
    for seq in 1..=50u64 {
        dev.command(HandCommand::closure(seq, 0.25 + 0.01 * seq as f32))
            .unwrap();
        if inside_rx.recv_timeout(Duration::from_millis(500)).is_ok() {
            inside = true;
            break;
        }
    }
    assert!(
        inside,
        "no awaited sample was taken in the listener, on the service's thread, in 50 commands"
    );

    let (done_tx, done_rx) = mpsc::channel();
    let dropper = std::thread::spawn(move || {
        drop(dev);
        let _ = done_tx.send(());
    });
    if done_rx.recv_timeout(DROP_DEADLINE).is_err() {
        panic!(
            "the device's drop did not return within {DROP_DEADLINE:?}: its loop was dropped inside the \
             listener holding it, deleting its writer there (deadlock at teardown)"
        );
    }
    dropper.join().unwrap();
    stop.store(true, Ordering::Relaxed);
    service.join().unwrap();
}
