//! A thin, typed layer over cyclonedds-rs: a domain participant bound to a domain id and
//! (optionally) one network interface, writers and readers with readiness checks (matched
//! peers) and a callback-driven reader for event loops.
//!
//! Network interface selection mirrors unitree_sdk2's `ChannelFactoryInitialize(domain, "eth0")`:
//! a CycloneDDS XML config naming the interface is attached to the domain.

use std::marker::PhantomData;
use std::sync::Arc;
use std::time::{Duration, Instant};

use cyclonedds_rs::{
    dds_domain::DdsDomain, DdsParticipant, DdsQos, DdsReader, DdsTopic, DdsWriter, Entity, ParticipantBuilder,
    SampleBuffer, TopicBuilder, TopicType,
};
use cyclonedds_sys::{dds_history_kind, dds_reliability_kind};

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

impl Qos {
    /// The QoS an endpoint created with `self` has, as discovery and its diagnostics compare
    /// it (volatile: nothing here sets durability).
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

/// The CycloneDDS XML that binds a domain to one network interface.
pub fn interface_config(interface: &str) -> Result<String, DdsError> {
    let ok = !interface.is_empty()
        && interface
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_' | ':'));
    if !ok {
        return Err(DdsError::BadInterface(interface.to_string()));
    }
    Ok(format!(
        "<CycloneDDS><Domain Id=\"any\"><General><Interfaces><NetworkInterface name=\"{interface}\" \
         priority=\"default\" multicast=\"default\"/></Interfaces></General></Domain></CycloneDDS>"
    ))
}

/// A participant on one DDS domain. Cheap to clone.
#[derive(Clone)]
pub struct Node {
    inner: Arc<NodeInner>,
}

struct NodeInner {
    participant: DdsParticipant,
    domain_id: u32,
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
        let participant = ParticipantBuilder::new()
            .with_domain(domain_id)
            .create()
            .map_err(dds_err("participant create"))?;
        Ok(Self {
            inner: Arc::new(NodeInner {
                participant,
                domain_id,
                _domain: domain,
            }),
        })
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
        let topic = self.topic::<T>(name)?;
        let writer = DdsWriter::create(&self.inner.participant, topic, Some(qos.to_dds()?), None)
            .map_err(dds_err("writer create"))?;
        Ok(Writer {
            writer,
            _node: self.clone(),
            topic: name.to_string(),
        })
    }

    /// A polled reader of `T` on topic `name`.
    pub fn reader<T: TopicType>(&self, name: &str, qos: Qos) -> Result<Reader<T>, DdsError> {
        let topic = self.topic::<T>(name)?;
        let reader = DdsReader::create(&self.inner.participant, topic, Some(qos.to_dds()?), None)
            .map_err(dds_err("reader create"))?;
        Ok(Reader {
            reader,
            _node: self.clone(),
            topic: name.to_string(),
            _p: PhantomData,
        })
    }

    /// A reader that calls `on_data` from CycloneDDS's listener thread whenever samples
    /// arrive. `on_data` must be quick (forward to a channel).
    pub fn reader_with_callback<T, F>(&self, name: &str, qos: Qos, mut on_data: F) -> Result<Reader<T>, DdsError>
    where
        T: TopicType + 'static,
        F: FnMut(&DdsReaderHandle<T>) + Send + 'static,
    {
        let topic = self.topic::<T>(name)?;
        let listener = cyclonedds_rs::DdsListenerBuilder::new()
            .on_data_available(move |entity| {
                let handle = DdsReaderHandle::<T> {
                    entity,
                    _p: PhantomData,
                };
                on_data(&handle);
            })
            .build();
        let reader = DdsReader::create(&self.inner.participant, topic, Some(qos.to_dds()?), Some(listener))
            .map_err(dds_err("reader create"))?;
        Ok(Reader {
            reader,
            _node: self.clone(),
            topic: name.to_string(),
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
        take_all(&self.entity, out)
    }
}

fn take_all<T: TopicType + Clone>(entity: &cyclonedds_sys::DdsEntity, out: &mut Vec<T>) -> usize {
    const BATCH: usize = 16;
    let mut total = 0;
    loop {
        let mut buf = SampleBuffer::<T>::new(BATCH);
        let n = match DdsReader::<T>::readn_from_entity_now(entity, &mut buf, true) {
            Ok(n) => n,
            Err(_) => break, // no data (cyclonedds-rs reports "no data" as an error)
        };
        for i in 0..n {
            if buf.is_valid_sample(i) {
                if let Some(s) = buf.get(i).try_deref() {
                    out.push(s.clone());
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

/// A typed writer.
pub struct Writer<T: TopicType> {
    writer: DdsWriter<T>,
    _node: Node,
    topic: String,
}

unsafe impl<T: TopicType> Send for Writer<T> {}

impl<T: TopicType> Writer<T> {
    pub fn write(&mut self, sample: T) -> Result<(), DdsError> {
        self.writer.write(Arc::new(sample)).map_err(dds_err("write"))
    }

    pub fn topic(&self) -> &str {
        &self.topic
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
    _node: Node,
    topic: String,
    _p: PhantomData<T>,
}

unsafe impl<T: TopicType> Send for Reader<T> {}

impl<T: TopicType + Clone> Reader<T> {
    /// Takes every available sample, oldest first.
    pub fn take(&self) -> Vec<T> {
        let mut out = Vec::new();
        take_all(self.reader.entity(), &mut out);
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
