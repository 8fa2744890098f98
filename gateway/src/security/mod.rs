//! DDS Security for a lab (docs/security-keystore.md): `handgate security`'s keystore (a lab
//! CA, one identity per gateway and operator with permissions per robot, revocation and
//! renewal) in the SROS2 keystore layout, made with the `openssl` command line; and the
//! doctor's reading of one identity's files ([`diagnose`]).

pub mod diagnose;
pub mod keystore;
pub mod openssl;
pub mod time;
pub mod xml;

use std::path::PathBuf;

/// Why a keystore operation failed.
#[derive(Debug, thiserror::Error)]
pub enum SecurityError {
    #[error("cannot run openssl (install it: apt-get install openssl): {0}")]
    OpensslMissing(std::io::Error),
    #[error("openssl could not {what}: {detail}")]
    Openssl { what: String, detail: String },
    #[error("{path}: {error}")]
    Io { path: PathBuf, error: std::io::Error },
    #[error("{0} already holds a keystore (its CA would be replaced): refusing to overwrite it")]
    KeystoreExists(PathBuf),
    #[error("{0} is held by another `handgate security` command (still there after 60 s: remove it if no such command runs)")]
    Locked(PathBuf),
    #[error("{0} is not empty: `handgate security init` makes a keystore in a new directory, or one without files in public/, private/ and enclaves/")]
    NotEmpty(PathBuf),
    #[error("{0} is not a handgate keystore (no private/ca.key.pem, public/ca.cert.pem or private/ca.cnf: run `handgate security init` first)")]
    NoKeystore(PathBuf),
    #[error("enclave name {name:?} {why}")]
    BadName { name: String, why: &'static str },
    #[error("enclave {0} exists already (renew it with `handgate security renew`)")]
    EnclaveExists(String),
    #[error("no enclave {0} in the keystore (enclaves/{0}/cert.pem)")]
    NoEnclave(String),
    #[error("role {0} needs at least one --robot DOMAIN (the robots' DDS domains it may join)")]
    NoRobot(&'static str),
    #[error("domain {0} is out of range: CycloneDDS accepts 0 to {max} in DDS Security documents", max = xml::MAX_DOMAIN)]
    BadDomain(u32),
    #[error("{what} {value:?} is not an RFC 3339 time (2026-01-31T12:00:00Z)")]
    BadTime { what: &'static str, value: String },
    #[error("the validity is empty: not after {not_after} is not later than not before {not_before}")]
    EmptyValidity { not_before: String, not_after: String },
    #[error("--days must be at least 1")]
    BadDays,
    #[error("--san {0:?}: give DNS:NAME or IP:ADDRESS")]
    BadSan(String),
    #[error("CA name {0:?}: give letters, digits, spaces and - _ . only")]
    BadCaName(String),
    #[error("the permissions of {0} are not handgate's (an SROS2 policy's, or edited): renew them with the tool that wrote them")]
    ForeignPermissions(String),
}

impl SecurityError {
    fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> SecurityError {
        let path = path.into();
        move |error| SecurityError::Io { path, error }
    }
}
