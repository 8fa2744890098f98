//! The doctor's reading of one DDS Security identity (`[export.security]`, `[dds.security]`):
//! the usual mistakes, each in words, as plain data ([`Finding`]); `handgate doctor` prints
//! them (docs/security-keystore.md, "The doctor's checks"). Everything is read with the
//! `openssl` command line, as CycloneDDS's plugins would read it (OpenSSL 3).

use std::ffi::OsStr;
use std::fmt;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};

use handgate_adapters::dds_security::Security;

use super::openssl::{self, CertInfo};
use super::time::{self, Unix};
use super::xml;

/// How much a finding matters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Severity {
    /// CycloneDDS would refuse the identity, or every peer would refuse it.
    Problem,
    /// Works, but should be fixed.
    Warning,
    /// A check passed.
    Ok,
}

/// One thing the doctor found about an identity. Keys (`certificate`, `private_key`, ...)
/// are the profile's (`SecurityConfig`'s fields, `ENCLAVE_FILES`' roles).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Finding {
    /// A file is missing or cannot be read.
    Unreadable {
        key: &'static str,
        path: PathBuf,
        error: String,
    },
    /// A file is there but is not what its key says (not a certificate, not a key, not a CRL).
    Malformed {
        key: &'static str,
        path: PathBuf,
        error: String,
    },
    /// The certificate's validity has ended.
    CertificateExpired { not_before: Unix, not_after: Unix },
    /// The certificate's validity has not begun.
    CertificateNotYetValid { not_before: Unix, not_after: Unix },
    /// A CA certificate's validity has ended (or not begun).
    CaNotValid {
        key: &'static str,
        not_before: Unix,
        not_after: Unix,
    },
    /// The private key is not the certificate's.
    KeyMismatch,
    /// The certificate was not issued by the identity CA.
    NotIssuedByIdentityCa { issuer: String, ca: String, detail: String },
    /// The revocation list revokes the certificate.
    Revoked { serial: String },
    /// The revocation list is not the identity CA's, or cannot be used.
    CrlUnusable { detail: String },
    /// The revocation list's next update has passed: OpenSSL then fails every verification
    /// that uses it.
    CrlExpired { next_update: Unix },
    /// The governance or the permissions were not signed by the permissions CA.
    NotSignedByPermissionsCa { key: &'static str, detail: String },
    /// The governance has no rule for the domain.
    GovernanceMissesDomain { domain: u32, domains: String },
    /// No grant of the permissions has the certificate's subject.
    SubjectNotGranted { subject: String, grants: Vec<String> },
    /// The grant does not allow the domain.
    DomainNotGranted {
        subject: String,
        domain: u32,
        domains: String,
    },
    /// The grant's validity has ended (or not begun).
    PermissionsNotValid {
        not_before: String,
        not_after: String,
        expired: bool,
    },
    /// The grant's validity is unreadable.
    PermissionsDates { not_before: String, not_after: String },
    /// CycloneDDS would not find its DDS Security plugins.
    PluginsMissing { missing: Vec<String>, looked: Vec<PathBuf> },
    /// The private key can be read by its group or by others.
    KeyReadable { path: PathBuf, mode: u32 },
    /// What passed, in words.
    Passed(String),
}

impl Finding {
    pub fn severity(&self) -> Severity {
        match self {
            Finding::KeyReadable { .. } => Severity::Warning,
            Finding::Passed(_) => Severity::Ok,
            _ => Severity::Problem,
        }
    }

    /// The fix, in words (`None` for a passed check).
    pub fn fix(&self) -> Option<String> {
        let s = match self {
            Finding::Unreadable { key, .. } => format!(
                "give the file (or the enclave holding it) to `{key}` in the profile's security section, readable by handgate's user"
            ),
            Finding::Malformed { key, .. } => format!("`{key}` names the wrong file: give the PEM file it expects"),
            Finding::CertificateExpired { .. } | Finding::CertificateNotYetValid { .. } => {
                "renew the identity (`handgate security renew --keystore DIR NAME`) and copy its enclave over; check this host's clock".into()
            }
            Finding::CaNotValid { .. } => "the lab CA is not valid now: check this host's clock, or make a new keystore".into(),
            Finding::KeyMismatch => "give the key.pem issued with this cert.pem (the same enclave): a renewal replaces both".into(),
            Finding::NotIssuedByIdentityCa { .. } => {
                "use the identity_ca.cert.pem of the keystore that issued this certificate (every participant of the domain must share it)".into()
            }
            Finding::Revoked { .. } => "this identity was revoked: issue or renew it (`handgate security renew`) and use the new enclave".into(),
            Finding::CrlUnusable { .. } => "give the keystore's public/crl.pem, written by `handgate security revoke` with the identity CA".into(),
            Finding::CrlExpired { .. } => "rewrite the list (`handgate security revoke` of any identity rewrites it) and copy public/crl.pem over".into(),
            Finding::NotSignedByPermissionsCa { .. } => {
                "use the permissions_ca.cert.pem, governance.p7s and permissions.p7s of one keystore (the same enclave)".into()
            }
            Finding::GovernanceMissesDomain { .. } => "use a governance that covers the domain (`handgate security init` writes one for 0-230)".into(),
            Finding::SubjectNotGranted { .. } => {
                "give the permissions.p7s issued with this certificate (the same enclave): its grant names the certificate's subject".into()
            }
            Finding::DomainNotGranted { domain, .. } => format!(
                "issue the identity for this robot: `handgate security issue ... --robot {domain}` (or renew an identity issued with it)"
            ),
            Finding::PermissionsNotValid { .. } | Finding::PermissionsDates { .. } => {
                "renew the identity (`handgate security renew`): it re-signs the permissions for the new validity".into()
            }
            Finding::PluginsMissing { .. } => {
                "install CycloneDDS's DDS Security plugins (Debian: libddsc0debian ships libdds_security_{auth,ac,crypto}.so) or add their directory to LD_LIBRARY_PATH".into()
            }
            Finding::KeyReadable { path, .. } => format!("chmod 600 {}", path.display()),
            Finding::Passed(_) => return None,
        };
        Some(s)
    }
}

impl fmt::Display for Finding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let t = |u: Unix| time::rfc3339(u);
        match self {
            Finding::Unreadable { key, path, error } => write!(f, "{key}: {} cannot be read: {error}", path.display()),
            Finding::Malformed { key, path, error } => write!(f, "{key}: {} is not usable: {error}", path.display()),
            Finding::CertificateExpired { not_before, not_after } => write!(
                f,
                "the certificate expired on {} (valid {} to {}): every peer refuses it",
                t(*not_after),
                t(*not_before),
                t(*not_after)
            ),
            Finding::CertificateNotYetValid { not_before, not_after } => write!(
                f,
                "the certificate is not valid yet: valid from {} to {}",
                t(*not_before),
                t(*not_after)
            ),
            Finding::CaNotValid { key, not_before, not_after } => write!(
                f,
                "{key}: the CA certificate is valid from {} to {}, not now",
                t(*not_before),
                t(*not_after)
            ),
            Finding::KeyMismatch => write!(f, "the private key does not match the certificate (another identity's key)"),
            Finding::NotIssuedByIdentityCa { issuer, ca, detail } => write!(
                f,
                "the certificate was not issued by the identity CA: its issuer is {issuer}, the identity CA is {ca} ({detail})"
            ),
            Finding::Revoked { serial } => write!(
                f,
                "the certificate (serial {serial}) is revoked by the revocation list: every peer holding the list refuses it, and CycloneDDS refuses to start with it"
            ),
            Finding::CrlUnusable { detail } => write!(f, "crl: the revocation list cannot be used with the identity CA: {detail}"),
            Finding::CrlExpired { next_update } => write!(
                f,
                "crl: the revocation list's next update was {}: OpenSSL fails every certificate check that uses an outdated list",
                t(*next_update)
            ),
            Finding::NotSignedByPermissionsCa { key, detail } => {
                write!(f, "{key}: not signed by the permissions CA ({detail})")
            }
            Finding::GovernanceMissesDomain { domain, domains } => write!(
                f,
                "governance: no domain rule for domain {domain} (it covers {domains}): CycloneDDS refuses to create the participant"
            ),
            Finding::SubjectNotGranted { subject, grants } => write!(
                f,
                "permissions: no grant for the certificate's subject {subject} (the grants name {}): CycloneDDS refuses the identity",
                if grants.is_empty() { "nobody".to_string() } else { grants.join(", ") }
            ),
            Finding::DomainNotGranted { subject, domain, domains } => write!(
                f,
                "permissions: the grant of {subject} does not allow domain {domain} (it allows {domains})"
            ),
            Finding::PermissionsNotValid { not_before, not_after, expired } => write!(
                f,
                "permissions: the grant {} (valid {not_before} to {not_after}, UTC)",
                if *expired { "has expired" } else { "is not valid yet" }
            ),
            Finding::PermissionsDates { not_before, not_after } => write!(
                f,
                "permissions: the grant's validity {not_before:?} to {not_after:?} is not readable"
            ),
            Finding::PluginsMissing { missing, looked } => {
                let dirs: Vec<String> = looked.iter().map(|d| d.display().to_string()).collect();
                write!(
                    f,
                    "CycloneDDS's DDS Security plugins not found: {} (looked in {})",
                    missing.join(", "),
                    dirs.join(", ")
                )
            }
            Finding::KeyReadable { path, mode } => write!(
                f,
                "private_key: {} is readable by {} (mode {:o})",
                path.display(),
                if mode & 0o004 != 0 { "everyone" } else { "its group" },
                mode & 0o777
            ),
            Finding::Passed(s) => f.write_str(s),
        }
    }
}

/// The DDS Security plugins CycloneDDS loads (`dds.sec.*.library.path`), as files.
pub const PLUGINS: [&str; 3] = [
    "libdds_security_auth.so",
    "libdds_security_ac.so",
    "libdds_security_crypto.so",
];

/// Where CycloneDDS 0.10.2 looks for its plugins: `dlopen`'s search (LD_LIBRARY_PATH, the
/// system's library directories) and Debian's build's own directory beside libddsc
/// (`<libdir>/libddsc0debian/`, compiled into its libddsc).
pub fn plugin_dirs() -> Vec<PathBuf> {
    let mut dirs: Vec<PathBuf> = std::env::var_os("LD_LIBRARY_PATH")
        .map(|v| {
            std::env::split_paths(&v)
                .filter(|p| !p.as_os_str().is_empty())
                .collect()
        })
        .unwrap_or_default();
    // libddsc as this process loaded it.
    if let Ok(maps) = std::fs::read_to_string("/proc/self/maps") {
        if let Some(lib) = maps.lines().filter_map(|l| l.split_whitespace().nth(5)).find(|p| {
            Path::new(p)
                .file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with("libddsc.so"))
        }) {
            if let Some(dir) = Path::new(lib).parent() {
                dirs.push(dir.join("libddsc0debian"));
                dirs.push(dir.to_path_buf());
            }
        }
    }
    let multiarch = format!("{}-linux-gnu", std::env::consts::ARCH);
    for d in [
        format!("/usr/lib/{multiarch}/libddsc0debian"),
        format!("/usr/lib/{multiarch}"),
        format!("/lib/{multiarch}"),
        "/usr/local/lib".into(),
        "/usr/lib".into(),
        "/lib".into(),
    ] {
        dirs.push(PathBuf::from(d));
    }
    let mut seen = std::collections::HashSet::new();
    dirs.retain(|d| seen.insert(d.clone()));
    dirs
}

/// The plugins found in `dirs`: a passed check naming where, or what is missing.
pub fn plugins(dirs: &[PathBuf]) -> Finding {
    let mut missing = Vec::new();
    let mut found = Vec::new();
    for p in PLUGINS {
        match dirs.iter().find(|d| d.join(p).is_file()) {
            Some(d) => found.push(d.join(p)),
            None => missing.push(p.to_string()),
        }
    }
    if missing.is_empty() {
        let dir = found[0].parent().map(|d| d.display().to_string()).unwrap_or_default();
        Finding::Passed(format!("CycloneDDS's DDS Security plugins are in {dir}"))
    } else {
        Finding::PluginsMissing {
            missing,
            looked: dirs.to_vec(),
        }
    }
}

/// Reads `path` for the check of `key`: `None` (and a finding) when it cannot be read.
fn readable(key: &'static str, path: &Path, out: &mut Vec<Finding>) -> bool {
    match std::fs::read(path) {
        Ok(_) => true,
        Err(e) => {
            out.push(Finding::Unreadable {
                key,
                path: path.to_path_buf(),
                error: e.to_string(),
            });
            false
        }
    }
}

fn cert(key: &'static str, path: &Path, out: &mut Vec<Finding>) -> Option<CertInfo> {
    match openssl::cert_info(path) {
        Ok(c) => Some(c),
        Err(e) => {
            out.push(Finding::Malformed {
                key,
                path: path.to_path_buf(),
                error: e.to_string(),
            });
            None
        }
    }
}

fn os<'a>(args: &'a [&'a str]) -> impl Iterator<Item = &'a OsStr> {
    args.iter().map(OsStr::new)
}

/// `openssl verify` of `cert` against `ca` (with `crl` when given), the dates left out (they
/// are checked on their own): `Ok` or OpenSSL's words.
fn verify(cert: &Path, ca: &Path, crl: Option<&Path>) -> Result<(), String> {
    let mut args: Vec<&OsStr> = os(&["verify", "-no_check_time", "-CAfile"]).collect();
    args.push(ca.as_os_str());
    if let Some(c) = crl {
        args.extend(os(&["-crl_check", "-CRLfile"]));
        args.push(c.as_os_str());
    }
    args.push(cert.as_os_str());
    openssl::run("verify the certificate", &args, None, None)
        .map(|_| ())
        .map_err(|e| match e {
            super::SecurityError::Openssl { detail, .. } => detail
                .split("; ")
                .find_map(|l| l.split_once("lookup: ").map(|(_, why)| why.to_string()))
                .unwrap_or(detail),
            other => other.to_string(),
        })
}

/// The public key of a certificate or of a private key (PEM), to compare them.
fn public_key(path: &Path, of_certificate: bool) -> Result<String, String> {
    let args: Vec<&OsStr> = if of_certificate {
        let mut a: Vec<&OsStr> = os(&["x509", "-noout", "-pubkey", "-in"]).collect();
        a.push(path.as_os_str());
        a
    } else {
        let mut a: Vec<&OsStr> = os(&["pkey", "-pubout", "-in"]).collect();
        a.push(path.as_os_str());
        a
    };
    openssl::text("read a public key", &args, None).map_err(|e| e.to_string())
}

/// Checks the identity `sec` for domain `domain` at time `now`: every file readable, the
/// certificate valid now, its key, its issuer, not revoked; the governance and permissions
/// signed by the permissions CA, the governance covering the domain, the permissions granting
/// the certificate's subject the domain now; the plugins where CycloneDDS looks
/// ([`plugin_dirs`]); the private key not readable by others. Problems first in the order
/// CycloneDDS meets them, then the checks passed.
pub fn diagnose(sec: &Security, domain: u32, now: Unix) -> Vec<Finding> {
    diagnose_with(sec, domain, now, &plugin_dirs())
}

/// [`diagnose`] with the plugins looked for in `plugin_dirs`.
pub fn diagnose_with(sec: &Security, domain: u32, now: Unix, plugin_dirs: &[PathBuf]) -> Vec<Finding> {
    let mut out = Vec::new();
    let mut passed = Vec::new();
    let ok: Vec<bool> = sec
        .files()
        .into_iter()
        .map(|(key, path)| readable(key, path, &mut out))
        .collect();
    let [id_ca_ok, cert_ok, key_ok, perm_ca_ok, gov_ok, perm_ok] = [ok[0], ok[1], ok[2], ok[3], ok[4], ok[5]];
    let crl_ok = ok.get(6).copied().unwrap_or(false);

    // The private key's mode.
    if key_ok {
        if let Ok(m) = std::fs::metadata(&sec.private_key) {
            let mode = m.permissions().mode();
            if mode & 0o077 != 0 {
                out.push(Finding::KeyReadable {
                    path: sec.private_key.clone(),
                    mode,
                });
            }
        }
    }

    // The identity: certificate, key, CA, revocation.
    let certificate = if cert_ok {
        cert("certificate", &sec.certificate, &mut out)
    } else {
        None
    };
    if let Some(c) = &certificate {
        if now >= c.not_after {
            out.push(Finding::CertificateExpired {
                not_before: c.not_before,
                not_after: c.not_after,
            });
        } else if now < c.not_before {
            out.push(Finding::CertificateNotYetValid {
                not_before: c.not_before,
                not_after: c.not_after,
            });
        } else {
            passed.push(format!(
                "certificate {} valid until {}",
                c.subject,
                time::rfc3339(c.not_after)
            ));
        }
        if key_ok {
            match (public_key(&sec.certificate, true), public_key(&sec.private_key, false)) {
                (Ok(a), Ok(b)) if a == b => passed.push("the private key matches the certificate".into()),
                (Ok(_), Ok(_)) => out.push(Finding::KeyMismatch),
                (_, Err(e)) => out.push(Finding::Malformed {
                    key: "private_key",
                    path: sec.private_key.clone(),
                    error: e,
                }),
                (Err(_), _) => {}
            }
        }
    }
    let identity_ca = if id_ca_ok {
        cert("identity_ca", &sec.identity_ca, &mut out)
    } else {
        None
    };
    if let Some(ca) = &identity_ca {
        if now >= ca.not_after || now < ca.not_before {
            out.push(Finding::CaNotValid {
                key: "identity_ca",
                not_before: ca.not_before,
                not_after: ca.not_after,
            });
        }
    }
    if let (Some(c), Some(ca)) = (&certificate, &identity_ca) {
        match verify(&sec.certificate, &sec.identity_ca, None) {
            Err(detail) => out.push(Finding::NotIssuedByIdentityCa {
                issuer: c.issuer.clone(),
                ca: ca.subject.clone(),
                detail,
            }),
            Ok(()) => {
                passed.push(format!("the certificate was issued by the identity CA {}", ca.subject));
                if let (true, Some(crl)) = (crl_ok, sec.crl.as_deref()) {
                    check_crl(c, sec, crl, now, &mut out, &mut passed);
                }
            }
        }
    }

    // Access control: the signed documents.
    let permissions_ca = if perm_ca_ok {
        cert("permissions_ca", &sec.permissions_ca, &mut out)
    } else {
        None
    };
    if let Some(ca) = &permissions_ca {
        if now >= ca.not_after || now < ca.not_before {
            out.push(Finding::CaNotValid {
                key: "permissions_ca",
                not_before: ca.not_before,
                not_after: ca.not_after,
            });
        }
    }
    let signed = |key: &'static str, path: &Path, out: &mut Vec<Finding>| -> Option<String> {
        match openssl::smime_verify(path, &sec.permissions_ca) {
            Ok(doc) => Some(doc),
            Err(e) => {
                let detail = match e {
                    super::SecurityError::Openssl { detail, .. } => detail,
                    other => other.to_string(),
                };
                out.push(Finding::NotSignedByPermissionsCa { key, detail });
                None
            }
        }
    };
    if permissions_ca.is_some() && gov_ok {
        if let Some(doc) = signed("governance", &sec.governance, &mut out) {
            let domains = xml::governance_domains(&doc);
            if domains.contains(domain) {
                passed.push(format!(
                    "the governance is signed by the permissions CA and covers domain {domain}"
                ));
            } else {
                out.push(Finding::GovernanceMissesDomain {
                    domain,
                    domains: domains.describe(),
                });
            }
        }
    }
    if permissions_ca.is_some() && perm_ok {
        if let Some(doc) = signed("permissions", &sec.permissions, &mut out) {
            if let Some(c) = &certificate {
                check_grant(&doc, c, domain, now, &mut out, &mut passed);
            }
        }
    }

    match plugins(plugin_dirs) {
        Finding::Passed(s) => passed.push(s),
        f => out.push(f),
    }
    out.extend(passed.into_iter().map(Finding::Passed));
    out
}

fn check_crl(c: &CertInfo, sec: &Security, crl: &Path, now: Unix, out: &mut Vec<Finding>, passed: &mut Vec<String>) {
    let next = openssl::text(
        "read the revocation list",
        &[
            OsStr::new("crl"),
            OsStr::new("-noout"),
            OsStr::new("-nextupdate"),
            OsStr::new("-dateopt"),
            OsStr::new("iso_8601"),
            OsStr::new("-in"),
            crl.as_os_str(),
        ],
        None,
    );
    let next = match next {
        Ok(t) => t
            .lines()
            .find_map(|l| l.strip_prefix("nextUpdate="))
            .and_then(time::parse),
        Err(e) => {
            out.push(Finding::Malformed {
                key: "crl",
                path: crl.to_path_buf(),
                error: e.to_string(),
            });
            return;
        }
    };
    if let Some(n) = next.filter(|&n| now >= n) {
        out.push(Finding::CrlExpired { next_update: n });
    }
    match verify(&sec.certificate, &sec.identity_ca, Some(crl)) {
        Ok(()) => passed.push(format!(
            "the certificate is not on the revocation list {}",
            crl.display()
        )),
        Err(why) if why.contains("revoked") => out.push(Finding::Revoked {
            serial: c.serial.clone(),
        }),
        Err(why) => out.push(Finding::CrlUnusable { detail: why }),
    }
}

fn check_grant(doc: &str, c: &CertInfo, domain: u32, now: Unix, out: &mut Vec<Finding>, passed: &mut Vec<String>) {
    let grants = xml::read_permissions(doc);
    let Some(g) = grants.iter().find(|g| xml::same_subject(&g.subject, &c.subject)) else {
        out.push(Finding::SubjectNotGranted {
            subject: c.subject.clone(),
            grants: grants.iter().map(|g| g.subject.clone()).collect(),
        });
        return;
    };
    let (nb, na) = (
        g.not_before.clone().unwrap_or_default(),
        g.not_after.clone().unwrap_or_default(),
    );
    match (time::parse(&nb), time::parse(&na)) {
        (Some(b), Some(a)) => {
            if now >= a || now < b {
                out.push(Finding::PermissionsNotValid {
                    not_before: nb.clone(),
                    not_after: na.clone(),
                    expired: now >= a,
                });
            }
        }
        _ => out.push(Finding::PermissionsDates {
            not_before: nb.clone(),
            not_after: na.clone(),
        }),
    }
    let allowed: Vec<&xml::Rule> = g.allow.iter().filter(|r| r.domains.contains(domain)).collect();
    if allowed.is_empty() {
        let all: Vec<String> = g.allow.iter().map(|r| r.domains.describe()).collect();
        out.push(Finding::DomainNotGranted {
            subject: c.subject.clone(),
            domain,
            domains: if all.is_empty() { "none".into() } else { all.join("; ") },
        });
    } else {
        passed.push(format!(
            "the permissions are signed by the permissions CA and grant {} domain {domain} until {na}",
            c.subject
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::security::keystore::{IssueRequest, Keystore, Validity};
    use crate::security::xml::Role;
    use std::sync::OnceLock;

    /// Two keystores made once for every test: `lab` (gateway `robot_a` on 11, `old`
    /// expired, `future` not valid yet, `eve` revoked) and `other` (`mallory`); and `short`,
    /// whose CA (and so its revocation list) lasts 2 days.
    struct Fixture {
        lab: Keystore,
        other: Keystore,
        short: Keystore,
        now: Unix,
    }

    fn fixture() -> &'static Fixture {
        static F: OnceLock<Fixture> = OnceLock::new();
        F.get_or_init(|| {
            let dir = std::env::temp_dir().join(format!("handgate-diagnose-{}", std::process::id()));
            let _ = std::fs::remove_dir_all(&dir);
            let now = time::now();
            let ks = |name: &str, days| Keystore::init(&dir.join(name), "test CA", days, now).expect("init");
            let (lab, other, short) = (ks("lab", 30), ks("other", 30), ks("short", 2));
            let issue = |k: &Keystore, name: &str, validity| {
                k.issue(
                    &IssueRequest {
                        name: name.into(),
                        role: Role::Gateway,
                        robots: vec![11],
                        validity,
                        sans: vec![],
                    },
                    now,
                )
                .expect("issue");
            };
            issue(&lab, "robot_a", Validity::Days(10));
            issue(&lab, "robot_b", Validity::Days(10));
            let year = 365 * 86_400;
            issue(
                &lab,
                "old",
                Validity::Span {
                    not_before: now - 2 * year,
                    not_after: now - year,
                },
            );
            issue(
                &lab,
                "future",
                Validity::Span {
                    not_before: now + year,
                    not_after: now + 2 * year,
                },
            );
            issue(&lab, "eve", Validity::Days(10));
            lab.revoke("eve", now).expect("revoke");
            issue(&other, "mallory", Validity::Days(10));
            issue(&short, "robot_s", Validity::Days(10));
            Fixture { lab, other, short, now }
        })
    }

    fn enclave(k: &Keystore, name: &str) -> Security {
        Security::from_enclave(&k.enclaves().join(name), Some(k.crl()))
    }

    fn here() -> Vec<PathBuf> {
        // The plugins' check is its own test: give it a directory that has them (or none).
        plugin_dirs()
    }

    fn problems(f: &[Finding]) -> Vec<&Finding> {
        f.iter().filter(|f| f.severity() == Severity::Problem).collect()
    }

    #[test]
    fn a_good_identity_has_no_problem() {
        let f = fixture();
        let got = diagnose_with(&enclave(&f.lab, "robot_a"), 11, f.now, &here());
        let p: Vec<_> = problems(&got)
            .into_iter()
            .filter(|f| !matches!(f, Finding::PluginsMissing { .. }))
            .collect();
        assert!(p.is_empty(), "{got:#?}");
        assert!(
            got.iter()
                .any(|f| matches!(f, Finding::Passed(s) if s.contains("grant CN=/robot_a domain 11"))),
            "{got:#?}"
        );
        assert!(
            !got.iter().any(|f| matches!(f, Finding::KeyReadable { .. })),
            "{got:#?}"
        );
    }

    #[test]
    fn missing_file_names_the_key() {
        let f = fixture();
        let mut s = enclave(&f.lab, "robot_a");
        s.certificate = s.certificate.with_file_name("nope.pem");
        let got = diagnose_with(&s, 11, f.now, &here());
        assert!(
            matches!(&got[0], Finding::Unreadable { key: "certificate", path, .. } if path.ends_with("nope.pem")),
            "{got:#?}"
        );
        assert!(got[0].to_string().starts_with("certificate: "), "{}", got[0]);
    }

    #[test]
    fn expired_and_not_yet_valid() {
        let f = fixture();
        let old = diagnose_with(&enclave(&f.lab, "old"), 11, f.now, &here());
        assert!(
            old.iter().any(|x| matches!(x, Finding::CertificateExpired { .. })),
            "{old:#?}"
        );
        assert!(
            old.iter()
                .any(|x| matches!(x, Finding::PermissionsNotValid { expired: true, .. })),
            "{old:#?}"
        );
        let text: Vec<String> = old.iter().map(|x| x.to_string()).collect();
        assert!(
            text.iter().any(|t| t.contains("the certificate expired on ")),
            "{text:?}"
        );
        let future = diagnose_with(&enclave(&f.lab, "future"), 11, f.now, &here());
        assert!(
            future
                .iter()
                .any(|x| matches!(x, Finding::CertificateNotYetValid { .. })),
            "{future:#?}"
        );
        assert!(
            future
                .iter()
                .any(|x| matches!(x, Finding::PermissionsNotValid { expired: false, .. })),
            "{future:#?}"
        );
    }

    #[test]
    fn another_identitys_key_or_permissions() {
        let f = fixture();
        let mut s = enclave(&f.lab, "robot_a");
        s.private_key = f.lab.enclaves().join("robot_b/key.pem");
        let got = diagnose_with(&s, 11, f.now, &here());
        assert!(got.contains(&Finding::KeyMismatch), "{got:#?}");
        let mut s = enclave(&f.lab, "robot_a");
        s.permissions = f.lab.enclaves().join("robot_b/permissions.p7s");
        let got = diagnose_with(&s, 11, f.now, &here());
        assert!(
            got.iter()
                .any(|x| matches!(x, Finding::SubjectNotGranted { subject, grants }
                if subject == "CN=/robot_a" && grants == &vec!["CN=/robot_b".to_string()])),
            "{got:#?}"
        );
    }

    #[test]
    fn another_ca() {
        let f = fixture();
        let mut s = enclave(&f.lab, "robot_a");
        s.identity_ca = f.other.ca_cert();
        s.crl = None;
        let got = diagnose_with(&s, 11, f.now, &here());
        assert!(
            got.iter().any(|x| matches!(x, Finding::NotIssuedByIdentityCa { detail, .. } if detail.contains("unable to get local issuer"))),
            "{got:#?}"
        );
        let mut s = enclave(&f.lab, "robot_a");
        s.governance = f.other.governance();
        let got = diagnose_with(&s, 11, f.now, &here());
        assert!(
            got.iter()
                .any(|x| matches!(x, Finding::NotSignedByPermissionsCa { key: "governance", .. })),
            "{got:#?}"
        );
        assert!(!got
            .iter()
            .any(|x| matches!(x, Finding::NotSignedByPermissionsCa { key: "permissions", .. })));
    }

    #[test]
    fn revoked_by_the_list() {
        let f = fixture();
        let got = diagnose_with(&enclave(&f.lab, "eve"), 11, f.now, &here());
        assert!(got.iter().any(|x| matches!(x, Finding::Revoked { .. })), "{got:#?}");
        // Without the list, nothing says so.
        let mut s = enclave(&f.lab, "eve");
        s.crl = None;
        let got = diagnose_with(&s, 11, f.now, &here());
        assert!(!got.iter().any(|x| matches!(x, Finding::Revoked { .. })), "{got:#?}");
        // Another CA's list.
        let mut s = enclave(&f.lab, "robot_a");
        s.crl = Some(f.other.crl());
        let got = diagnose_with(&s, 11, f.now, &here());
        assert!(got.iter().any(|x| matches!(x, Finding::CrlUnusable { .. })), "{got:#?}");
    }

    #[test]
    fn outdated_list_and_ca() {
        let f = fixture();
        let later = f.now + 3 * 86_400;
        let got = diagnose_with(&enclave(&f.short, "robot_s"), 11, later, &here());
        assert!(got.iter().any(|x| matches!(x, Finding::CrlExpired { .. })), "{got:#?}");
        assert!(
            got.iter()
                .any(|x| matches!(x, Finding::CaNotValid { key: "identity_ca", .. })),
            "{got:#?}"
        );
    }

    #[test]
    fn domain_not_granted() {
        let f = fixture();
        let got = diagnose_with(&enclave(&f.lab, "robot_a"), 12, f.now, &here());
        assert!(
            got.iter()
                .any(|x| matches!(x, Finding::DomainNotGranted { domain: 12, domains, .. } if domains == "11")),
            "{got:#?}"
        );
        assert_eq!(problems(&got).len(), 1, "{got:#?}");
    }

    #[test]
    fn plugins_where_cyclonedds_looks() {
        let empty = std::env::temp_dir().join(format!("handgate-noplugins-{}", std::process::id()));
        std::fs::create_dir_all(&empty).unwrap();
        let f = plugins(std::slice::from_ref(&empty));
        assert!(
            matches!(&f, Finding::PluginsMissing { missing, looked } if missing.len() == 3 && looked == &vec![empty.clone()]),
            "{f:?}"
        );
        for p in PLUGINS {
            std::fs::write(empty.join(p), b"").unwrap();
        }
        assert!(matches!(plugins(std::slice::from_ref(&empty)), Finding::Passed(_)));
        let _ = std::fs::remove_dir_all(&empty);
        // libddsc is loaded in this process: its directory is among those looked in.
        assert!(
            plugin_dirs().iter().any(|d| d.ends_with("libddsc0debian")),
            "{:?}",
            plugin_dirs()
        );
    }

    #[test]
    fn key_readable_by_others_is_a_warning() {
        let f = fixture();
        let s = enclave(&f.lab, "robot_b");
        let loose = s.private_key.with_file_name("loose.key.pem");
        std::fs::copy(&s.private_key, &loose).unwrap();
        std::fs::set_permissions(&loose, std::fs::Permissions::from_mode(0o644)).unwrap();
        let mut t = s.clone();
        t.private_key = loose.clone();
        let got = diagnose_with(&t, 11, f.now, &here());
        let w: Vec<_> = got.iter().filter(|x| x.severity() == Severity::Warning).collect();
        assert!(
            matches!(w.as_slice(), [Finding::KeyReadable { mode, .. }] if mode & 0o777 == 0o644),
            "{got:#?}"
        );
        assert!(w[0].to_string().contains("readable by everyone"), "{}", w[0]);
    }
}
