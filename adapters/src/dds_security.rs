//! DDS Security for one participant (docs/security.md): the OMG DDS Security plugins Debian's
//! CycloneDDS 0.10.2 ships (`libdds_security_{auth,ac,crypto}.so`), configured through the
//! participant's QoS properties rather than the domain's XML, so that one process may hold a
//! plain participant on the robot's domain and a secured one on the lab's, and so that a
//! revocation list can be given (the XML of 0.10.2 has no element for it; the authentication
//! plugin reads the property `org.eclipse.cyclonedds.sec.auth.crl`).
//!
//! And the refusals: CycloneDDS reports a remote participant it refuses (a failed handshake:
//! another CA, a revoked or expired certificate; a participant its permissions do not let join)
//! through its log, at warning level. [`install_log_sink`] routes CycloneDDS's log into
//! `tracing` and counts those refusals per domain ([`refusals`]); [`classify`] is the pure
//! reading of one log line.

use std::collections::HashMap;
use std::ffi::{c_char, c_void, CString};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

/// The files of one identity: everything the three plugins read. Paths are absolute once
/// resolved (the profile's check resolves them).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Security {
    /// The CA that signed every identity on the domain (`identity_ca.cert.pem`).
    pub identity_ca: PathBuf,
    /// This participant's certificate (`cert.pem`).
    pub certificate: PathBuf,
    /// Its private key (`key.pem`, unencrypted PEM as SROS2 writes it).
    pub private_key: PathBuf,
    /// The CA that signed the governance and permissions documents (`permissions_ca.cert.pem`).
    pub permissions_ca: PathBuf,
    /// The signed governance document (`governance.p7s`).
    pub governance: PathBuf,
    /// The signed permissions document of this identity (`permissions.p7s`).
    pub permissions: PathBuf,
    /// A certificate revocation list of the identity CA (PEM), if the lab revokes.
    pub crl: Option<PathBuf>,
}

/// The files of an enclave directory in the SROS2 keystore layout
/// (`<keystore>/enclaves/<name>/`), as `ros2 security create_enclave` and
/// `handgate security issue` write them.
pub const ENCLAVE_FILES: [(&str, &str); 6] = [
    ("identity_ca", "identity_ca.cert.pem"),
    ("certificate", "cert.pem"),
    ("private_key", "key.pem"),
    ("permissions_ca", "permissions_ca.cert.pem"),
    ("governance", "governance.p7s"),
    ("permissions", "permissions.p7s"),
];

impl Security {
    /// The identity in an SROS2 enclave directory, with an optional CRL.
    pub fn from_enclave(dir: &Path, crl: Option<PathBuf>) -> Self {
        let f = |name: &str| dir.join(name);
        Security {
            identity_ca: f(ENCLAVE_FILES[0].1),
            certificate: f(ENCLAVE_FILES[1].1),
            private_key: f(ENCLAVE_FILES[2].1),
            permissions_ca: f(ENCLAVE_FILES[3].1),
            governance: f(ENCLAVE_FILES[4].1),
            permissions: f(ENCLAVE_FILES[5].1),
            crl,
        }
    }

    /// Every file with its role, the CRL last when there is one.
    pub fn files(&self) -> Vec<(&'static str, &Path)> {
        let mut v = vec![
            ("identity_ca", self.identity_ca.as_path()),
            ("certificate", self.certificate.as_path()),
            ("private_key", self.private_key.as_path()),
            ("permissions_ca", self.permissions_ca.as_path()),
            ("governance", self.governance.as_path()),
            ("permissions", self.permissions.as_path()),
        ];
        if let Some(c) = &self.crl {
            v.push(("crl", c.as_path()));
        }
        v
    }

    /// The participant QoS properties that load and configure the three plugins (names from
    /// the DDS Security specification, §9.3.1, §9.4.1, and CycloneDDS's `dds_security_*`
    /// libraries with their init/finalize functions).
    pub fn properties(&self) -> Vec<(&'static str, String)> {
        let uri = |p: &Path| format!("file:{}", p.display());
        let mut v = vec![
            ("dds.sec.auth.library.path", "dds_security_auth".to_string()),
            ("dds.sec.auth.library.init", "init_authentication".to_string()),
            ("dds.sec.auth.library.finalize", "finalize_authentication".to_string()),
            ("dds.sec.crypto.library.path", "dds_security_crypto".to_string()),
            ("dds.sec.crypto.library.init", "init_crypto".to_string()),
            ("dds.sec.crypto.library.finalize", "finalize_crypto".to_string()),
            ("dds.sec.access.library.path", "dds_security_ac".to_string()),
            ("dds.sec.access.library.init", "init_access_control".to_string()),
            ("dds.sec.access.library.finalize", "finalize_access_control".to_string()),
            ("dds.sec.auth.identity_ca", uri(&self.identity_ca)),
            ("dds.sec.auth.identity_certificate", uri(&self.certificate)),
            ("dds.sec.auth.private_key", uri(&self.private_key)),
            ("dds.sec.access.permissions_ca", uri(&self.permissions_ca)),
            ("dds.sec.access.governance", uri(&self.governance)),
            ("dds.sec.access.permissions", uri(&self.permissions)),
        ];
        if let Some(c) = &self.crl {
            v.push(("org.eclipse.cyclonedds.sec.auth.crl", uri(c)));
        }
        v
    }

    /// A participant QoS carrying [`Security::properties`].
    pub(crate) fn participant_qos(&self) -> Result<cyclonedds_rs::DdsQos, crate::dds::DdsError> {
        extern "C" {
            // CycloneDDS 0.10.2 dds_public_qos.h (not in cyclonedds-sys 0.2.1's bindings).
            fn dds_qset_prop(qos: *mut cyclonedds_sys::dds_qos_t, name: *const c_char, value: *const c_char);
        }
        let q = cyclonedds_rs::DdsQos::create().map_err(|source| crate::dds::DdsError::Dds {
            what: "qos create",
            source,
        })?;
        let raw = <*const cyclonedds_sys::dds_qos_t>::from(q) as *mut cyclonedds_sys::dds_qos_t;
        for (name, value) in self.properties() {
            let (Ok(n), Ok(v)) = (CString::new(name), CString::new(value)) else {
                // SAFETY: `raw` is the QoS object taken out above, owned by nobody else.
                drop(unsafe { crate::dds::qos_from_raw(raw) });
                return Err(crate::dds::DdsError::BadSecurityPath(name));
            };
            // SAFETY: `raw` is live; CycloneDDS copies both strings.
            unsafe { dds_qset_prop(raw, n.as_ptr(), v.as_ptr()) };
        }
        // SAFETY: `raw` is the live QoS object taken out of `q` above.
        Ok(unsafe { crate::dds::qos_from_raw(raw) })
    }
}

/// The tracing element of a secured domain's CycloneDDS configuration: its discovery trace
/// on (to [`install_log_sink`]'s function, the file is never written), so a participant
/// without security is seen being refused.
pub(crate) const DISCOVERY_TRACE: &str =
    "<Tracing><Category>discovery</Category><OutputFile>/dev/null</OutputFile></Tracing>";

/// Why CycloneDDS refused a remote participant, read from its log line ([`classify`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Refusal {
    /// Its certificate was not issued by this domain's identity CA.
    UnknownCa,
    /// Its certificate is on the revocation list.
    Revoked,
    /// Its certificate has expired.
    Expired,
    /// Its certificate is not valid yet.
    NotYetValid,
    /// The handshake failed for another reason (a bad signature, a malformed certificate).
    Handshake,
    /// It authenticated, but its permissions do not let it join this domain.
    NotAllowed,
    /// It joined without DDS Security (no identity at all): none of its readers or writers is
    /// matched.
    Unauthenticated,
}

impl Refusal {
    /// Every reason, in the order `/metrics` lists them.
    pub const ALL: [Refusal; 7] = [
        Refusal::Unauthenticated,
        Refusal::UnknownCa,
        Refusal::Revoked,
        Refusal::Expired,
        Refusal::NotYetValid,
        Refusal::Handshake,
        Refusal::NotAllowed,
    ];

    /// Its label in `/metrics` and `handgate status`.
    pub fn label(self) -> &'static str {
        match self {
            Refusal::UnknownCa => "unknown_ca",
            Refusal::Revoked => "revoked",
            Refusal::Expired => "expired",
            Refusal::NotYetValid => "not_yet_valid",
            Refusal::Handshake => "handshake",
            Refusal::NotAllowed => "not_allowed",
            Refusal::Unauthenticated => "unauthenticated",
        }
    }
}

/// What one CycloneDDS log line says about a refused remote participant: the reason and who
/// (the certificate's subject when the line names it, else the participant's GUID).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Refused {
    pub reason: Refusal,
    pub who: String,
}

/// Reads one CycloneDDS log message (without its time/thread header). `None` for every line
/// that is not a refusal of a remote participant.
///
/// The lines are CycloneDDS 0.10.2's (measured with `ddsperf` peers, docs/security.md):
/// `Begin handshake reply failed: Certificate not valid: error: unable to get local issuer
/// certificate; subject: /CN=mallory(code: 200)` (also `Begin handshake request failed`,
/// `Process handshake ... failed`), with OpenSSL's verify error (`certificate revoked`,
/// `certificate has expired`, `certificate is not yet valid`), and `Remote secure participant
/// <guid> not allowed` when its permissions do not grant the domain.
pub fn classify(message: &str) -> Option<Refused> {
    let m = message.trim();
    // A participant without security: CycloneDDS's discovery trace refuses each of its
    // endpoints ("Non secure remote writer 1104cf6:f49acf2e:93b57be8:3c2 is not allowed.");
    // the participant is the GUID's prefix.
    for kind in ["Non secure remote writer ", "Non secure remote reader "] {
        if let Some(rest) = m.strip_prefix(kind) {
            let guid = rest.split_whitespace().next()?;
            let prefix: Vec<&str> = guid.split(':').take(3).collect();
            if prefix.len() != 3 || !rest.contains("not allowed") {
                return None;
            }
            return Some(Refused {
                reason: Refusal::Unauthenticated,
                who: prefix.join(":"),
            });
        }
    }
    if let Some(rest) = m.strip_prefix("Remote secure participant ") {
        let guid = rest.strip_suffix(" not allowed")?;
        return Some(Refused {
            reason: Refusal::NotAllowed,
            who: guid.trim().to_string(),
        });
    }
    let lower = m.to_ascii_lowercase();
    if !(lower.contains("handshake") && lower.contains("failed")) {
        return None;
    }
    let reason = if lower.contains("unable to get local issuer") || lower.contains("self-signed certificate") {
        Refusal::UnknownCa
    } else if lower.contains("certificate revoked") {
        Refusal::Revoked
    } else if lower.contains("certificate has expired") {
        Refusal::Expired
    } else if lower.contains("not yet valid") {
        Refusal::NotYetValid
    } else {
        Refusal::Handshake
    };
    let who = lower
        .find("subject: ")
        .map(|i| {
            let s = &m[i + "subject: ".len()..];
            s.split("(code").next().unwrap_or(s).trim().to_string()
        })
        .unwrap_or_default();
    Some(Refused { reason, who })
}

/// Refusals on one domain: per reason, the number of distinct remote identities refused (a
/// peer retries its handshake every second or so: each identity counts once per reason), and
/// the log lines seen.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct DomainRefusals {
    /// Distinct refused identities per reason.
    pub participants: HashMap<Refusal, u64>,
    /// Every refusal line, retries included.
    pub attempts: u64,
}

impl DomainRefusals {
    /// Distinct refused identities, every reason.
    pub fn total(&self) -> u64 {
        self.participants.values().sum()
    }
}

/// One domain's counts and the identities already counted (kept here, not in the counts that
/// `/metrics` and the status copy out).
#[derive(Debug, Default)]
struct Tally {
    counts: DomainRefusals,
    seen: std::collections::HashSet<(Refusal, String)>,
}

impl Tally {
    /// Records one refusal; true when it is a new identity for its reason.
    fn record(&mut self, r: &Refused) -> bool {
        self.counts.attempts += 1;
        if self.seen.len() < 4096 && self.seen.insert((r.reason, r.who.clone())) {
            *self.counts.participants.entry(r.reason).or_insert(0) += 1;
            return true;
        }
        false
    }
}

fn table() -> &'static Mutex<HashMap<u32, Tally>> {
    static T: OnceLock<Mutex<HashMap<u32, Tally>>> = OnceLock::new();
    T.get_or_init(|| Mutex::new(HashMap::new()))
}

/// Records that this process joined `domain` with DDS Security (its refusals are then
/// reported even while there are none).
pub(crate) fn mark_secured(domain: u32) {
    table()
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .entry(domain)
        .or_default();
}

/// Every domain this process joined with DDS Security or saw a refusal on, with its
/// refusals, in domain order.
pub fn secured() -> Vec<(u32, DomainRefusals)> {
    let t = table().lock().unwrap_or_else(|p| p.into_inner());
    let mut v: Vec<_> = t.iter().map(|(d, r)| (*d, r.counts.clone())).collect();
    v.sort_by_key(|(d, _)| *d);
    v
}

/// The refusals counted on `domain` since [`install_log_sink`].
pub fn refusals(domain: u32) -> DomainRefusals {
    table()
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .get(&domain)
        .map(|t| t.counts.clone())
        .unwrap_or_default()
}

/// CycloneDDS's error and warning lines so far: how many, and the last one.
fn last_errors() -> &'static Mutex<(u64, String)> {
    static L: OnceLock<Mutex<(u64, String)>> = OnceLock::new();
    L.get_or_init(|| Mutex::new((0, String::new())))
}

/// A mark for [`last_error_since`]: the number of CycloneDDS error and warning lines so far.
pub fn errors_seen() -> u64 {
    last_errors().lock().unwrap_or_else(|p| p.into_inner()).0
}

/// The last CycloneDDS error or warning line logged after `mark` (its words for refusing a
/// local identity: "validate_local_identity: ... Certificate expired", ...), if any.
pub fn last_error_since(mark: u64) -> Option<String> {
    let l = last_errors().lock().unwrap_or_else(|p| p.into_inner());
    (l.0 > mark).then(|| l.1.clone())
}

/// `dds_log_data_t` of CycloneDDS 0.10.2 (ddsrt/log.h).
#[repr(C)]
struct LogData {
    priority: u32,
    domid: u32,
    file: *const c_char,
    line: u32,
    function: *const c_char,
    message: *const c_char,
    size: usize,
    hdrsize: usize,
}

/// DDS_LC_FATAL, DDS_LC_ERROR, DDS_LC_WARNING (ddsrt/log.h).
const LC_FATAL: u32 = 1;
const LC_ERROR: u32 = 2;
const LC_WARNING: u32 = 4;
const LC_INFO: u32 = 8;

/// The domain id in a log line's header (`<sec>.<usec> [<domain>] <thread>: `).
fn header_domain(header: &str) -> Option<u32> {
    let open = header.find('[')?;
    let close = header[open..].find(']')? + open;
    header[open + 1..close].trim().parse().ok()
}

extern "C" fn log_sink(_arg: *mut c_void, data: *const LogData) {
    // SAFETY: CycloneDDS passes a valid record for the duration of the call; `message` points
    // at `size` bytes (no NUL needed) and the header sits `hdrsize` bytes before it.
    let (priority, msg, header) = unsafe {
        let d = &*data;
        if d.message.is_null() {
            return;
        }
        let body = std::slice::from_raw_parts(d.message as *const u8, d.size);
        let head = std::slice::from_raw_parts((d.message as *const u8).sub(d.hdrsize), d.hdrsize);
        (d.priority, String::from_utf8_lossy(body), String::from_utf8_lossy(head))
    };
    let domain = header_domain(&header);
    if let (Some(r), Some(domain)) = (classify(&msg), domain) {
        let new = table()
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .entry(domain)
            .or_default()
            .record(&r);
        if new {
            tracing::warn!(
                domain,
                reason = r.reason.label(),
                who = %r.who,
                "DDS Security refused a participant: {}",
                msg.trim()
            );
        }
        return;
    }
    let msg = msg.trim();
    if priority & (LC_FATAL | LC_ERROR | LC_WARNING) != 0 {
        let mut l = last_errors().lock().unwrap_or_else(|p| p.into_inner());
        l.0 += 1;
        l.1 = msg.to_string();
    }
    if priority & (LC_FATAL | LC_ERROR) != 0 {
        tracing::error!(target: "cyclonedds", "{msg}");
    } else if priority & LC_WARNING != 0 {
        tracing::warn!(target: "cyclonedds", "{msg}");
    } else if priority & LC_INFO != 0 {
        tracing::info!(target: "cyclonedds", "{msg}");
    }
    // Anything else is a trace line (a secured domain's discovery): not for the log.
}

/// Routes CycloneDDS's log (errors, warnings) into `tracing` and counts refused participants
/// per domain. Process-wide; idempotent. CycloneDDS's traces go to the same function
/// (a domain secured through [`domain_config`] traces its discovery there, which is where a
/// participant without security is refused); trace lines that are not refusals are dropped,
/// so a process that secures a domain writes no CycloneDDS trace file.
pub fn install_log_sink() {
    static ONCE: OnceLock<()> = OnceLock::new();
    ONCE.get_or_init(|| {
        extern "C" {
            fn dds_set_log_sink(callback: extern "C" fn(*mut c_void, *const LogData), userdata: *mut c_void);
        }
        extern "C" {
            fn dds_set_trace_sink(callback: extern "C" fn(*mut c_void, *const LogData), userdata: *mut c_void);
        }
        // SAFETY: `log_sink` is a plain function valid for the life of the process and does
        // not call back into CycloneDDS. The same function and argument for both sinks:
        // CycloneDDS then passes a line that is both logged and traced only once.
        unsafe {
            dds_set_log_sink(log_sink, std::ptr::null_mut());
            dds_set_trace_sink(log_sink, std::ptr::null_mut());
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classifies_cyclonedds_lines() {
        let c = |s| classify(s).map(|r| (r.reason, r.who));
        assert_eq!(
            c("Begin handshake reply failed: Certificate not valid: error: unable to get local issuer certificate; subject: /CN=mallory(code: 200)"),
            Some((Refusal::UnknownCa, "/CN=mallory".into()))
        );
        assert_eq!(
            c("Begin handshake request failed: Certificate not valid: error: certificate revoked; subject: /CN=/eve(code: 200)"),
            Some((Refusal::Revoked, "/CN=/eve".into()))
        );
        assert_eq!(
            c("Begin handshake reply failed: Certificate not valid: error: certificate has expired; subject: /CN=/old(code: 200)"),
            Some((Refusal::Expired, "/CN=/old".into()))
        );
        assert_eq!(
            c("Remote secure participant b0436de6:d29086f3:60bb4eca:1c1 not allowed"),
            Some((Refusal::NotAllowed, "b0436de6:d29086f3:60bb4eca:1c1".into()))
        );
        assert_eq!(
            c("Non secure remote writer 1104cf6:f49acf2e:93b57be8:3c2 is not allowed.connect_proxy_writer_with_reader (pwr 1104cf6:f49acf2e:93b57be8:3c2) with (rd c55cd5c5:9c978408:9db1f39c:3c7) not allowed by security"),
            Some((Refusal::Unauthenticated, "1104cf6:f49acf2e:93b57be8".into()))
        );
        assert_eq!(
            c("selected interface \"lo\" is not multicast-capable: disabling multicast"),
            None
        );
        assert_eq!(c("handshake_debug ok"), None);
    }

    #[test]
    fn retries_count_once() {
        let mut d = Tally::default();
        let r = Refused {
            reason: Refusal::UnknownCa,
            who: "/CN=x".into(),
        };
        assert!(d.record(&r));
        assert!(!d.record(&r));
        assert_eq!((d.counts.total(), d.counts.attempts), (1, 2));
    }

    #[test]
    fn header_domain_reads_the_id() {
        assert_eq!(header_domain("1795954694.930576 [50]        fsm:"), Some(50));
        assert_eq!(header_domain("1795954694.930576 []  fsm:"), None);
    }

    #[test]
    fn enclave_layout() {
        let s = Security::from_enclave(Path::new("/k/enclaves/robot_a"), None);
        assert_eq!(s.certificate, Path::new("/k/enclaves/robot_a/cert.pem"));
        assert_eq!(s.properties().len(), 15);
    }
}
