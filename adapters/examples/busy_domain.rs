//! A busy DDS domain for benchmarks: K endpoints (half writers, half readers) on distinct
//! topics in this process, until stdin closes.
//!
//! ```sh
//! cargo run --release -p handgate-adapters --example busy_domain -- <domain> [K=500] [prefix]
//! ```
//!
//! Prints `READY <k>` once every endpoint exists (discovery by peers takes a moment more).

use std::io::Read;

use handgate_adapters::dds::Node;
use handgate_adapters::discovery::busy_endpoints;

fn main() {
    let mut args = std::env::args().skip(1);
    let usage = "usage: busy_domain <domain> [K=500] [topic prefix=rt/busy/]";
    let domain: u32 = args.next().and_then(|a| a.parse().ok()).expect(usage);
    let k: usize = args.next().map_or(500, |a| a.parse().expect(usage));
    let prefix = args.next().unwrap_or_else(|| "rt/busy/".to_string());
    let node = Node::new(domain, None).expect("join the domain");
    let busy = busy_endpoints(&node, k, &prefix).expect("create the endpoints");
    println!("READY {}", busy.len());
    let _ = std::io::stdin().read_to_end(&mut Vec::new());
}
