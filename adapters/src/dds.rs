//! A thin, typed layer over cyclonedds-rs: a domain participant bound to a domain id and
//! (optionally) one network interface, writers and readers with readiness checks (matched
//! peers) and a callback-driven reader for event loops.
//!
//! Network interface selection mirrors unitree_sdk2's `ChannelFactoryInitialize(domain, "eth0")`:
//! a CycloneDDS XML config naming the interface is attached to the domain.

use std::marker::PhantomData;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use cyclonedds_rs::{
    dds_domain::DdsDomain, DdsParticipant, DdsQos, DdsReader, DdsTopic, DdsWriter, Entity, ParticipantBuilder,
    SampleBuffer, TopicBuilder, TopicType,
};
use cyclonedds_sys::{dds_durability_kind, dds_history_kind, dds_reliability_kind};

use crate::discovery::{Guid, Role};

/// Errors from the DDS layer.
#[derive(Debug, thiserror::Error)]
pub enum DdsError {
    #[error("DDS {what} failed: {source}")]
    Dds {
        what: &'static str,
        #[source]
        source: cyclonedds_rs::DDSError,
    },
    #[error("invalid network interface name {0:?}")]
    BadInterface(String),
    #[error("trace file path {0:?} has characters other than letters, digits, /, ., - and _")]
    BadTracePath(String),
    #[error("DDS Security file path for {0} is not a valid C string")]
    BadSecurityPath(&'static str),
    #[error("could not join domain {domain} with DDS Security: {detail}")]
    Security { domain: u32, detail: String },
    #[error("could not start a thread: {0}")]
    Thread(String),
    #[error("timed out after {0:?} waiting for {1}")]
    Timeout(Duration, &'static str),
}

fn dds_err(what: &'static str) -> impl FnOnce(cyclonedds_rs::DDSError) -> DdsError {
    move |source| DdsError::Dds { what, source }
}

/// The DDS type name `T` registers (`unitree_hg::msg::dds_::HandCmd_`), as discovery sees it.
pub fn type_name<T: TopicType>() -> String {
    T::typename().to_string_lossy().into_owned()
}

/// Reliability/history of a topic endpoint.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Qos {
    /// Best effort, keep last 1: high-rate state streams where only the newest matters.
    BestEffort,
    /// Reliable, keep last `depth`: commands and status (unitree_sdk2's default for channels).
    Reliable { depth: i32 },
    /// Best effort, keep last `depth`: a reader that polls and must not lose the samples that
    /// arrive between two polls (the recorder); matches best-effort and reliable writers.
    BestEffortDepth { depth: i32 },
}

/// DURABILITY of an endpoint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Durability {
    /// Samples go to the readers matched when they are written (the DDS and ROS 2 default).
    #[default]
    Volatile,
    /// A writer keeps its history for readers that join later (ROS 2 `transient_local`).
    TransientLocal,
}

/// What an endpoint carries beyond its [`Qos`]: durability and USER_DATA (e.g. a ROS 2
/// type hash, `typehash=RIHS01_...;`, see `handgate_idl::type_hash::user_data`). The default
/// is what [`Node::writer`] and [`Node::reader`] use: volatile, no USER_DATA.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct EndpointOptions {
    pub durability: Durability,
    /// USER_DATA bytes; empty: none.
    pub user_data: Vec<u8>,
}

impl EndpointOptions {
    /// These options with USER_DATA `bytes`.
    pub fn user_data(mut self, bytes: impl Into<Vec<u8>>) -> Self {
        self.user_data = bytes.into();
        self
    }

    /// These options with durability `d`.
    pub fn durability(mut self, d: Durability) -> Self {
        self.durability = d;
        self
    }
}

impl Qos {
    /// The QoS an endpoint created with `self` has, as discovery and its diagnostics compare
    /// it (volatile: durability comes from [`EndpointOptions`], which fronts do not set).
    pub fn served(self) -> crate::discovery::diagnose::ServedQos {
        use crate::discovery::{Durability, History, Reliability};
        let (reliability, history) = match self {
            Qos::BestEffort => (Reliability::BestEffort, History::KeepLast(1)),
            Qos::Reliable { depth } => (Reliability::Reliable, History::KeepLast(depth.max(1))),
            Qos::BestEffortDepth { depth } => (Reliability::BestEffort, History::KeepLast(depth.max(1))),
        };
        crate::discovery::diagnose::ServedQos {
            reliability,
            durability: Durability::Volatile,
            history,
        }
    }

    /// Best effort (no resend, nothing kept for a reader that was not there).
    fn is_best_effort(self) -> bool {
        matches!(self, Qos::BestEffort | Qos::BestEffortDepth { .. })
    }

    /// The QoS of an endpoint of `T`: [`Qos::to_dds_with`], and XCDR2 as the only data
    /// representation for a type with its own (XCDR2) encoding, so that a CycloneDDS reader or
    /// writer of the `@appendable` type it stands for matches it (docs/wire-types.md).
    fn to_dds_for<T: TopicType>(self, opts: &EndpointOptions) -> Result<DdsQos, DdsError> {
        let q = self.to_dds_with(opts)?;
        if !T::own_encoding() {
            return Ok(q);
        }
        extern "C" {
            // CycloneDDS 0.10.2 dds_public_qos.h (not in cyclonedds-sys 0.2.1's bindings).
            fn dds_qset_data_representation(qos: *mut cyclonedds_sys::dds_qos_t, n: u32, values: *const i16);
        }
        /// DDS_DATA_REPRESENTATION_XCDR2 (dds_public_impl.h).
        const XCDR2: i16 = 2;
        let raw = <*const cyclonedds_sys::dds_qos_t>::from(q) as *mut cyclonedds_sys::dds_qos_t;
        // SAFETY: `raw` is the live QoS object `q` owned, now owned by nobody; CycloneDDS copies
        // the one value.
        unsafe {
            dds_qset_data_representation(raw, 1, &XCDR2);
            Ok(qos_from_raw(raw))
        }
    }

    fn to_dds_with(self, opts: &EndpointOptions) -> Result<DdsQos, DdsError> {
        let mut q = self.to_dds()?;
        if opts.durability == Durability::TransientLocal {
            q.set_durability(dds_durability_kind::DDS_DURABILITY_TRANSIENT_LOCAL);
        }
        finish_qos(q, &opts.user_data)
    }

    fn to_dds(self) -> Result<DdsQos, DdsError> {
        let mut q = DdsQos::create().map_err(dds_err("qos create"))?;
        match self {
            Qos::BestEffort => {
                q.set_reliability(
                    dds_reliability_kind::DDS_RELIABILITY_BEST_EFFORT,
                    Duration::from_millis(0),
                );
                q.set_history(dds_history_kind::DDS_HISTORY_KEEP_LAST, 1);
            }
            Qos::Reliable { depth } => {
                q.set_reliability(
                    dds_reliability_kind::DDS_RELIABILITY_RELIABLE,
                    Duration::from_millis(100),
                );
                q.set_history(dds_history_kind::DDS_HISTORY_KEEP_LAST, depth.max(1));
            }
            Qos::BestEffortDepth { depth } => {
                q.set_reliability(
                    dds_reliability_kind::DDS_RELIABILITY_BEST_EFFORT,
                    Duration::from_millis(0),
                );
                q.set_history(dds_history_kind::DDS_HISTORY_KEEP_LAST, depth.max(1));
            }
        }
        Ok(q)
    }
}

/// `q` with USER_DATA `user_data` (unchanged when `user_data` is empty).
fn finish_qos(q: DdsQos, user_data: &[u8]) -> Result<DdsQos, DdsError> {
    if user_data.is_empty() {
        return Ok(q);
    }
    // cyclonedds-rs 0.6.5's DdsQos has no USER_DATA setter and keeps its pointer private: take
    // the pointer out (the wrapper gives up ownership), set the policy through the C API and
    // wrap the same object again.
    let raw = <*const cyclonedds_sys::dds_qos_t>::from(q) as *mut cyclonedds_sys::dds_qos_t;
    // SAFETY: `raw` is the live QoS object `q` owned, now owned by nobody; CycloneDDS copies the
    // bytes of `user_data`.
    unsafe {
        cyclonedds_sys::dds_qset_userdata(raw, user_data.as_ptr().cast(), user_data.len() as _);
        Ok(qos_from_raw(raw))
    }
}

/// A `DdsQos` owning `raw`.
///
/// # Safety
/// `raw` is a live QoS object owned by nobody else. `DdsQos` is a one-field tuple struct
/// holding exactly this pointer (cyclonedds-rs 0.6.5, pinned `=0.6.5`); `transmute` checks the
/// sizes agree.
pub(crate) unsafe fn qos_from_raw(raw: *mut cyclonedds_sys::dds_qos_t) -> DdsQos {
    // SAFETY: see the function's contract.
    unsafe { std::mem::transmute::<*mut cyclonedds_sys::dds_qos_t, DdsQos>(raw) }
}

/// The CycloneDDS XML that binds a domain to one network interface.
pub fn interface_config(interface: &str) -> Result<String, DdsError> {
    Ok(domain_xml(&general_xml(interface)?))
}

/// The `<General>` element that binds a domain to `interface` (its name checked first).
fn general_xml(interface: &str) -> Result<String, DdsError> {
    let ok = !interface.is_empty()
        && interface
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_' | ':'));
    if !ok {
        return Err(DdsError::BadInterface(interface.to_string()));
    }
    Ok(format!(
        "<General><Interfaces><NetworkInterface name=\"{interface}\" priority=\"default\" \
         multicast=\"default\"/></Interfaces></General>"
    ))
}

/// A whole CycloneDDS configuration of one domain from the elements `inner`.
fn domain_xml(inner: &str) -> String {
    format!("<CycloneDDS><Domain Id=\"any\">{inner}</Domain></CycloneDDS>")
}

/// The CycloneDDS XML for one domain: an optional interface, and optionally CycloneDDS's
/// `config` trace (which includes the interfaces it found, the ones it selected and its
/// multicast decision) written to `trace_file`.
fn domain_config(interface: Option<&str>, trace_file: Option<&std::path::Path>) -> Result<String, DdsError> {
    let mut inner = match interface {
        Some(iface) => general_xml(iface)?,
        None => String::new(),
    };
    if let Some(path) = trace_file {
        let path = path.to_string_lossy();
        let ok = path
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '/' | '.' | '-' | '_'));
        if !ok {
            return Err(DdsError::BadTracePath(path.into_owned()));
        }
        inner.push_str(&format!(
            "<Tracing><Category>config</Category><OutputFile>{path}</OutputFile></Tracing>"
        ));
    }
    Ok(domain_xml(&inner))
}

/// What CycloneDDS's `config` trace says about network interfaces (see [`Node::with_trace`]).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct InterfaceTrace {
    /// The `interfaces:` line: every interface CycloneDDS found, with its locator.
    pub found: Option<String>,
    /// The `selected interfaces:` line.
    pub selected: Option<String>,
    /// Every other trace line about an interface or multicast (its decision on multicast,
    /// an interface name that matches nothing, ...), in order.
    pub notes: Vec<String>,
}

impl InterfaceTrace {
    /// Reads the lines of a CycloneDDS trace (`<time> [<domain>] <thread>: <message>`),
    /// skipping the `config:` echo of every setting.
    pub fn parse(trace: &str) -> Self {
        let mut out = Self::default();
        for line in trace.lines() {
            let Some((_, msg)) = line.split_once("]") else { continue };
            let msg = msg.split_once(": ").map_or(msg, |(_, m)| m).trim();
            if msg.starts_with("config:") {
                continue;
            }
            if let Some(v) = msg.strip_prefix("selected interfaces:") {
                out.selected.get_or_insert_with(|| v.trim().to_string());
            } else if let Some(v) = msg.strip_prefix("interfaces:") {
                out.found.get_or_insert_with(|| v.trim().to_string());
            } else {
                let l = msg.to_ascii_lowercase();
                if (l.contains("interface") || l.contains("multicast"))
                    && !l.contains("transmit port")
                    && !l.contains("ports:")
                {
                    out.notes.push(msg.to_string());
                }
            }
        }
        out
    }
}

/// A participant on one DDS domain. Cheap to clone.
#[derive(Clone)]
pub struct Node {
    inner: Arc<NodeInner>,
}

struct NodeInner {
    participant: DdsParticipant,
    domain_id: u32,
    /// The participant's GUID.
    guid: Guid,
    /// Every reader and writer made through this node and still alive, in creation order
    /// (what the ROS 2 graph message lists, `crate::ros`), and a counter bumped on each change.
    endpoints: Mutex<(Vec<(Role, Guid)>, u64)>,
    // Keeps an explicitly configured domain alive as long as the participant.
    _domain: Option<DdsDomain>,
}

// SAFETY-free justification: DDS entity handles are integers used through CycloneDDS's
// thread-safe C API; cyclonedds-rs does not mark them Send/Sync only because of raw pointers
// in listeners, which we never share.
unsafe impl Send for NodeInner {}
unsafe impl Sync for NodeInner {}

impl std::fmt::Debug for Node {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Node")
            .field("domain_id", &self.inner.domain_id)
            .finish()
    }
}

impl Node {
    /// Joins `domain_id`, optionally restricted to one network interface (e.g. "eth0", "lo").
    pub fn new(domain_id: u32, interface: Option<&str>) -> Result<Self, DdsError> {
        let domain = match interface {
            Some(iface) => {
                let cfg = interface_config(iface)?;
                Some(DdsDomain::create(domain_id, Some(&cfg)).map_err(dds_err("domain create"))?)
            }
            None => None,
        };
        Self::join(domain_id, domain)
    }

    /// As [`Node::new`], the participant joining with DDS Security when `security` is given
    /// (its QoS properties: `crate::dds_security`). CycloneDDS's reason for refusing the
    /// identity (a file it cannot read, an expired certificate, permissions that do not
    /// grant the domain) is in the error.
    pub fn with_security(
        domain_id: u32,
        interface: Option<&str>,
        security: Option<&crate::dds_security::Security>,
    ) -> Result<Self, DdsError> {
        let Some(sec) = security else {
            return Self::new(domain_id, interface);
        };
        crate::dds_security::install_log_sink();
        let general = interface.map(general_xml).transpose()?.unwrap_or_default();
        let cfg = domain_xml(&(general + crate::dds_security::DISCOVERY_TRACE));
        // A second secured participant on the same domain in this process (several identities
        // in one test) joins the domain the first one configured.
        let domain = match DdsDomain::create(domain_id, Some(&cfg)) {
            Ok(d) => Some(d),
            Err(cyclonedds_rs::DDSError::PreconditionNotMet) => None,
            Err(e) => return Err(dds_err("domain create")(e)),
        };
        crate::dds_security::mark_secured(domain_id);
        let qos = sec.participant_qos()?;
        let mark = crate::dds_security::errors_seen();
        Self::join_with(domain_id, domain, Some(qos)).map_err(|e| match e {
            DdsError::Dds { .. } => DdsError::Security {
                domain: domain_id,
                detail: crate::dds_security::last_error_since(mark).unwrap_or_else(|| e.to_string()),
            },
            other => other,
        })
    }

    /// A participant on `domain_id`, holding `domain` (an explicitly configured domain) as
    /// long as it lives.
    fn join(domain_id: u32, domain: Option<DdsDomain>) -> Result<Self, DdsError> {
        Self::join_with(domain_id, domain, None)
    }

    fn join_with(domain_id: u32, domain: Option<DdsDomain>, qos: Option<DdsQos>) -> Result<Self, DdsError> {
        let mut builder = ParticipantBuilder::new().with_domain(domain_id);
        if let Some(q) = qos {
            builder = builder.with_qos(q);
        }
        let participant = builder.create().map_err(dds_err("participant create"))?;
        // SAFETY: only reads the integer handle out of the wrapper.
        let guid = entity_guid(unsafe { participant.entity().entity() })?;
        Ok(Self {
            inner: Arc::new(NodeInner {
                participant,
                domain_id,
                guid,
                endpoints: Mutex::new((Vec::new(), 0)),
                _domain: domain,
            }),
        })
    }

    /// The participant's DDS GUID.
    pub fn guid(&self) -> Guid {
        self.inner.guid
    }

    /// The readers and writers made through this node that are alive, in creation order, and
    /// a generation number that changes whenever that list does.
    pub fn endpoints(&self) -> (Vec<(Role, Guid)>, u64) {
        let g = self.inner.endpoints.lock().unwrap_or_else(|p| p.into_inner());
        (g.0.clone(), g.1)
    }

    fn register(&self, role: Role, entity: cyclonedds_sys::dds_entity_t) -> Result<Guid, DdsError> {
        let guid = entity_guid(entity)?;
        let mut g = self.inner.endpoints.lock().unwrap_or_else(|p| p.into_inner());
        g.0.push((role, guid));
        g.1 += 1;
        Ok(guid)
    }

    fn unregister(&self, guid: Guid) {
        let mut g = self.inner.endpoints.lock().unwrap_or_else(|p| p.into_inner());
        g.0.retain(|(_, k)| *k != guid);
        g.1 += 1;
    }

    /// As [`Node::new`], and CycloneDDS writes its `config` trace for this domain to
    /// `trace_file` ([`InterfaceTrace::parse`] reads what it chose). Without an interface the
    /// configuration in `CYCLONEDDS_URI` (if any) still applies, the trace added to it; with
    /// one, as [`Node::new`], only the interface is configured.
    pub fn with_trace(domain_id: u32, interface: Option<&str>, trace_file: &std::path::Path) -> Result<Self, DdsError> {
        let ours = domain_config(interface, Some(trace_file))?;
        let cfg = match (interface, std::env::var("CYCLONEDDS_URI")) {
            (None, Ok(env)) if !env.trim().is_empty() => format!("{env},{ours}"),
            _ => ours,
        };
        let domain = DdsDomain::create(domain_id, Some(&cfg)).map_err(dds_err("domain create"))?;
        Self::join(domain_id, Some(domain))
    }

    pub fn domain_id(&self) -> u32 {
        self.inner.domain_id
    }

    /// The participant's C entity handle, for this crate's modules that use the C API
    /// directly (discovery). Valid as long as a clone of this `Node` is alive.
    pub(crate) fn participant_entity(&self) -> cyclonedds_sys::dds_entity_t {
        // SAFETY: only reads the integer handle out of the wrapper; no C call.
        unsafe { self.inner.participant.entity().entity() }
    }

    fn topic<T: TopicType>(&self, name: &str) -> Result<DdsTopic<T>, DdsError> {
        TopicBuilder::<T>::new()
            .with_name(name.to_string())
            .create(&self.inner.participant)
            .map_err(dds_err("topic create"))
    }

    /// A writer of `T` on topic `name`.
    pub fn writer<T: TopicType>(&self, name: &str, qos: Qos) -> Result<Writer<T>, DdsError> {
        self.writer_with(name, qos, &EndpointOptions::default())
    }

    /// A writer of `T` on topic `name` with durability and USER_DATA from `opts`.
    pub fn writer_with<T: TopicType>(
        &self,
        name: &str,
        qos: Qos,
        opts: &EndpointOptions,
    ) -> Result<Writer<T>, DdsError> {
        let topic = self.topic::<T>(name)?;
        let writer = DdsWriter::create(&self.inner.participant, topic, Some(qos.to_dds_for::<T>(opts)?), None)
            .map_err(dds_err("writer create"))?;
        // SAFETY: only reads the integer handle out of the wrapper.
        let guid = self.register(Role::Writer, unsafe { writer.entity().entity() })?;
        Ok(Writer {
            writer,
            node: self.clone(),
            topic: name.to_string(),
            guid,
            skip_unmatched: qos.is_best_effort() && opts.durability == Durability::Volatile,
        })
    }

    /// A polled reader of `T` on topic `name`.
    pub fn reader<T: TopicType>(&self, name: &str, qos: Qos) -> Result<Reader<T>, DdsError> {
        self.reader_with(name, qos, &EndpointOptions::default())
    }

    /// A polled reader of `T` on topic `name` with durability and USER_DATA from `opts`.
    pub fn reader_with<T: TopicType>(
        &self,
        name: &str,
        qos: Qos,
        opts: &EndpointOptions,
    ) -> Result<Reader<T>, DdsError> {
        let topic = self.topic::<T>(name)?;
        let reader = DdsReader::create(&self.inner.participant, topic, Some(qos.to_dds_for::<T>(opts)?), None)
            .map_err(dds_err("reader create"))?;
        // SAFETY: only reads the integer handle out of the wrapper.
        let guid = self.register(Role::Reader, unsafe { reader.entity().entity() })?;
        Ok(Reader {
            reader,
            node: self.clone(),
            topic: name.to_string(),
            guid,
            _p: PhantomData,
        })
    }

    /// A reader that calls `on_data` from CycloneDDS's listener thread whenever samples
    /// arrive. `on_data` must be quick (forward to a channel). A panic in `on_data` is caught
    /// here and logged: it never reaches CycloneDDS's C frames (the listener trampoline is
    /// `extern "C"`, where a panic aborts the process: every device would stop where it is,
    /// with no safe state); the next samples call `on_data` again.
    pub fn reader_with_callback<T, F>(&self, name: &str, qos: Qos, on_data: F) -> Result<Reader<T>, DdsError>
    where
        T: TopicType + 'static,
        F: FnMut(&DdsReaderHandle<T>) + Send + 'static,
    {
        self.reader_with_callback_opts(name, qos, &EndpointOptions::default(), on_data)
    }

    /// [`Self::reader_with_callback`] with durability and USER_DATA from `opts` (a ROS-typed
    /// reader's type hash).
    pub fn reader_with_callback_opts<T, F>(
        &self,
        name: &str,
        qos: Qos,
        opts: &EndpointOptions,
        mut on_data: F,
    ) -> Result<Reader<T>, DdsError>
    where
        T: TopicType + 'static,
        F: FnMut(&DdsReaderHandle<T>) + Send + 'static,
    {
        let topic = self.topic::<T>(name)?;
        let topic_name = name.to_string();
        let listener = cyclonedds_rs::DdsListenerBuilder::new()
            .on_data_available(move |entity| {
                let _within = Enter::new(Within::Callback);
                let handle = DdsReaderHandle::<T> {
                    entity,
                    _p: PhantomData,
                };
                if std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| on_data(&handle))).is_err() {
                    tracing::error!(topic = %topic_name, "a reader callback panicked (caught; the reader goes on)");
                }
            })
            .build();
        let reader = DdsReader::create(
            &self.inner.participant,
            topic,
            Some(qos.to_dds_for::<T>(opts)?),
            Some(listener),
        )
        .map_err(dds_err("reader create"))?;
        // SAFETY: only reads the integer handle out of the wrapper.
        let guid = self.register(Role::Reader, unsafe { reader.entity().entity() })?;
        Ok(Reader {
            reader,
            node: self.clone(),
            topic: name.to_string(),
            guid,
            _p: PhantomData,
        })
    }
}

/// Passed to a reader callback: take the samples that arrived.
pub struct DdsReaderHandle<T> {
    entity: cyclonedds_sys::DdsEntity,
    _p: PhantomData<T>,
}

impl<T: TopicType> DdsReaderHandle<T> {
    /// Takes every available sample, oldest first, appending clones to `out`.
    pub fn take_into(&self, out: &mut Vec<T>) -> usize
    where
        T: Clone,
    {
        take_each(&self.entity, |s, _, _| out.push(s))
    }

    /// Takes every available sample, oldest first, appending clones to `out` with the
    /// handle of the writer that wrote each and its source timestamp (ns since the UNIX
    /// epoch by the writer's clock; `None`: the sample carries none).
    pub fn take_with_writers(&self, out: &mut Vec<(T, WriterHandle, Option<i64>)>) -> usize
    where
        T: Clone,
    {
        take_each(&self.entity, |s, w, t| out.push((s, w, t)))
    }

    /// What this reader knows of the matched writer `handle` (its GUID, its participant's,
    /// its USER_DATA); only the handle when the writer is no longer matched.
    pub fn matched_writer(&self, handle: WriterHandle) -> WriterInfo {
        // SAFETY: reads the integer handle of the reader this callback runs for.
        matched_writer(unsafe { self.entity.entity() }, handle)
    }
}

/// The writer of a sample as a reader knows it: the writer's instance handle on the reading
/// participant (`dds_sample_info::publication_handle`), stable while the writer is matched.
pub type WriterHandle = cyclonedds_sys::dds_instance_handle_t;

/// Longest USER_DATA kept from a matched writer, bytes (the rest is cut).
pub const MAX_USER_DATA: usize = 64;

/// A writer matched by a reader, read once from CycloneDDS's matched-publication data.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct WriterInfo {
    pub handle: WriterHandle,
    /// The writer's GUID (`None`: no longer matched when asked).
    pub guid: Option<crate::discovery::Guid>,
    /// The GUID of the writer's participant (names its process through discovery).
    pub participant: Option<crate::discovery::Guid>,
    /// The writer's USER_DATA QoS, at most [`MAX_USER_DATA`] bytes.
    pub user_data: Vec<u8>,
    /// A writer that is not a DDS endpoint (a dashboard page): how logs name it.
    pub label: Option<String>,
}

mod ffi {
    extern "C" {
        // libddsc 0.10.2 exports it; cyclonedds-sys 0.2.1 does not declare it.
        pub fn dds_builtintopic_free_endpoint(e: *mut cyclonedds_sys::dds_builtintopic_endpoint_t);
    }
}

fn matched_writer(reader: cyclonedds_sys::dds_entity_t, handle: WriterHandle) -> WriterInfo {
    let mut info = WriterInfo {
        handle,
        ..WriterInfo::default()
    };
    // SAFETY: `reader` is a live reader; the handle is a plain integer (an unknown one gives
    // null). A non-null result is an endpoint CycloneDDS allocated for us, freed below.
    let ep = unsafe { cyclonedds_sys::dds_get_matched_publication_data(reader, handle) };
    if ep.is_null() {
        return info;
    }
    // SAFETY: `ep` is valid until freed at the end of this block; its qos is null or valid;
    // the USER_DATA copy is CycloneDDS's allocation of `sz` bytes, which we own and free.
    unsafe {
        info.guid = Some(crate::discovery::Guid((*ep).key.v));
        info.participant = Some(crate::discovery::Guid((*ep).participant_key.v));
        let qos = (*ep).qos;
        if !qos.is_null() {
            let mut value: *mut std::ffi::c_void = std::ptr::null_mut();
            let mut sz: cyclonedds_sys::size_t = 0;
            let found = cyclonedds_sys::dds_qget_userdata(qos, &mut value, &mut sz);
            if !value.is_null() {
                if found {
                    let n = (sz as usize).min(MAX_USER_DATA);
                    info.user_data = std::slice::from_raw_parts(value.cast::<u8>(), n).to_vec();
                }
                cyclonedds_sys::dds_free(value);
            }
        }
        ffi::dds_builtintopic_free_endpoint(ep);
    }
    info
}

/// CycloneDDS's "no timestamp" (`DDS_TIME_INVALID`): the source timestamp of a sample whose
/// writer sent none.
const DDS_TIME_INVALID: i64 = i64::MIN;

/// Takes every available sample, oldest first, handing each (cloned) to `each` with the
/// handle of its writer and its source timestamp (`None`: it carries none).
fn take_each<T: TopicType + Clone>(
    entity: &cyclonedds_sys::DdsEntity,
    mut each: impl FnMut(T, WriterHandle, Option<i64>),
) -> usize {
    const BATCH: usize = 16;
    let mut total = 0;
    loop {
        let mut buf = SampleBuffer::<T>::new(BATCH);
        let n = match DdsReader::<T>::readn_from_entity_now(entity, &mut buf, true) {
            Ok(n) => n,
            Err(_) => break, // no data (cyclonedds-rs reports "no data" as an error)
        };
        // The buffer's own sample infos, filled by the take above (cyclonedds-rs keeps the
        // field private; the pointer is its public way to them).
        // SAFETY: only the pointer is taken; nothing is written through it.
        let (_, infos) = unsafe { buf.as_mut_ptr() };
        for i in 0..n.min(BATCH) {
            if buf.is_valid_sample(i) {
                // SAFETY: `infos` points to the buffer's BATCH infos, alive as long as `buf`;
                // i < BATCH.
                let (writer, stamp) = unsafe { ((*infos.add(i)).publication_handle, (*infos.add(i)).source_timestamp) };
                if let Some(s) = buf.get(i).try_deref() {
                    each(s.clone(), writer, (stamp != DDS_TIME_INVALID).then_some(stamp));
                    total += 1;
                }
            }
        }
        if n < BATCH {
            break;
        }
    }
    total
}

/// Where this thread is in the DDS layer: what a device loop allocates inside a write is
/// cyclonedds-rs's and CycloneDDS's, and inside a reader callback its reader's (docs/deployment.md,
/// "Real-time"). `adapters/tests/rt_alloc.rs` counts those apart from the loop's own.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Within {
    /// In none of the below.
    Caller,
    /// Inside [`Writer::write`]: the binding and CycloneDDS handling one sample.
    Write,
    /// Inside a callback of [`Node::reader_with_callback`]. CycloneDDS delivers a sample to a
    /// reader of the same process on the writing thread: an in-process reader's callback runs
    /// inside the write, on the writer's thread.
    Callback,
    /// Inside a DDS-client device's own work (`dds_device`), on whichever thread runs it: its
    /// loop's, or the thread that brings a command or a sample and takes it at once. A write
    /// or a callback inside it is [`Within::Write`] / [`Within::Callback`] until it returns.
    Device,
}

thread_local! {
    static WITHIN: std::cell::Cell<Within> = const { std::cell::Cell::new(Within::Caller) };
}

/// Where this thread is in the DDS layer; reading it never allocates.
pub fn within() -> Within {
    WITHIN.with(std::cell::Cell::get)
}

/// This thread is `Within` something until dropped (then back where it was).
pub(crate) struct Enter(Within);

impl Enter {
    pub(crate) fn new(w: Within) -> Self {
        Enter(WITHIN.with(|c| c.replace(w)))
    }
}

impl Drop for Enter {
    fn drop(&mut self) {
        WITHIN.with(|c| c.set(self.0));
    }
}

/// A typed writer.
pub struct Writer<T: TopicType> {
    writer: DdsWriter<T>,
    node: Node,
    topic: String,
    guid: Guid,
    /// A best-effort, volatile writer skips a write while no reader is matched: no reader
    /// could ever receive that sample (none keeps it for a late joiner), so it is neither
    /// copied nor serialized (a front's state with no client attached).
    skip_unmatched: bool,
}

impl<T: TopicType> Drop for Writer<T> {
    fn drop(&mut self) {
        self.node.unregister(self.guid);
    }
}

unsafe impl<T: TopicType> Send for Writer<T> {}

impl<T: TopicType> Writer<T> {
    pub fn write(&mut self, sample: T) -> Result<(), DdsError> {
        if self.unread() {
            return Ok(());
        }
        self.send(sample)
    }

    /// Builds a sample with `build` and writes it, unless a write now would reach no reader
    /// (then nothing is built: a front's state with no client attached). `None` writes nothing.
    pub fn write_with(&mut self, build: impl FnOnce() -> Option<T>) -> Result<(), DdsError> {
        if self.unread() {
            return Ok(());
        }
        build().map_or(Ok(()), |sample| self.send(sample))
    }

    /// Whether a write now would reach no reader and is skipped (a best-effort, volatile writer
    /// with no matched reader).
    fn unread(&self) -> bool {
        self.skip_unmatched && self.matched() == 0
    }

    fn send(&mut self, sample: T) -> Result<(), DdsError> {
        let _within = Enter::new(Within::Write);
        self.writer.write(Arc::new(sample)).map_err(dds_err("write"))
    }

    /// Writes a copy of `sample`, which the caller keeps to fill again. cyclonedds-rs takes
    /// each sample as an owned `Arc` and CycloneDDS holds on to it after the call (the
    /// writer's history, in-process readers), so every write hands over a new copy: made
    /// here, inside the write, where it belongs to the binding's part (docs/deployment.md,
    /// "Real-time").
    pub fn write_copy(&mut self, sample: &T) -> Result<(), DdsError>
    where
        T: Clone,
    {
        if self.unread() {
            return Ok(());
        }
        let _within = Enter::new(Within::Write);
        self.writer.write(Arc::new(sample.clone())).map_err(dds_err("write"))
    }

    /// Writes `sample` with source timestamp `source_ns` (ns since the UNIX epoch) instead of
    /// this host's clock at the write (CycloneDDS's `dds_write_ts`): a client replaying what
    /// a bridge delivers out of order, or a test of a front's ordering rule.
    pub fn write_ts(&mut self, sample: T, source_ns: i64) -> Result<(), DdsError> {
        if self.unread() {
            return Ok(());
        }
        let _within = Enter::new(Within::Write);
        let sample = cyclonedds_rs::Sample::<T>::from(Arc::new(sample));
        // SAFETY: a live writer; `sample` is what cyclonedds-rs's own `write` hands
        // `dds_write` (a `Sample<T>` the sertype's callbacks read), alive across the call.
        let rc = unsafe {
            cyclonedds_sys::dds_write_ts(
                self.writer.entity().entity(),
                (&sample as *const cyclonedds_rs::Sample<T>).cast(),
                source_ns,
            )
        };
        if rc < 0 {
            return Err(DdsError::Dds {
                what: "write",
                source: cyclonedds_rs::DDSError::from(rc),
            });
        }
        Ok(())
    }

    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// The writer's DDS GUID.
    pub fn guid(&self) -> Guid {
        self.guid
    }

    /// Number of readers currently matched.
    pub fn matched(&self) -> u32 {
        let mut st = cyclonedds_sys::dds_publication_matched_status_t::default();
        // SAFETY: valid writer handle; status struct is a plain C out-parameter.
        let rc = unsafe { cyclonedds_sys::dds_get_publication_matched_status(self.writer.entity().entity(), &mut st) };
        if rc < 0 {
            0
        } else {
            st.current_count
        }
    }

    /// Blocks until at least `n` readers are matched.
    pub fn wait_matched(&self, n: u32, timeout: Duration) -> Result<(), DdsError> {
        wait_until(timeout, "matched reader", || self.matched() >= n)
    }
}

/// A typed reader (polled, or callback-driven when made with `reader_with_callback`).
pub struct Reader<T: TopicType> {
    reader: DdsReader<T>,
    node: Node,
    topic: String,
    guid: Guid,
    _p: PhantomData<T>,
}

impl<T: TopicType> Drop for Reader<T> {
    fn drop(&mut self) {
        self.node.unregister(self.guid);
    }
}

unsafe impl<T: TopicType> Send for Reader<T> {}

impl<T: TopicType + Clone> Reader<T> {
    /// Takes every available sample, oldest first.
    pub fn take(&self) -> Vec<T> {
        let mut out = Vec::new();
        take_each(self.reader.entity(), |s, _, _| out.push(s));
        out
    }

    /// Takes every available sample, oldest first, with its source timestamp (ns since the
    /// epoch, the writer's clock).
    pub fn take_stamped(&self, out: &mut Vec<(T, i64)>) -> usize {
        const BATCH: usize = 16;
        let mut total = 0;
        loop {
            let mut buf = SampleBuffer::<T>::new(BATCH);
            // SAFETY: only the pointer to the buffer's sample-info array is kept; the array
            // is not reallocated while `buf` lives, and it is read after the take filled it.
            let (_, info) = unsafe { buf.as_mut_ptr() };
            let n = match DdsReader::<T>::readn_from_entity_now(self.reader.entity(), &mut buf, true) {
                Ok(n) => n,
                Err(_) => break,
            };
            for i in 0..n {
                if buf.is_valid_sample(i) {
                    if let Some(s) = buf.get(i).try_deref() {
                        // SAFETY: i < n <= BATCH, the length of the info array.
                        let stamp = unsafe { (*info.add(i)).source_timestamp };
                        out.push((s.clone(), stamp));
                        total += 1;
                    }
                }
            }
            if n < BATCH {
                break;
            }
        }
        total
    }

    /// Polls until at least one sample arrives.
    pub fn wait_take(&self, timeout: Duration) -> Result<Vec<T>, DdsError> {
        let deadline = Instant::now() + timeout;
        loop {
            let v = self.take();
            if !v.is_empty() {
                return Ok(v);
            }
            if Instant::now() >= deadline {
                return Err(DdsError::Timeout(timeout, "a sample"));
            }
            std::thread::sleep(Duration::from_micros(200));
        }
    }
}

impl<T: TopicType> Reader<T> {
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// The reader's DDS GUID.
    pub fn guid(&self) -> Guid {
        self.guid
    }

    /// Number of writers currently matched.
    pub fn matched(&self) -> u32 {
        let mut st = cyclonedds_sys::dds_subscription_matched_status_t::default();
        // SAFETY: valid reader handle; status struct is a plain C out-parameter.
        let rc = unsafe { cyclonedds_sys::dds_get_subscription_matched_status(self.reader.entity().entity(), &mut st) };
        if rc < 0 {
            0
        } else {
            st.current_count
        }
    }

    /// Blocks until at least `n` writers are matched.
    pub fn wait_matched(&self, n: u32, timeout: Duration) -> Result<(), DdsError> {
        wait_until(timeout, "matched writer", || self.matched() >= n)
    }
}

extern "C" {
    // Not in cyclonedds-sys 0.2.1's bindings; CycloneDDS 0.10's `dds_get_guid`.
    fn dds_get_guid(
        entity: cyclonedds_sys::dds_entity_t,
        guid: *mut cyclonedds_sys::dds_guid_t,
    ) -> cyclonedds_sys::dds_return_t;
}

/// The DDS GUID of a live entity (participant, reader, writer).
pub(crate) fn entity_guid(entity: cyclonedds_sys::dds_entity_t) -> Result<Guid, DdsError> {
    let mut g = cyclonedds_sys::dds_guid_t::default();
    // SAFETY: `g` is a plain out-parameter; an invalid handle is reported as an error code.
    let rc = unsafe { dds_get_guid(entity, &mut g) };
    if rc < 0 {
        return Err(DdsError::Dds {
            what: "get guid",
            source: cyclonedds_rs::DDSError::from(rc),
        });
    }
    Ok(Guid(g.v))
}

fn wait_until(timeout: Duration, what: &'static str, mut cond: impl FnMut() -> bool) -> Result<(), DdsError> {
    let deadline = Instant::now() + timeout;
    while !cond() {
        if Instant::now() >= deadline {
            return Err(DdsError::Timeout(timeout, what));
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    Ok(())
}

/// A reader of one topic that keeps each sample's bytes (`handgate doctor`'s layout check).
pub trait RawTake {
    fn take_bytes(&self) -> Vec<Vec<u8>>;
}

impl<T: handgate_idl::DdsTypeName> RawTake for Reader<handgate_idl::layout::Raw<T>> {
    fn take_bytes(&self) -> Vec<Vec<u8>> {
        self.take().into_iter().map(|r| r.bytes).collect()
    }
}

/// A best-effort reader keeping the raw bytes of `topic`, for the types whose older layouts
/// `handgate_idl::layout` knows (the Unitree hand messages); `None` for any other type.
pub fn layout_reader(node: &Node, topic: &str, type_name: &str) -> Result<Option<Box<dyn RawTake>>, DdsError> {
    use handgate_idl::layout::Raw;
    use handgate_idl::{unitree_hg, DdsTypeName};
    Ok(if type_name == unitree_hg::HandCmd_::DDS_TYPE_NAME {
        Some(Box::new(
            node.reader::<Raw<unitree_hg::HandCmd_>>(topic, Qos::BestEffort)?,
        ))
    } else if type_name == unitree_hg::HandState_::DDS_TYPE_NAME {
        Some(Box::new(
            node.reader::<Raw<unitree_hg::HandState_>>(topic, Qos::BestEffort)?,
        ))
    } else {
        None
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interface_trace_lines() {
        // Lines as CycloneDDS 0.10.2 writes them (measured here, `Tracing/Category config`).
        let t = "1795523015.6 [147]     python: config: Domain/General/AllowMulticast/#text: default {}\n\
                 1795523015.6 [147]     python: interfaces: lo udp/127.0.0.1(q1) eth0 udp/192.0.2.2(q9)\n\
                 1795523015.6 [147]     python: selected interfaces: lo (index 1 priority 2)\n\
                 1795523015.6 [147]     python: selected interface \"lo\" is not multicast-capable: disabling multicast\n\
                 1795523015.6 [147]     python: interface lo: transmit port 50754\n";
        let p = InterfaceTrace::parse(t);
        assert_eq!(p.found.as_deref(), Some("lo udp/127.0.0.1(q1) eth0 udp/192.0.2.2(q9)"));
        assert_eq!(p.selected.as_deref(), Some("lo (index 1 priority 2)"));
        assert_eq!(
            p.notes,
            vec!["selected interface \"lo\" is not multicast-capable: disabling multicast".to_string()]
        );
    }

    #[test]
    fn domain_config_validates_names() {
        assert!(domain_config(Some("eth0"), Some(std::path::Path::new("/tmp/x.log"))).is_ok());
        assert!(domain_config(Some("eth0\"/>"), None).is_err());
        assert!(domain_config(None, Some(std::path::Path::new("/tmp/a b<"))).is_err());
    }
}
