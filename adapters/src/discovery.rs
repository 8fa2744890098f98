//! Endpoint discovery: what every remote reader and writer on this process's DDS domain is,
//! read from CycloneDDS's built-in topics (DCPSParticipant, DCPSPublication,
//! DCPSSubscription).
//!
//! [`Discovery::start`] runs one thread per domain (its own, never a device path) that waits on
//! a waitset over the three built-in readers, takes every sample (alive, disposed and
//! unregistered instances), applies it to a bounded [`Tracker`] and publishes an immutable
//! [`Snapshot`] (`Arc<Snapshot>`) that callers read without ever blocking the thread, and the
//! thread never waits for them. Everything read from the network is bounded: at most
//! `max_endpoints` endpoints and `max_participants` participants (the rest counted as
//! dropped), every string capped at `max_string_len` bytes (counted when cut).
//!
//! The pure diagnostics over a snapshot are in [`diagnose`]. docs/discovery.md describes
//! what CycloneDDS 0.10.2 reports and what it does not.

pub mod diagnose;

use std::collections::HashMap;
use std::ffi::{c_char, c_void, CStr};
use std::fmt;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use cyclonedds_sys::{dds_entity_t, dds_guid_t, dds_instance_handle_t, dds_qos_t, dds_return_t};

use crate::dds::{DdsError, Node};

// ---------------------------------------------------------------------------------------------
// Snapshot types (plain data, no DDS)
// ---------------------------------------------------------------------------------------------

/// A DDS GUID (16 bytes: 12 of participant prefix, 4 of entity id).
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct Guid(pub [u8; 16]);

impl Guid {
    /// The GUID of the participant an endpoint with this GUID belongs to (same prefix,
    /// entity id 0x000001c1).
    pub fn participant(&self) -> Guid {
        let mut g = self.0;
        g[12..].copy_from_slice(&[0, 0, 1, 0xc1]);
        Guid(g)
    }
}

impl fmt::Display for Guid {
    /// CycloneDDS's own notation: four groups of 8 hex digits separated by `:`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, chunk) in self.0.chunks(4).enumerate() {
            if i > 0 {
                f.write_str(":")?;
            }
            for b in chunk {
                write!(f, "{b:02x}")?;
            }
        }
        Ok(())
    }
}

impl fmt::Debug for Guid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

/// Reader or writer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Role {
    Reader,
    Writer,
}

impl Role {
    /// The role an endpoint must have to match one of this role.
    pub fn counterpart(self) -> Role {
        match self {
            Role::Reader => Role::Writer,
            Role::Writer => Role::Reader,
        }
    }
}

/// RELIABILITY kind. `BestEffort < Reliable`: a writer offering at least what a reader
/// requests matches it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Reliability {
    BestEffort,
    Reliable,
}

/// DURABILITY kind, ordered as DDS compares offered with requested.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Durability {
    Volatile,
    TransientLocal,
    Transient,
    Persistent,
}

/// HISTORY kind and depth.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum History {
    KeepLast(i32),
    KeepAll,
}

/// The QoS of a discovered endpoint that matters for matching and diagnosis. `None`: the
/// discovery data did not carry the policy (CycloneDDS fills in defaults for missing
/// policies of remote endpoints, so this is rare).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EndpointQos {
    pub reliability: Option<Reliability>,
    pub durability: Option<Durability>,
    pub history: Option<History>,
}

/// Where an endpoint or participant lives, relative to the process reading discovery.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Origin {
    /// The participant discovery runs on.
    ThisParticipant,
    /// Another participant of this process (same `__Pid` and `__Hostname` as ours).
    ThisProcess,
    /// Anything else.
    Remote,
}

impl Origin {
    pub fn is_local(self) -> bool {
        self != Origin::Remote
    }
}

/// A discovered reader or writer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Endpoint {
    pub key: Guid,
    pub participant: Guid,
    pub role: Role,
    pub topic: Arc<str>,
    pub type_name: Arc<str>,
    pub qos: EndpointQos,
    pub origin: Origin,
}

/// A discovered participant and what it reports about its process (CycloneDDS participant
/// properties; absent for other DDS implementations or when not sent).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Participant {
    pub key: Guid,
    /// `__Hostname`.
    pub hostname: Option<Arc<str>>,
    /// `__Pid`, when it parses as a number.
    pub pid: Option<u32>,
    /// `__ProcessName`.
    pub process_name: Option<Arc<str>>,
    /// `__NetworkAddresses`, split at `,` (e.g. `udp/192.168.123.161:40310@3`; CycloneDDS
    /// may list a multicast group too; see [`Participant::unicast_address`]).
    pub network_addresses: Vec<Arc<str>>,
    pub origin: Origin,
}

impl Participant {
    /// The first unicast IP in `network_addresses` (`udp/1.2.3.4:7410@3` -> `1.2.3.4`),
    /// skipping multicast groups and entries that are not IP locators (CycloneDDS reports
    /// `localprocess` for participants of this process).
    pub fn unicast_address(&self) -> Option<&str> {
        self.network_addresses.iter().find_map(|a| {
            let ip = locator_ip(a)?;
            let parsed: std::net::IpAddr = ip.parse().ok()?;
            (!parsed.is_multicast()).then_some(ip)
        })
    }
}

impl Participant {
    /// Every unicast IP in `network_addresses`.
    pub fn ip_addresses(&self) -> impl Iterator<Item = std::net::IpAddr> + '_ {
        self.network_addresses.iter().filter_map(|a| {
            let ip: std::net::IpAddr = locator_ip(a)?.parse().ok()?;
            (!ip.is_multicast()).then_some(ip)
        })
    }
}

/// `udp/1.2.3.4:7410@3` -> `1.2.3.4`; `udp/[::1]:7410@3` -> `::1`.
fn locator_ip(locator: &str) -> Option<&str> {
    let rest = locator.split_once('/').map_or(locator, |(_, r)| r);
    let rest = rest.split('@').next()?;
    if let Some(v6) = rest.strip_prefix('[') {
        return v6.split(']').next();
    }
    Some(rest.rsplit_once(':').map_or(rest, |(ip, _)| ip))
}

/// What the bounds cost so far (cumulative since start).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Counters {
    /// New endpoints not tracked because `max_endpoints` were tracked already.
    pub dropped_endpoints: u64,
    /// New participants not tracked because `max_participants` were tracked already.
    pub dropped_participants: u64,
    /// Strings (topic, type name, property values, addresses) cut at `max_string_len`,
    /// plus addresses beyond `max_addresses`.
    pub truncated_strings: u64,
    /// Built-in samples that could not be used (null pointers, a failed take).
    pub bad_samples: u64,
}

/// One immutable view of the domain. Endpoints sorted by (topic, role, key), participants
/// by key.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Snapshot {
    /// Increases by one with every published snapshot (0: nothing read yet).
    pub generation: u64,
    pub domain_id: u32,
    /// The GUID of the participant discovery runs on.
    pub this_participant: Guid,
    pub participants: Vec<Participant>,
    pub endpoints: Vec<Endpoint>,
    pub counters: Counters,
    /// When the newest change this snapshot includes was read (at the latest: a wake that
    /// took samples while changes were pending). Snapshots are published at most every
    /// `min_publish_interval`, so a change can be up to that old when its snapshot comes out:
    /// a wait for discovery to be quiet counts from here, not from the publish.
    pub changed_at: Option<Instant>,
}

impl Snapshot {
    pub fn empty(domain_id: u32, this_participant: Guid) -> Self {
        Self {
            generation: 0,
            domain_id,
            this_participant,
            participants: Vec::new(),
            endpoints: Vec::new(),
            counters: Counters::default(),
            changed_at: None,
        }
    }

    /// Endpoints of other processes.
    pub fn remote_endpoints(&self) -> impl Iterator<Item = &Endpoint> {
        self.endpoints.iter().filter(|e| e.origin == Origin::Remote)
    }

    /// Endpoints on `topic` (exact name), any origin.
    pub fn on_topic<'a>(&'a self, topic: &'a str) -> impl Iterator<Item = &'a Endpoint> + 'a {
        self.endpoints.iter().filter(move |e| &*e.topic == topic)
    }

    pub fn participant(&self, key: &Guid) -> Option<&Participant> {
        self.participants
            .binary_search_by(|p| p.key.cmp(key))
            .ok()
            .map(|i| &self.participants[i])
    }
}

// ---------------------------------------------------------------------------------------------
// Bounded state (plain data, unit-tested without DDS)
// ---------------------------------------------------------------------------------------------

/// Bounds and pacing of discovery.
#[derive(Debug, Clone)]
pub struct DiscoveryConfig {
    /// Readers + writers tracked at most (default 4096).
    pub max_endpoints: usize,
    /// Participants tracked at most (default 1024).
    pub max_participants: usize,
    /// Longest topic / type name / property value kept, in bytes (default 256).
    pub max_string_len: usize,
    /// Most `__NetworkAddresses` entries kept per participant (default 16).
    pub max_addresses: usize,
    /// Least time between two published snapshots (default 20 ms): a burst of discovery
    /// traffic becomes one snapshot, not thousands.
    pub min_publish_interval: Duration,
}

impl Default for DiscoveryConfig {
    fn default() -> Self {
        Self {
            max_endpoints: 4096,
            max_participants: 1024,
            max_string_len: 256,
            max_addresses: 16,
            min_publish_interval: Duration::from_millis(20),
        }
    }
}

/// A participant as read, before origins are worked out.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RawParticipant {
    pub key: Guid,
    pub hostname: Option<Arc<str>>,
    pub pid: Option<u32>,
    pub process_name: Option<Arc<str>>,
    pub network_addresses: Vec<Arc<str>>,
}

/// An endpoint as read, before origins are worked out.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RawEndpoint {
    pub key: Guid,
    pub participant: Guid,
    pub role: Role,
    pub topic: Arc<str>,
    pub type_name: Arc<str>,
    pub qos: EndpointQos,
}

/// The bounded discovery state, keyed by the built-in readers' instance handles (one per
/// participant / endpoint, also given for disposed and unregistered instances).
#[derive(Debug)]
pub struct Tracker {
    cfg: DiscoveryConfig,
    this_participant: Guid,
    participants: HashMap<dds_instance_handle_t, RawParticipant>,
    endpoints: HashMap<dds_instance_handle_t, RawEndpoint>,
    counters: Counters,
    dirty: bool,
}

impl Tracker {
    pub fn new(cfg: DiscoveryConfig, this_participant: Guid) -> Self {
        Self {
            cfg,
            this_participant,
            participants: HashMap::new(),
            endpoints: HashMap::new(),
            counters: Counters::default(),
            dirty: true,
        }
    }

    pub fn config(&self) -> &DiscoveryConfig {
        &self.cfg
    }

    /// An alive participant sample: updates a tracked one, adds a new one while below the
    /// bound, counts it as dropped otherwise.
    pub fn upsert_participant(&mut self, handle: dds_instance_handle_t, p: RawParticipant) {
        if let Some(old) = self.participants.get_mut(&handle) {
            if *old != p {
                *old = p;
                self.dirty = true;
            }
        } else if self.participants.len() < self.cfg.max_participants {
            self.participants.insert(handle, p);
            self.dirty = true;
        } else {
            self.counters.dropped_participants += 1;
            self.dirty = true;
        }
    }

    /// As [`Tracker::upsert_participant`], for readers and writers.
    pub fn upsert_endpoint(&mut self, handle: dds_instance_handle_t, e: RawEndpoint) {
        if let Some(old) = self.endpoints.get_mut(&handle) {
            if *old != e {
                *old = e;
                self.dirty = true;
            }
        } else if self.endpoints.len() < self.cfg.max_endpoints {
            self.endpoints.insert(handle, e);
            self.dirty = true;
        } else {
            self.counters.dropped_endpoints += 1;
            self.dirty = true;
        }
    }

    /// A disposed / unregistered participant instance.
    pub fn remove_participant(&mut self, handle: dds_instance_handle_t) {
        if self.participants.remove(&handle).is_some() {
            self.dirty = true;
        }
    }

    /// A disposed / unregistered endpoint instance.
    pub fn remove_endpoint(&mut self, handle: dds_instance_handle_t) {
        if self.endpoints.remove(&handle).is_some() {
            self.dirty = true;
        }
    }

    pub fn counters_mut(&mut self) -> &mut Counters {
        self.dirty = true;
        &mut self.counters
    }

    pub fn is_dirty(&self) -> bool {
        self.dirty
    }

    /// Builds the snapshot of the current state and clears the dirty flag.
    pub fn snapshot(&mut self, domain_id: u32, generation: u64) -> Snapshot {
        self.dirty = false;
        let me = self.this_participant;
        // Our process: the (hostname, pid) our own participant reports.
        let ours = self
            .participants
            .values()
            .find(|p| p.key == me)
            .and_then(|p| Some((p.hostname.clone()?, p.pid?)));
        let origin_of = |key: &Guid, raw: Option<&RawParticipant>| -> Origin {
            if *key == me {
                return Origin::ThisParticipant;
            }
            match (&ours, raw) {
                (Some((host, pid)), Some(p)) if p.pid == Some(*pid) && p.hostname.as_ref() == Some(host) => {
                    Origin::ThisProcess
                }
                _ => Origin::Remote,
            }
        };
        let by_key: HashMap<Guid, &RawParticipant> = self.participants.values().map(|p| (p.key, p)).collect();
        let mut participants: Vec<Participant> = self
            .participants
            .values()
            .map(|p| Participant {
                key: p.key,
                hostname: p.hostname.clone(),
                pid: p.pid,
                process_name: p.process_name.clone(),
                network_addresses: p.network_addresses.clone(),
                origin: origin_of(&p.key, Some(p)),
            })
            .collect();
        participants.sort_by_key(|a| a.key);
        let mut endpoints: Vec<Endpoint> = self
            .endpoints
            .values()
            .map(|e| Endpoint {
                key: e.key,
                participant: e.participant,
                role: e.role,
                topic: e.topic.clone(),
                type_name: e.type_name.clone(),
                qos: e.qos,
                origin: origin_of(&e.participant, by_key.get(&e.participant).copied()),
            })
            .collect();
        endpoints.sort_by(|a, b| (&a.topic, a.role, a.key).cmp(&(&b.topic, b.role, b.key)));
        Snapshot {
            generation,
            domain_id,
            this_participant: me,
            participants,
            endpoints,
            counters: self.counters,
            changed_at: None,
        }
    }
}

/// Cuts `s` to at most `max` bytes on a character boundary; true when it cut.
fn cap_string(s: &mut String, max: usize) -> bool {
    if s.len() <= max {
        return false;
    }
    let mut end = max;
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    s.truncate(end);
    true
}

/// Splits a `__NetworkAddresses` value into at most `max_addresses` entries of at most
/// `max_len` bytes each; returns the entries and how many were cut or left out.
pub fn split_addresses(value: &str, max_addresses: usize, max_len: usize) -> (Vec<Arc<str>>, u64) {
    let mut cut = 0u64;
    let mut out = Vec::new();
    for part in value.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        if out.len() >= max_addresses {
            cut += 1;
            continue;
        }
        let mut s = part.to_string();
        if cap_string(&mut s, max_len) {
            cut += 1;
        }
        out.push(Arc::from(s));
    }
    (out, cut)
}

// ---------------------------------------------------------------------------------------------
// The C API (cyclonedds-sys 0.2.1 lacks these declarations; libddsc 0.10.2 exports them)
// ---------------------------------------------------------------------------------------------

mod ffi {
    use super::*;

    /// `dds_builtintopic_participant_t` (dds/dds.h, CycloneDDS 0.10.2).
    #[repr(C)]
    pub struct BuiltinParticipant {
        pub key: dds_guid_t,
        pub qos: *mut dds_qos_t,
    }

    /// `DDS_DATA_AVAILABLE_STATUS` = 1 << `DDS_DATA_AVAILABLE_STATUS_ID` (8).
    pub const DATA_AVAILABLE_STATUS: u32 = 1 << 8;
    /// `DDS_IST_ALIVE`.
    pub const INSTANCE_ALIVE: u32 = 16;

    extern "C" {
        pub fn dds_qget_prop(qos: *const dds_qos_t, name: *const c_char, value: *mut *mut c_char) -> bool;
        // The kinds are read as plain integers (the sys crate's Rust enums would make an
        // unexpected value undefined behaviour).
        pub fn dds_qget_reliability(qos: *const dds_qos_t, kind: *mut u32, max_blocking: *mut i64) -> bool;
        pub fn dds_qget_durability(qos: *const dds_qos_t, kind: *mut u32) -> bool;
        pub fn dds_qget_history(qos: *const dds_qos_t, kind: *mut u32, depth: *mut i32) -> bool;
    }
}

/// Reads a NUL-terminated C string, scanning at most `max + 1` bytes, into an owned string
/// of at most `max` bytes (invalid UTF-8 replaced). Returns the string and whether it was cut.
///
/// # Safety
/// `ptr` is null or points to a NUL-terminated string that stays valid during the call.
unsafe fn bounded_cstr(ptr: *const c_char, max: usize) -> Option<(String, bool)> {
    if ptr.is_null() {
        return None;
    }
    // SAFETY: (caller) `ptr` is NUL-terminated, so strnlen stops at the NUL or after
    // `max + 1` bytes, both inside the string.
    let len = unsafe { libc::strnlen(ptr, max + 1) };
    // SAFETY: the `len.min(max)` bytes just measured are readable and not mutated meanwhile.
    let bytes = unsafe { std::slice::from_raw_parts(ptr.cast::<u8>(), len.min(max)) };
    let mut s = String::from_utf8_lossy(bytes).into_owned();
    let lossy_cut = cap_string(&mut s, max);
    let cut = len > max || lossy_cut;
    Some((s, cut))
}

/// One property of a participant QoS, copied out and capped (the C copy freed here).
///
/// # Safety
/// `qos` is a valid QoS object for the duration of the call.
unsafe fn qos_property(qos: *const dds_qos_t, name: &CStr, max: usize, cut: &mut u64) -> Option<String> {
    let mut value: *mut c_char = std::ptr::null_mut();
    // SAFETY: (caller) valid qos; `name` is NUL-terminated; on success CycloneDDS stores a
    // freshly allocated copy in `value`, which we own.
    let found = unsafe { ffi::dds_qget_prop(qos, name.as_ptr(), &mut value) };
    if !found || value.is_null() {
        return None;
    }
    // SAFETY: `value` is CycloneDDS's NUL-terminated copy, alive until freed below.
    let read = unsafe { bounded_cstr(value, max) };
    // SAFETY: `value` was allocated by CycloneDDS for us; freed exactly once.
    unsafe { cyclonedds_sys::dds_free(value.cast::<c_void>()) };
    let (s, was_cut) = read?;
    *cut += u64::from(was_cut);
    Some(s)
}

/// Copies a participant sample out of a loan.
///
/// # Safety
/// `p` points to a valid `dds_builtintopic_participant_t` sample for the duration of the call.
unsafe fn read_participant(p: *const ffi::BuiltinParticipant, cfg: &DiscoveryConfig, cut: &mut u64) -> RawParticipant {
    // SAFETY: (caller) valid sample; we copy the key and keep the qos pointer only for
    // the calls below.
    let (key, qos) = unsafe { (Guid((*p).key.v), (*p).qos as *const dds_qos_t) };
    let mut out = RawParticipant {
        key,
        hostname: None,
        pid: None,
        process_name: None,
        network_addresses: Vec::new(),
    };
    if qos.is_null() {
        return out;
    }
    let max = cfg.max_string_len;
    // SAFETY: `qos` belongs to the loaned sample, valid during this call.
    unsafe {
        out.hostname = qos_property(qos, c"__Hostname", max, cut).map(Arc::from);
        out.process_name = qos_property(qos, c"__ProcessName", max, cut).map(Arc::from);
        out.pid = qos_property(qos, c"__Pid", max, cut).and_then(|s| s.trim().parse().ok());
        if let Some(addrs) = qos_property(qos, c"__NetworkAddresses", max.saturating_mul(4), cut) {
            let (list, n) = split_addresses(&addrs, cfg.max_addresses, max);
            out.network_addresses = list;
            *cut += n;
        }
    }
    out
}

/// Reads the matching-relevant QoS policies.
///
/// # Safety
/// `qos` is null or a valid QoS object for the duration of the call.
unsafe fn read_qos(qos: *const dds_qos_t) -> EndpointQos {
    let mut q = EndpointQos::default();
    if qos.is_null() {
        return q;
    }
    let (mut rk, mut mbt, mut dk, mut hk, mut depth) = (0u32, 0i64, 0u32, 0u32, 0i32);
    // SAFETY: valid qos (caller); every out-parameter is a local of the declared C type.
    unsafe {
        if ffi::dds_qget_reliability(qos, &mut rk, &mut mbt) {
            q.reliability = match rk {
                0 => Some(Reliability::BestEffort),
                1 => Some(Reliability::Reliable),
                _ => None,
            };
        }
        if ffi::dds_qget_durability(qos, &mut dk) {
            q.durability = match dk {
                0 => Some(Durability::Volatile),
                1 => Some(Durability::TransientLocal),
                2 => Some(Durability::Transient),
                3 => Some(Durability::Persistent),
                _ => None,
            };
        }
        if ffi::dds_qget_history(qos, &mut hk, &mut depth) {
            q.history = match hk {
                0 => Some(History::KeepLast(depth)),
                1 => Some(History::KeepAll),
                _ => None,
            };
        }
    }
    q
}

/// Copies an endpoint sample out of a loan; None when its names are missing.
///
/// # Safety
/// `e` points to a valid `dds_builtintopic_endpoint_t` sample for the duration of the call.
unsafe fn read_endpoint(
    e: *const cyclonedds_sys::dds_builtintopic_endpoint,
    role: Role,
    cfg: &DiscoveryConfig,
    cut: &mut u64,
) -> Option<RawEndpoint> {
    // SAFETY: (caller) valid sample; plain field reads.
    let (key, participant, topic, type_name, qos) = unsafe {
        (
            (*e).key.v,
            (*e).participant_key.v,
            (*e).topic_name,
            (*e).type_name,
            (*e).qos,
        )
    };
    let max = cfg.max_string_len;
    // SAFETY: the names belong to the loaned sample (NUL-terminated, CycloneDDS-owned).
    let (topic, c1) = unsafe { bounded_cstr(topic, max) }?;
    // SAFETY: as above.
    let (type_name, c2) = unsafe { bounded_cstr(type_name, max) }?;
    *cut += u64::from(c1) + u64::from(c2);
    Some(RawEndpoint {
        key: Guid(key),
        participant: Guid(participant),
        role,
        topic: Arc::from(topic),
        type_name: Arc::from(type_name),
        // SAFETY: the qos belongs to the loaned sample.
        qos: unsafe { read_qos(qos) },
    })
}

#[derive(Clone, Copy)]
enum Builtin {
    Participant,
    Publication,
    Subscription,
}

/// Samples taken per `dds_take` call.
const BATCH: usize = 64;
/// Batches per reader per wake-up before the loop yields (and comes back at once).
const BATCHES_PER_WAKE: usize = 16;

/// Takes up to `BATCH` samples from `reader` (loaned), applies them to the tracker and
/// returns the loan. Returns how many were taken (0 also on error).
fn take_batch(reader: dds_entity_t, which: Builtin, tracker: &mut Tracker) -> usize {
    let mut ptrs: [*mut c_void; BATCH] = [std::ptr::null_mut(); BATCH];
    let mut infos = [cyclonedds_sys::dds_sample_info_t::default(); BATCH];
    // SAFETY: `reader` is a live reader of ours; `ptrs` holds BATCH null pointers, which
    // asks CycloneDDS to loan its own samples; `infos` has room for BATCH infos.
    let n =
        unsafe { cyclonedds_sys::dds_take(reader, ptrs.as_mut_ptr(), infos.as_mut_ptr(), BATCH as _, BATCH as u32) };
    if n <= 0 {
        if n < 0 {
            tracker.counters_mut().bad_samples += 1;
        }
        return 0;
    }
    let n = (n as usize).min(BATCH);
    let cfg = tracker.config().clone();
    let mut cut = 0u64;
    for (ptr, info) in ptrs.iter().zip(infos.iter()).take(n) {
        let handle = info.instance_handle;
        let alive = info.instance_state == ffi::INSTANCE_ALIVE;
        if !alive {
            match which {
                Builtin::Participant => tracker.remove_participant(handle),
                Builtin::Publication | Builtin::Subscription => tracker.remove_endpoint(handle),
            }
            continue;
        }
        if !info.valid_data || ptr.is_null() {
            continue;
        }
        match which {
            Builtin::Participant => {
                // SAFETY: a valid sample loaned by the DCPSParticipant reader: its type is
                // dds_builtintopic_participant_t; the loan is returned below.
                let p = unsafe { read_participant(ptr.cast_const().cast(), &cfg, &mut cut) };
                tracker.upsert_participant(handle, p);
            }
            Builtin::Publication | Builtin::Subscription => {
                let role = if matches!(which, Builtin::Publication) {
                    Role::Writer
                } else {
                    Role::Reader
                };
                // SAFETY: a valid sample loaned by a DCPSPublication/DCPSSubscription reader:
                // its type is dds_builtintopic_endpoint_t; the loan is returned below.
                match unsafe { read_endpoint(ptr.cast_const().cast(), role, &cfg, &mut cut) } {
                    Some(e) => tracker.upsert_endpoint(handle, e),
                    None => tracker.counters_mut().bad_samples += 1,
                }
            }
        }
    }
    if cut > 0 {
        tracker.counters_mut().truncated_strings += cut;
    }
    // SAFETY: returns exactly the loan `dds_take` gave (same reader, same buffer, n samples);
    // nothing borrowed from it is used afterwards (everything was copied).
    unsafe { cyclonedds_sys::dds_return_loan(reader, ptrs.as_mut_ptr(), n as i32) };
    n
}

// ---------------------------------------------------------------------------------------------
// The discovery thread and its snapshot cell
// ---------------------------------------------------------------------------------------------

/// The published snapshot: readers clone an `Arc` under a lock held only for that clone;
/// the thread swaps the `Arc` the same way. Blocking waiters use the condvar; async ones the
/// watch channel.
struct Cell {
    current: Mutex<Arc<Snapshot>>,
    changed: Condvar,
    watch: tokio::sync::watch::Sender<Arc<Snapshot>>,
}

impl Cell {
    fn get(&self) -> Arc<Snapshot> {
        Arc::clone(&self.current.lock().unwrap_or_else(|e| e.into_inner()))
    }

    fn publish(&self, s: Arc<Snapshot>) {
        // The watch first: whoever sees a snapshot in `current` finds it in the watch too.
        self.watch.send_replace(Arc::clone(&s));
        *self.current.lock().unwrap_or_else(|e| e.into_inner()) = s;
        self.changed.notify_all();
    }
}

/// The built-in readers and waitset, deleted when the thread ends.
struct Entities {
    readers: [(dds_entity_t, Builtin); 3],
    waitset: dds_entity_t,
}

impl Drop for Entities {
    fn drop(&mut self) {
        for (r, _) in self.readers {
            if r > 0 {
                // SAFETY: a reader we created and nobody else deletes.
                unsafe { cyclonedds_sys::dds_delete(r) };
            }
        }
        if self.waitset > 0 {
            // SAFETY: the waitset we created; no thread waits on it any more.
            unsafe { cyclonedds_sys::dds_delete(self.waitset) };
        }
    }
}

/// Endpoint discovery on one domain (one [`Node`]). Stops its thread when dropped.
pub struct Discovery {
    cell: Arc<Cell>,
    stop: Arc<AtomicBool>,
    waitset: dds_entity_t,
    this_participant: Guid,
    thread: Option<JoinHandle<()>>,
}

impl fmt::Debug for Discovery {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Discovery")
            .field("this_participant", &self.this_participant)
            .finish()
    }
}

fn dds_call(what: &'static str, rc: dds_return_t) -> Result<dds_return_t, DdsError> {
    if rc < 0 {
        Err(DdsError::Dds {
            what,
            source: cyclonedds_rs::DDSError::from(rc),
        })
    } else {
        Ok(rc)
    }
}

impl Discovery {
    /// Starts reading discovery on `node`'s participant (its endpoints are then
    /// [`Origin::ThisParticipant`]). The first snapshot holds what CycloneDDS already knows.
    pub fn start(node: &Node, cfg: DiscoveryConfig) -> Result<Self, DdsError> {
        let participant = node.participant_entity();
        let me = node.guid();

        let mut ents = Entities {
            readers: [
                (0, Builtin::Participant),
                (0, Builtin::Publication),
                (0, Builtin::Subscription),
            ],
            waitset: 0,
        };
        let topics = [
            cyclonedds_sys::BUILTIN_TOPIC_DCPSPARTICIPANT,
            cyclonedds_sys::BUILTIN_TOPIC_DCPSPUBLICATION,
            cyclonedds_sys::BUILTIN_TOPIC_DCPSSUBSCRIPTION,
        ];
        // SAFETY: a live participant handle; creates a waitset owned by `ents`.
        ents.waitset = dds_call("create waitset", unsafe {
            cyclonedds_sys::dds_create_waitset(participant)
        })?;
        for (i, topic) in topics.into_iter().enumerate() {
            // SAFETY: the pseudo-handles of the built-in topics are valid topic arguments;
            // default QoS, no listener. The reader is owned (and deleted) by `ents`.
            let r = dds_call("create builtin reader", unsafe {
                cyclonedds_sys::dds_create_reader(participant, topic, std::ptr::null(), std::ptr::null())
            })?;
            ents.readers[i].0 = r;
            // SAFETY: `r` and the waitset are ours; plain integer arguments.
            unsafe {
                dds_call(
                    "set status mask",
                    cyclonedds_sys::dds_set_status_mask(r, ffi::DATA_AVAILABLE_STATUS),
                )?;
                dds_call(
                    "waitset attach",
                    cyclonedds_sys::dds_waitset_attach(ents.waitset, r, i as isize),
                )?;
            }
        }

        let first = Arc::new(Snapshot::empty(node.domain_id(), me));
        let (watch, _) = tokio::sync::watch::channel(Arc::clone(&first));
        let cell = Arc::new(Cell {
            current: Mutex::new(first),
            changed: Condvar::new(),
            watch,
        });
        let stop = Arc::new(AtomicBool::new(false));
        let waitset = ents.waitset;
        let thread = {
            let (cell, stop, node) = (Arc::clone(&cell), Arc::clone(&stop), node.clone());
            let domain = node.domain_id();
            std::thread::Builder::new()
                .name(format!("discovery-{domain}"))
                .spawn(move || {
                    let _node = node; // keeps the participant alive while the entities live
                    run(ents, Tracker::new(cfg, me), domain, &cell, &stop);
                })
                .map_err(|e| DdsError::Thread(e.to_string()))?
        };
        Ok(Self {
            cell,
            stop,
            waitset,
            this_participant: me,
            thread: Some(thread),
        })
    }

    /// The latest snapshot (never blocks on the discovery thread beyond an `Arc` clone).
    pub fn snapshot(&self) -> Arc<Snapshot> {
        self.cell.get()
    }

    /// A watch receiver for async callers (`changed().await`).
    pub fn subscribe(&self) -> tokio::sync::watch::Receiver<Arc<Snapshot>> {
        self.cell.watch.subscribe()
    }

    /// The GUID of the participant discovery runs on.
    pub fn this_participant(&self) -> Guid {
        self.this_participant
    }

    /// Blocks until a published snapshot satisfies `pred` (checked on the current one first),
    /// and returns it.
    pub fn wait_for(
        &self,
        timeout: Duration,
        mut pred: impl FnMut(&Snapshot) -> bool,
    ) -> Result<Arc<Snapshot>, DdsError> {
        let deadline = Instant::now() + timeout;
        let mut guard = self.cell.current.lock().unwrap_or_else(|e| e.into_inner());
        loop {
            if pred(&guard) {
                return Ok(Arc::clone(&guard));
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(DdsError::Timeout(timeout, "a discovery snapshot"));
            }
            guard = self
                .cell
                .changed
                .wait_timeout(guard, left)
                .unwrap_or_else(|e| e.into_inner())
                .0;
        }
    }
}

impl Drop for Discovery {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        // SAFETY: the waitset is alive until the thread (joined below) deletes it; triggering
        // a waitset from another thread is allowed by the C API.
        unsafe { cyclonedds_sys::dds_waitset_set_trigger(self.waitset, true) };
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn run(ents: Entities, mut tracker: Tracker, domain: u32, cell: &Cell, stop: &AtomicBool) {
    let min_interval = tracker.config().min_publish_interval;
    let mut generation = 0u64;
    let mut last_publish: Option<Instant> = None;
    // When a wake last took samples while changes were pending (the newest change read).
    let mut changed_at: Option<Instant> = None;
    let mut pending = false;
    while !stop.load(Ordering::SeqCst) {
        let timeout = if pending {
            Duration::ZERO
        } else if tracker.is_dirty() {
            last_publish.map_or(Duration::ZERO, |t| min_interval.saturating_sub(t.elapsed()))
        } else {
            Duration::from_secs(1)
        };
        // SAFETY: our waitset; no attach-result buffer requested.
        let _ = unsafe {
            cyclonedds_sys::dds_waitset_wait(ents.waitset, std::ptr::null_mut(), 0, timeout.as_nanos() as i64)
        };
        if stop.load(Ordering::SeqCst) {
            break;
        }
        pending = false;
        let mut took = 0;
        for (reader, which) in ents.readers {
            let mut batches = 0;
            loop {
                let n = take_batch(reader, which, &mut tracker);
                took += n;
                if n < BATCH {
                    break;
                }
                batches += 1;
                if batches >= BATCHES_PER_WAKE {
                    pending = true; // more left; the status was reset by the take
                    break;
                }
            }
        }
        if took > 0 && tracker.is_dirty() {
            changed_at = Some(Instant::now());
        }
        let due = last_publish.map_or(true, |t| t.elapsed() >= min_interval);
        if tracker.is_dirty() && due {
            generation += 1;
            let mut snapshot = tracker.snapshot(domain, generation);
            snapshot.changed_at = changed_at;
            cell.publish(Arc::new(snapshot));
            last_publish = Some(Instant::now());
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Busy-domain helper (tests, and later the loop benchmark with a busy domain)
// ---------------------------------------------------------------------------------------------

/// Endpoints that exist only to be discovered; dropped together.
pub struct BusyEndpoints {
    _writers: Vec<crate::dds::Writer<handgate_idl::unitree_go::MotorCmds_>>,
    _readers: Vec<crate::dds::Reader<handgate_idl::unitree_go::MotorCmds_>>,
}

impl fmt::Debug for BusyEndpoints {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("BusyEndpoints").field("endpoints", &self.len()).finish()
    }
}

impl BusyEndpoints {
    pub fn len(&self) -> usize {
        self._writers.len() + self._readers.len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Creates `k` endpoints on `node` (every other one a writer, the rest readers; unitree_go
/// `MotorCmds_`, best effort), each on its own topic `{prefix}{i}`. Nothing is written.
/// Run it in another participant (ideally another process, `adapters/examples/busy_domain.rs`) than
/// the one measured.
pub fn busy_endpoints(node: &Node, k: usize, prefix: &str) -> Result<BusyEndpoints, DdsError> {
    let mut w = Vec::with_capacity(k.div_ceil(2));
    let mut r = Vec::with_capacity(k / 2);
    for i in 0..k {
        let topic = format!("{prefix}{i}");
        if i % 2 == 0 {
            w.push(node.writer(&topic, crate::dds::Qos::BestEffort)?);
        } else {
            r.push(node.reader(&topic, crate::dds::Qos::BestEffort)?);
        }
    }
    Ok(BusyEndpoints {
        _writers: w,
        _readers: r,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn raw_ep(n: u8, participant: u8, topic: &str) -> RawEndpoint {
        let mut key = [participant; 16];
        key[15] = n;
        RawEndpoint {
            key: Guid(key),
            participant: Guid([participant; 16]).participant(),
            role: Role::Writer,
            topic: Arc::from(topic),
            type_name: Arc::from("t::T_"),
            qos: EndpointQos::default(),
        }
    }

    fn raw_p(n: u8, host: &str, pid: u32) -> RawParticipant {
        RawParticipant {
            key: Guid([n; 16]).participant(),
            hostname: Some(Arc::from(host)),
            pid: Some(pid),
            process_name: None,
            network_addresses: Vec::new(),
        }
    }

    #[test]
    fn tracker_bounds_endpoints_and_counts_drops() {
        let cfg = DiscoveryConfig {
            max_endpoints: 3,
            max_participants: 1,
            ..Default::default()
        };
        let mut t = Tracker::new(cfg, Guid::default());
        for i in 0..5u8 {
            t.upsert_endpoint(u64::from(i), raw_ep(i, 1, "rt/a"));
        }
        t.upsert_participant(1, raw_p(1, "h", 1));
        t.upsert_participant(2, raw_p(2, "h", 2));
        let s = t.snapshot(0, 1);
        assert_eq!(s.endpoints.len(), 3);
        assert_eq!(s.counters.dropped_endpoints, 2);
        assert_eq!(s.participants.len(), 1);
        assert_eq!(s.counters.dropped_participants, 1);
        // A slot freed by a disposal takes the next new endpoint.
        t.remove_endpoint(0);
        t.upsert_endpoint(9, raw_ep(9, 1, "rt/b"));
        let s = t.snapshot(0, 2);
        assert_eq!(s.endpoints.len(), 3);
        assert!(s.endpoints.iter().any(|e| &*e.topic == "rt/b"));
        assert_eq!(s.counters.dropped_endpoints, 2);
    }

    #[test]
    fn tracker_update_in_place_is_not_a_drop_and_unchanged_is_not_dirty() {
        let mut t = Tracker::new(
            DiscoveryConfig {
                max_endpoints: 1,
                ..Default::default()
            },
            Guid::default(),
        );
        t.upsert_endpoint(7, raw_ep(1, 1, "rt/a"));
        let _ = t.snapshot(0, 1);
        t.upsert_endpoint(7, raw_ep(1, 1, "rt/a"));
        assert!(!t.is_dirty());
        t.upsert_endpoint(7, raw_ep(1, 1, "rt/a2"));
        assert!(t.is_dirty());
        assert_eq!(t.snapshot(0, 2).counters.dropped_endpoints, 0);
    }

    #[test]
    fn origins_from_own_participant_and_process() {
        let me = Guid([1; 16]).participant();
        let mut t = Tracker::new(DiscoveryConfig::default(), me);
        t.upsert_participant(1, raw_p(1, "host", 42));
        t.upsert_participant(2, raw_p(2, "host", 42));
        t.upsert_participant(3, raw_p(3, "host", 43));
        t.upsert_participant(4, raw_p(4, "other", 42));
        for i in 1..=5u8 {
            t.upsert_endpoint(u64::from(i), raw_ep(i, i, "rt/a"));
        }
        let s = t.snapshot(0, 1);
        let origin = |p: u8| {
            s.endpoints
                .iter()
                .find(|e| e.participant == Guid([p; 16]).participant())
                .unwrap()
                .origin
        };
        assert_eq!(origin(1), Origin::ThisParticipant);
        assert_eq!(origin(2), Origin::ThisProcess);
        assert_eq!(origin(3), Origin::Remote);
        assert_eq!(origin(4), Origin::Remote);
        assert_eq!(origin(5), Origin::Remote, "participant not (yet) discovered");
    }

    #[test]
    fn strings_are_capped_on_char_boundaries() {
        let mut s = "ab€cd".to_string(); // € is 3 bytes at 2..5
        assert!(cap_string(&mut s, 4));
        assert_eq!(s, "ab");
        let mut s = "abc".to_string();
        assert!(!cap_string(&mut s, 3));
        let c = std::ffi::CString::new("rt/dex1/left/cmd").unwrap();
        // SAFETY: a valid NUL-terminated string.
        let (s, cut) = unsafe { bounded_cstr(c.as_ptr(), 7) }.unwrap();
        assert_eq!((s.as_str(), cut), ("rt/dex1", true));
        // SAFETY: as above.
        let (s, cut) = unsafe { bounded_cstr(c.as_ptr(), 16) }.unwrap();
        assert_eq!((s.as_str(), cut), ("rt/dex1/left/cmd", false));
        // SAFETY: null is allowed.
        assert!(unsafe { bounded_cstr(std::ptr::null(), 8) }.is_none());
    }

    #[test]
    fn addresses_split_capped_and_unicast_picked() {
        let (a, cut) = split_addresses("udp/239.255.0.1:7400@3, udp/192.168.123.161:40310@3,x,y", 3, 64);
        assert_eq!(a.len(), 3);
        assert_eq!(cut, 1);
        let p = Participant {
            key: Guid::default(),
            hostname: None,
            pid: None,
            process_name: None,
            network_addresses: a,
            origin: Origin::Remote,
        };
        assert_eq!(p.unicast_address(), Some("192.168.123.161"));
        assert_eq!(locator_ip("udp/[fe80::1]:7410@3"), Some("fe80::1"));
        let local = Participant {
            network_addresses: vec![Arc::from("localprocess")],
            ..p
        };
        assert_eq!(local.unicast_address(), None);
    }

    #[test]
    fn guid_display_and_participant() {
        let g = Guid([0x01, 0x10, 0xaa, 0xbb, 0, 0, 0, 1, 2, 3, 4, 5, 0, 0, 0x12, 0x03]);
        assert_eq!(g.to_string(), "0110aabb:00000001:02030405:00001203");
        assert_eq!(g.participant().to_string(), "0110aabb:00000001:02030405:000001c1");
    }
}
