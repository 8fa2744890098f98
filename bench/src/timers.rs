//! Benchmark 4b: what a loop's own thread costs (#17 part 5, docs/deployment.md "Loop
//! threads"). `n` empty periodic loops at `hz`, run two ways in one process, one after the
//! other, each for `secs`:
//!
//! - **own threads**: each loop a thread sleeping to its absolute deadlines (what every
//!   device loop was), its phase where it happened to start (spread over the period);
//! - **shared**: the same loops as tasks of `handgate_adapters::loops` (the code the DDS-client
//!   device loops run on), their deadlines on the process grid.
//!
//! Reported per way: the process's CPU (% of one core, and µs per loop cycle), and how late
//! each iteration ran after its deadline (the price of sharing: loops due together run one
//! after the other).

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use handgate_adapters::loops::{self, Task};
use serde::{Deserialize, Serialize};

use crate::stats::{cpu_seconds, Summary};

#[derive(Debug, Serialize, Deserialize)]
pub struct Way {
    pub way: String,
    pub loops: usize,
    pub hz: f64,
    pub secs: f64,
    pub cycles: u64,
    /// % of one core, the whole process, over the window.
    pub cpu_pct: f64,
    pub cpu_us_per_cycle: f64,
    /// µs after the deadline each iteration started.
    pub late_us: Option<Summary>,
    /// Machine load average (1 min) at the end of the window.
    pub load1: f64,
}

#[derive(Debug, Serialize, Deserialize)]
pub struct Result {
    pub ways: Vec<Way>,
}

/// Lateness samples, shared by every loop of a way (one lock per iteration: the same for both
/// ways, and small next to a wake-up).
type Late = Arc<Mutex<Vec<f64>>>;

struct Empty {
    period: Duration,
    next: Instant,
    end: Instant,
    late: Late,
}

impl Task for Empty {
    fn run(&mut self, now: Instant) -> Option<Instant> {
        if now < self.next {
            return Some(self.next);
        }
        if now >= self.end {
            return None;
        }
        self.late
            .lock()
            .unwrap()
            .push(now.duration_since(self.next).as_secs_f64() * 1e6);
        self.next += self.period;
        Some(self.next)
    }
}

fn load1() -> f64 {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse().ok())
        .unwrap_or(f64::NAN)
}

fn finish(way: &str, n: usize, hz: f64, secs: f64, cpu0: f64, t0: Instant, late: &Late) -> Way {
    let wall = t0.elapsed().as_secs_f64();
    let cpu = cpu_seconds(std::process::id()).unwrap_or(cpu0) - cpu0;
    let late = std::mem::take(&mut *late.lock().unwrap());
    Way {
        way: way.into(),
        loops: n,
        hz,
        secs,
        cycles: late.len() as u64,
        cpu_pct: 100.0 * cpu / wall,
        cpu_us_per_cycle: 1e6 * cpu / (late.len().max(1) as f64),
        late_us: Summary::of(&late),
        load1: load1(),
    }
}

pub fn run(n: usize, hz: f64, secs: f64) -> Result {
    let period = Duration::from_secs_f64(1.0 / hz);
    let mut ways = Vec::new();

    // Own threads: absolute deadlines, phases spread over the period as independent starts give.
    let late: Late = Default::default();
    let cpu0 = cpu_seconds(std::process::id()).unwrap_or(0.0);
    let t0 = Instant::now();
    let end = t0 + Duration::from_secs_f64(secs);
    let threads: Vec<_> = (0..n)
        .map(|i| {
            let mut task = Empty {
                period,
                next: t0 + period.mul_f64(i as f64 / n as f64),
                end,
                late: late.clone(),
            };
            std::thread::spawn(move || {
                let mut due = task.next;
                loop {
                    let now = Instant::now();
                    if due > now {
                        std::thread::sleep(due - now);
                        continue;
                    }
                    match task.run(now) {
                        Some(d) => due = d,
                        None => return,
                    }
                }
            })
        })
        .collect();
    for t in threads {
        let _ = t.join();
    }
    ways.push(finish("own threads", n, hz, secs, cpu0, t0, &late));

    // Shared: the loops module, as the device loops use it.
    let late: Late = Default::default();
    let cpu0 = cpu_seconds(std::process::id()).unwrap_or(0.0);
    let t0 = Instant::now();
    let end = t0 + Duration::from_secs_f64(secs);
    let handles: Vec<_> = (0..n)
        .map(|_| {
            let first = loops::first_deadline(period);
            let task = Empty {
                period,
                next: first,
                end,
                late: late.clone(),
            };
            loops::spawn(loops::Class::Devices, "bench-loop", first, task).expect("spawn a loop")
        })
        .collect();
    // Each task ends itself at `end`; stop() returns once it has.
    for h in &handles {
        while Instant::now() < end {
            std::thread::sleep(Duration::from_millis(50));
        }
        h.stop();
    }
    ways.push(finish(
        &format!("shared ({} threads)", loops::DEFAULT_THREADS),
        n,
        hz,
        secs,
        cpu0,
        t0,
        &late,
    ));
    Result { ways }
}
