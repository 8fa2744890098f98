//! Periodic loops on shared threads (docs/deployment.md, "Loop threads").
//!
//! A loop with a thread of its own costs one wake-up per cycle: the `timers` benchmark
//! measured about 6 µs of CPU per wake-up on the 2-core development VM, so 32 Dex1 devices
//! and their 32 emulated services at 500 Hz spend a third of a core waking up, before doing
//! any work. Loops whose iterations never block (a DDS write, a watch send, an emulator's
//! physics) run here instead as [`Task`]s on a few shared threads. Their deadlines sit on one
//! process-wide grid ([`first_deadline`]), so loops of the same rate fall due together and
//! one wake-up serves them all; a [`Poker`] runs a task at once between its deadlines
//! (a forwarded command, a state sample).
//!
//! Loops that block (the Dex3 USB exchange on hardware, the Dynamixel bus) keep their own
//! threads: a blocking exchange must never delay another device.
//!
//! `threads = 0` gives every task a thread of its own named after it (the behaviour before
//! shared loops), running the same [`Task`] code.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, OnceLock};
use std::thread::Thread;
use std::time::{Duration, Instant};

/// One periodic loop. `run` is called at (or after) the deadline it last returned, and
/// whenever its [`Poker`] pokes it; it must not block.
pub trait Task: Send + 'static {
    /// One iteration at `now`. Returns when to run next, or `None` when the loop is done.
    fn run(&mut self, now: Instant) -> Option<Instant>;
}

/// Which loops share a pool: device loops get the `[realtime]` settings, emulated peers
/// (which stand in for another process or a hand's MCU) never do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Class {
    Devices,
    Emulators,
}

impl Class {
    fn prefix(self) -> &'static str {
        match self {
            Class::Devices => "dev-shared",
            Class::Emulators => "emu-shared",
        }
    }
}

/// Shared threads per class when nothing is configured (`[realtime] loop_threads`).
pub const DEFAULT_THREADS: usize = 2;
/// The most shared threads a profile may ask for.
pub const MAX_THREADS: usize = 64;

static DEVICE_THREADS: OnceLock<usize> = OnceLock::new();

/// Sets how many shared threads run the device loops (0: one thread per device). Call it
/// before any device opens; the first call wins (a later different value is reported).
pub fn configure_device_threads(threads: usize) -> Result<(), usize> {
    let got = *DEVICE_THREADS.get_or_init(|| threads);
    if got == threads {
        Ok(())
    } else {
        Err(got)
    }
}

fn threads_for(class: Class) -> usize {
    match class {
        Class::Devices => *DEVICE_THREADS.get_or_init(|| DEFAULT_THREADS),
        // Emulated peers: one thread, whatever their number.
        Class::Emulators => 1,
    }
}

/// The process-wide grid every task's deadlines are measured from.
fn epoch() -> Instant {
    static EPOCH: OnceLock<Instant> = OnceLock::new();
    *EPOCH.get_or_init(Instant::now)
}

/// The first instant at or after `at` on the grid of `period`: loops of the same period
/// (and of periods that divide each other) fall due at the same instants.
pub fn grid_at_or_after(at: Instant, period: Duration) -> Instant {
    let e = epoch();
    let p = period.as_nanos().max(1);
    let since = at.saturating_duration_since(e).as_nanos();
    let k = since.div_ceil(p);
    e + Duration::from_nanos(u64::try_from(k * p).unwrap_or(u64::MAX))
}

/// A new loop's first deadline: the next grid instant of its period.
pub fn first_deadline(period: Duration) -> Instant {
    grid_at_or_after(Instant::now(), period)
}

/// Control shared by a task's [`Handle`], its [`Poker`]s and the thread running it.
struct Ctl {
    poked: AtomicBool,
    stop: AtomicBool,
    /// Set once the task was dropped on its thread.
    done: Mutex<bool>,
    cv: Condvar,
    /// The thread running the task (set before the task first runs).
    thread: OnceLock<Thread>,
}

impl Ctl {
    fn new() -> Arc<Self> {
        Arc::new(Self {
            poked: AtomicBool::new(false),
            stop: AtomicBool::new(false),
            done: Mutex::new(false),
            cv: Condvar::new(),
            thread: OnceLock::new(),
        })
    }

    fn unpark(&self) {
        if let Some(t) = self.thread.get() {
            t.unpark();
        }
    }

    fn finish(&self) {
        *self.done.lock().unwrap_or_else(|p| p.into_inner()) = true;
        self.cv.notify_all();
    }
}

/// Runs a task between its deadlines. Cheap to clone; poking a stopped task does nothing.
#[derive(Clone)]
pub struct Poker(Arc<Ctl>);

impl Poker {
    pub fn poke(&self) {
        self.0.poked.store(true, Ordering::Release);
        self.0.unpark();
    }
}

/// Owns a running task: [`Handle::stop`] (or dropping it) ends the loop.
pub struct Handle {
    ctl: Arc<Ctl>,
}

impl Handle {
    pub fn poker(&self) -> Poker {
        Poker(self.ctl.clone())
    }

    /// Stops the loop; on return the task has been dropped and never runs again (called
    /// from the task's own thread, it is dropped after the current iteration). Idempotent.
    pub fn stop(&self) {
        self.ctl.stop.store(true, Ordering::Release);
        self.ctl.unpark();
        let on_own_thread = self
            .ctl
            .thread
            .get()
            .is_some_and(|t| t.id() == std::thread::current().id());
        if on_own_thread {
            return;
        }
        let done = self.ctl.done.lock().unwrap_or_else(|p| p.into_inner());
        let _done = self.ctl.cv.wait_while(done, |d| !*d).unwrap_or_else(|p| p.into_inner());
    }
}

impl Drop for Handle {
    fn drop(&mut self) {
        self.stop();
    }
}

struct Entry {
    name: String,
    task: Box<dyn Task>,
    due: Instant,
    ctl: Arc<Ctl>,
}

impl Entry {
    /// Runs the task if it is due or poked. `Some(false)`: it is done (or panicked).
    fn service(&mut self, now: Instant) -> Option<bool> {
        let poked = self.ctl.poked.swap(false, Ordering::AcqRel);
        if !(poked || self.due <= now) {
            return None;
        }
        match catch_unwind(AssertUnwindSafe(|| self.task.run(now))) {
            Ok(Some(due)) => {
                self.due = due;
                Some(true)
            }
            Ok(None) => Some(false),
            Err(_) => {
                tracing::error!(loop_name = %self.name, "loop panicked: it is stopped, the other loops on its thread run on");
                Some(false)
            }
        }
    }
}

/// One shared thread: its new tasks arrive in `inbox`.
struct Worker {
    inbox: Mutex<Vec<Entry>>,
    thread: OnceLock<Thread>,
    tasks: AtomicUsize,
}

struct Pool {
    class: Class,
    workers: Mutex<Vec<Arc<Worker>>>,
}

fn pool(class: Class) -> &'static Pool {
    static DEVICES: OnceLock<Pool> = OnceLock::new();
    static EMULATORS: OnceLock<Pool> = OnceLock::new();
    let cell = match class {
        Class::Devices => &DEVICES,
        Class::Emulators => &EMULATORS,
    };
    cell.get_or_init(|| Pool {
        class,
        workers: Mutex::new(Vec::new()),
    })
}

fn enter(class: Class) {
    if class == Class::Devices {
        crate::realtime::enter_device_loop();
    }
}

/// Starts `task` (named `name`, first run at `first`) on `class`'s threads.
pub fn spawn(class: Class, name: &str, first: Instant, task: impl Task) -> std::io::Result<Handle> {
    let ctl = Ctl::new();
    let entry = Entry {
        name: name.to_string(),
        task: Box::new(task),
        due: first,
        ctl: ctl.clone(),
    };
    let threads = threads_for(class);
    if threads == 0 {
        spawn_dedicated(class, entry)?;
    } else {
        pool(class).add(threads, entry)?;
    }
    Ok(Handle { ctl })
}

/// `threads = 0`: the task on a thread of its own, named after it.
fn spawn_dedicated(class: Class, mut e: Entry) -> std::io::Result<()> {
    let ctl = e.ctl.clone();
    let name = e.name.clone();
    let t = std::thread::Builder::new().name(name).spawn(move || {
        enter(class);
        while !e.ctl.stop.load(Ordering::Acquire) {
            if e.service(Instant::now()) == Some(false) {
                break;
            }
            let now = Instant::now();
            if e.due > now && !e.ctl.poked.load(Ordering::Acquire) {
                std::thread::park_timeout(e.due - now);
            }
        }
        let Entry { task, ctl, .. } = e;
        drop(task);
        ctl.finish();
    })?;
    let _ = ctl.thread.set(t.thread().clone());
    Ok(())
}

impl Pool {
    fn add(&self, threads: usize, entry: Entry) -> std::io::Result<()> {
        let mut workers = self.workers.lock().unwrap_or_else(|p| p.into_inner());
        let worker = if workers.len() < threads {
            let w = Arc::new(Worker {
                inbox: Mutex::new(Vec::new()),
                thread: OnceLock::new(),
                tasks: AtomicUsize::new(0),
            });
            let w2 = w.clone();
            let class = self.class;
            let t = std::thread::Builder::new()
                .name(format!("{}-{}", class.prefix(), workers.len()))
                .spawn(move || {
                    enter(class);
                    w2.run();
                })?;
            let _ = w.thread.set(t.thread().clone());
            workers.push(w.clone());
            w
        } else {
            // The least loaded thread; a task stays on the thread it was given.
            workers
                .iter()
                .min_by_key(|w| w.tasks.load(Ordering::Relaxed))
                .expect("at least one worker")
                .clone()
        };
        let thread = worker.thread.get().expect("set at spawn").clone();
        let _ = entry.ctl.thread.set(thread.clone());
        worker.tasks.fetch_add(1, Ordering::Relaxed);
        worker.inbox.lock().unwrap_or_else(|p| p.into_inner()).push(entry);
        thread.unpark();
        Ok(())
    }
}

impl Worker {
    fn run(&self) {
        let mut tasks: Vec<Entry> = Vec::new();
        loop {
            tasks.append(&mut self.inbox.lock().unwrap_or_else(|p| p.into_inner()));
            let mut now = Instant::now();
            let mut i = 0;
            while i < tasks.len() {
                let stopped = tasks[i].ctl.stop.load(Ordering::Acquire);
                let finished = !stopped && tasks[i].service(now) == Some(false);
                if stopped || finished {
                    let Entry { task, ctl, .. } = tasks.swap_remove(i);
                    drop(task);
                    self.tasks.fetch_sub(1, Ordering::Relaxed);
                    ctl.finish();
                    continue;
                }
                now = Instant::now();
                i += 1;
            }
            // Until the earliest deadline; a poke, a stop or a new task unparks earlier.
            let due = tasks.iter().map(|e| e.due).min();
            let now = Instant::now();
            match due {
                Some(d) if d <= now => {}
                Some(d) => std::thread::park_timeout(d - now),
                None => std::thread::park(),
            }
        }
    }
}

/// A task calling `tick(now)` every `period` on the grid (a late cycle is not made up in a
/// burst: the schedule skips to the next grid instant).
pub struct Periodic<F> {
    period: Duration,
    next: Instant,
    tick: F,
}

impl<F: FnMut(Instant) + Send + 'static> Periodic<F> {
    pub fn new(period: Duration, first: Instant, tick: F) -> Self {
        Self {
            period,
            next: first,
            tick,
        }
    }
}

impl<F: FnMut(Instant) + Send + 'static> Task for Periodic<F> {
    fn run(&mut self, now: Instant) -> Option<Instant> {
        if now < self.next {
            return Some(self.next);
        }
        (self.tick)(now);
        self.next += self.period;
        if self.next + self.period < now {
            self.next = grid_at_or_after(now, self.period);
        }
        Some(self.next)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc;

    #[test]
    fn grid_instants_coincide_for_loops_of_one_period() {
        let p = Duration::from_millis(2);
        let a = grid_at_or_after(Instant::now(), p);
        let b = grid_at_or_after(a + Duration::from_micros(1), p);
        assert_eq!(b - a, p, "the next grid instant after one is one period later");
        assert_eq!(grid_at_or_after(a, p), a, "a grid instant is its own");
        // A 1 ms grid holds every instant of the 2 ms grid.
        assert_eq!(grid_at_or_after(a, Duration::from_millis(1)), a);
    }

    struct Count {
        period: Duration,
        tx: mpsc::Sender<(std::thread::ThreadId, Instant)>,
        left: u32,
    }

    impl Task for Count {
        fn run(&mut self, now: Instant) -> Option<Instant> {
            let _ = self.tx.send((std::thread::current().id(), now));
            self.left = self.left.checked_sub(1)?;
            Some(now + self.period)
        }
    }

    #[test]
    fn tasks_run_on_shared_threads_until_done() {
        let (tx, rx) = mpsc::channel();
        let mut handles = Vec::new();
        for _ in 0..8 {
            let t = Count {
                period: Duration::from_millis(1),
                tx: tx.clone(),
                left: 4,
            };
            handles.push(spawn(Class::Emulators, "count", first_deadline(Duration::from_millis(1)), t).unwrap());
        }
        drop(tx);
        // Each task runs 5 times, then reports done (the channel closes when all are dropped).
        let runs: Vec<_> = rx.iter().collect();
        assert_eq!(runs.len(), 8 * 5);
        let threads: std::collections::HashSet<_> = runs.iter().map(|r| r.0).collect();
        assert_eq!(
            threads.len(),
            threads_for(Class::Emulators),
            "8 loops, one emulator thread"
        );
        for h in &handles {
            h.stop(); // already done: returns at once
        }
    }

    struct Poked {
        runs: Arc<AtomicUsize>,
    }

    impl Task for Poked {
        fn run(&mut self, now: Instant) -> Option<Instant> {
            self.runs.fetch_add(1, Ordering::SeqCst);
            Some(now + Duration::from_secs(3600))
        }
    }

    #[test]
    fn a_poke_runs_a_task_between_its_deadlines_and_stop_drops_it() {
        let runs = Arc::new(AtomicUsize::new(0));
        let h = spawn(Class::Emulators, "poked", Instant::now(), Poked { runs: runs.clone() }).unwrap();
        let start = Instant::now();
        while runs.load(Ordering::SeqCst) < 1 {
            assert!(start.elapsed() < Duration::from_secs(60), "first run never came");
            std::thread::yield_now();
        }
        // Next deadline an hour away: only the poke can run it again.
        h.poker().poke();
        while runs.load(Ordering::SeqCst) < 2 {
            assert!(start.elapsed() < Duration::from_secs(60), "the poke never ran the task");
            std::thread::yield_now();
        }
        h.stop();
        let after = runs.load(Ordering::SeqCst);
        h.poker().poke();
        // The task is dropped: a stopped task's thread serves others; run one to be sure the
        // poke was processed, then check the count did not move.
        let (tx, rx) = mpsc::channel();
        let probe = spawn(
            Class::Emulators,
            "probe",
            Instant::now(),
            Count {
                period: Duration::from_millis(1),
                tx,
                left: 0,
            },
        )
        .unwrap();
        rx.recv_timeout(Duration::from_secs(60)).expect("probe ran");
        drop(probe);
        assert_eq!(runs.load(Ordering::SeqCst), after, "a stopped task never runs again");
    }

    struct Boom;
    impl Task for Boom {
        fn run(&mut self, _now: Instant) -> Option<Instant> {
            panic!("boom (expected by the test)")
        }
    }

    #[test]
    fn a_panicking_task_stops_alone() {
        let h = spawn(Class::Emulators, "boom", Instant::now(), Boom).unwrap();
        h.stop(); // returns once it is gone, whether it had panicked yet or not
        let (tx, rx) = mpsc::channel();
        let _ok = spawn(
            Class::Emulators,
            "after-boom",
            Instant::now(),
            Count {
                period: Duration::from_millis(1),
                tx,
                left: 2,
            },
        )
        .unwrap();
        assert_eq!(rx.iter().count(), 3, "the thread serves other loops after a panic");
    }
}
