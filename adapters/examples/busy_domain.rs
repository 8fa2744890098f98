//! A busy DDS domain for benchmarks: K endpoints (half writers, half readers) on distinct
//! topics in this process, until stdin closes; optionally churning (every second, C of them
//! deleted and created again, so discovery keeps working while a benchmark measures).
//!
//! ```sh
//! cargo run --release -p handgate-adapters --example busy_domain -- <domain> [K=500] [C=0] [prefix]
//! ```
//!
//! Prints `READY <k>` once every endpoint exists (discovery by peers takes a moment more),
//! then `CHURNED <n>` on exit (endpoints deleted and re-created in all).

use std::io::Read;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::dds::Node;
use handgate_adapters::discovery::busy_endpoints;

/// Endpoints are made in groups of this size; churn replaces whole groups.
const GROUP: usize = 10;

fn main() {
    let mut args = std::env::args().skip(1);
    let usage = "usage: busy_domain <domain> [K=500] [churn per second=0] [topic prefix=rt/busy/]";
    let domain: u32 = args.next().and_then(|a| a.parse().ok()).expect(usage);
    let k: usize = args.next().map_or(500, |a| a.parse().expect(usage));
    let churn: usize = args.next().map_or(0, |a| a.parse().expect(usage));
    let prefix = args.next().unwrap_or_else(|| "rt/busy/".to_string());
    let node = Node::new(domain, None).expect("join the domain");
    let group = |g: usize| {
        busy_endpoints(&node, GROUP.min(k - g * GROUP), &format!("{prefix}{g}/")).expect("create the endpoints")
    };
    let mut groups: Vec<_> = (0..k.div_ceil(GROUP)).map(group).collect();
    println!("READY {}", groups.iter().map(|g| g.len()).sum::<usize>());
    let closed = Arc::new(AtomicBool::new(false));
    let c = closed.clone();
    std::thread::spawn(move || {
        let _ = std::io::stdin().read_to_end(&mut Vec::new());
        c.store(true, Ordering::Relaxed);
    });
    let (mut next, mut churned) = (0usize, 0usize);
    let mut tick = Instant::now();
    while !closed.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(20));
        if churn == 0 || groups.is_empty() || tick.elapsed() < Duration::from_secs(1) {
            continue;
        }
        tick += Duration::from_secs(1);
        for _ in 0..churn.div_ceil(GROUP) {
            let g = next % groups.len();
            groups[g] = busy_endpoints(&node, 0, "").expect("empty group"); // deletes group g
            groups[g] = group(g);
            churned += groups[g].len();
            next += 1;
        }
    }
    println!("CHURNED {churned}");
}
