//! A counting global allocator for a test binary: one slot of counters per thread (found by
//! the kernel thread id), split by where the thread is in handgate's DDS layer
//! ([`handgate_adapters::dds::within`]). Included (`#[path]`) by the tests that prove a
//! device loop's cycle allocates nothing of its own: `adapters/tests/rt_alloc.rs` and
//! `gateway/tests/front_alloc.rs`. Installing it in a test binary counts that binary only.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicI32, AtomicU64, AtomicUsize, Ordering::Relaxed};
use std::time::{Duration, Instant};

use handgate_adapters::dds::Within;

// ---------------------------------------------------------------------------------------
// The counting allocator: one slot of counters per thread, found by the kernel thread id.

/// Counters of one thread.
pub struct Slot {
    pub tid: AtomicI32,
    pub allocs: AtomicU64,
    pub bytes: AtomicU64,
    pub frees: AtomicU64,
    /// The part of `allocs` / `bytes` made inside a DDS write, outside any reader callback
    /// (`dds::Within::Write`): the binding's and CycloneDDS's.
    pub write_allocs: AtomicU64,
    pub write_bytes: AtomicU64,
    /// The part made inside a reader callback (`dds::Within::Callback`): an in-process peer's
    /// reader, run by CycloneDDS inside a write on the writing thread.
    pub callback_allocs: AtomicU64,
    pub callback_bytes: AtomicU64,
    /// The part made inside a DDS-client device's own work (`dds::Within::Device`), outside
    /// any write or callback in it.
    pub device_allocs: AtomicU64,
    pub device_bytes: AtomicU64,
}

impl Slot {
    const fn new() -> Self {
        Self {
            tid: AtomicI32::new(0),
            allocs: AtomicU64::new(0),
            bytes: AtomicU64::new(0),
            frees: AtomicU64::new(0),
            write_allocs: AtomicU64::new(0),
            write_bytes: AtomicU64::new(0),
            callback_allocs: AtomicU64::new(0),
            callback_bytes: AtomicU64::new(0),
            device_allocs: AtomicU64::new(0),
            device_bytes: AtomicU64::new(0),
        }
    }
}

/// More than the threads this binary ever starts (test threads, CycloneDDS's, the loops and
/// emulators); a thread beyond the last slot is not counted.
const SLOTS: usize = 4096;
static TABLE: [Slot; SLOTS] = [const { Slot::new() }; SLOTS];
static NEXT_SLOT: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// This thread's slot (`usize::MAX`: none yet). Const-initialised and without a
    /// destructor: reading it never allocates, also while the thread exits.
    static MY_SLOT: Cell<usize> = const { Cell::new(usize::MAX) };
}

fn my_slot() -> Option<&'static Slot> {
    MY_SLOT
        .try_with(|s| {
            if s.get() == usize::MAX {
                let i = NEXT_SLOT.fetch_add(1, Relaxed);
                if i >= SLOTS {
                    return None;
                }
                // SAFETY: gettid has no preconditions.
                TABLE[i].tid.store(unsafe { libc::gettid() }, Relaxed);
                s.set(i);
            }
            TABLE.get(s.get())
        })
        .ok()
        .flatten()
}

fn count_alloc(size: usize) {
    if let Some(s) = my_slot() {
        s.allocs.fetch_add(1, Relaxed);
        s.bytes.fetch_add(size as u64, Relaxed);
        let (n, b) = match handgate_adapters::dds::within() {
            Within::Caller => return,
            Within::Write => (&s.write_allocs, &s.write_bytes),
            Within::Callback => (&s.callback_allocs, &s.callback_bytes),
            Within::Device => (&s.device_allocs, &s.device_bytes),
        };
        n.fetch_add(1, Relaxed);
        b.fetch_add(size as u64, Relaxed);
    }
}

struct Counting;

// SAFETY: every call is forwarded to System with the caller's arguments (the caller upholds
// GlobalAlloc's contract for them); the counting beside it never allocates.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count_alloc(layout.size());
        // SAFETY: forwarded as received.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count_alloc(layout.size());
        // SAFETY: forwarded as received.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count_alloc(new_size);
        // SAFETY: forwarded as received.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        if let Some(s) = my_slot() {
            s.frees.fetch_add(1, Relaxed);
        }
        // SAFETY: forwarded as received.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// A snapshot of one thread's counters.
#[derive(Debug, Clone, Copy, Default)]
pub struct Counts {
    pub allocs: u64,
    pub bytes: u64,
    pub frees: u64,
    pub write_allocs: u64,
    pub write_bytes: u64,
    pub callback_allocs: u64,
    pub callback_bytes: u64,
    pub device_allocs: u64,
    pub device_bytes: u64,
}

impl Counts {
    pub fn load(s: &Slot) -> Self {
        Counts {
            allocs: s.allocs.load(Relaxed),
            bytes: s.bytes.load(Relaxed),
            frees: s.frees.load(Relaxed),
            write_allocs: s.write_allocs.load(Relaxed),
            write_bytes: s.write_bytes.load(Relaxed),
            callback_allocs: s.callback_allocs.load(Relaxed),
            callback_bytes: s.callback_bytes.load(Relaxed),
            device_allocs: s.device_allocs.load(Relaxed),
            device_bytes: s.device_bytes.load(Relaxed),
        }
    }

    /// The slots in use.
    pub fn slots() -> &'static [Slot] {
        &TABLE[..NEXT_SLOT.load(Relaxed).min(SLOTS)]
    }

    /// Thread `tid`'s counters (its newest slot: a kernel thread id can be reused).
    pub fn of(tid: i32) -> Self {
        Self::slots()
            .iter()
            .rev()
            .find(|s| s.tid.load(Relaxed) == tid)
            .map(Counts::load)
            .unwrap_or_default()
    }

    /// Allocations and bytes of the code counted itself: everything but the DDS writes and the
    /// reader callbacks run inside them.
    pub fn own(&self) -> (u64, u64) {
        (
            self.allocs - self.write_allocs - self.callback_allocs,
            self.bytes - self.write_bytes - self.callback_bytes,
        )
    }

    pub fn since(self, before: Counts) -> Counts {
        Counts {
            allocs: self.allocs - before.allocs,
            bytes: self.bytes - before.bytes,
            frees: self.frees - before.frees,
            write_allocs: self.write_allocs - before.write_allocs,
            write_bytes: self.write_bytes - before.write_bytes,
            callback_allocs: self.callback_allocs - before.callback_allocs,
            callback_bytes: self.callback_bytes - before.callback_bytes,
            device_allocs: self.device_allocs - before.device_allocs,
            device_bytes: self.device_bytes - before.device_bytes,
        }
    }
}

/// The kernel thread ids of this process's threads whose name (`comm`) `matches`.
pub fn threads_where(matches: impl Fn(&str) -> bool) -> Vec<i32> {
    std::fs::read_dir("/proc/self/task")
        .unwrap()
        .flatten()
        .filter(|e| {
            matches(
                std::fs::read_to_string(e.path().join("comm"))
                    .unwrap_or_default()
                    .trim_end(),
            )
        })
        .map(|e| e.file_name().to_string_lossy().parse().unwrap())
        .collect()
}

/// The kernel thread id of this process's thread named `name` (its `comm`).
pub fn thread_named(name: &str, deadline: Duration) -> i32 {
    let end = Instant::now() + deadline;
    loop {
        if let Some(&tid) = threads_where(|comm| comm == name).first() {
            return tid;
        }
        assert!(Instant::now() < end, "no thread named {name}");
        std::thread::sleep(Duration::from_millis(1));
    }
}
