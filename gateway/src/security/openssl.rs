//! The `openssl` command line (OpenSSL 3.0, what SROS2 and CycloneDDS rely on too): every key,
//! certificate, signature and revocation list of the keystore is made by it. Nothing secret
//! is logged: a failure carries the command's name and OpenSSL's own error lines.

use std::ffi::OsStr;
use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};

use super::SecurityError;

/// Runs `openssl ARGS` in `cwd` (when given), `stdin` fed to it; its standard output, or an
/// error naming `what` with OpenSSL's error output.
pub fn run<S: AsRef<OsStr>>(
    what: &str,
    args: &[S],
    cwd: Option<&Path>,
    stdin: Option<&[u8]>,
) -> Result<Vec<u8>, SecurityError> {
    let mut cmd = Command::new("openssl");
    cmd.args(args)
        .stdin(if stdin.is_some() { Stdio::piped() } else { Stdio::null() })
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    if let Some(dir) = cwd {
        cmd.current_dir(dir);
    }
    let mut child = cmd.spawn().map_err(SecurityError::OpensslMissing)?;
    if let (Some(data), Some(mut pipe)) = (stdin, child.stdin.take()) {
        // A command that exits early closes its end: its error output says why.
        let _ = pipe.write_all(data);
    }
    let out = child.wait_with_output().map_err(SecurityError::OpensslMissing)?;
    if out.status.success() {
        Ok(out.stdout)
    } else {
        Err(SecurityError::Openssl {
            what: what.to_string(),
            detail: summary(&out.stderr, &out.stdout),
        })
    }
}

/// OpenSSL's error output in one line: its lines joined, the long `error:0A000086:...:`
/// prefixes kept (they name the reason).
fn summary(stderr: &[u8], stdout: &[u8]) -> String {
    let text = String::from_utf8_lossy(if stderr.iter().any(|c| !c.is_ascii_whitespace()) {
        stderr
    } else {
        stdout
    });
    let lines: Vec<&str> = text.lines().map(str::trim).filter(|l| !l.is_empty()).take(6).collect();
    if lines.is_empty() {
        "no error output".into()
    } else {
        lines.join("; ")
    }
}

/// `openssl` as text (its output is ASCII for everything the keystore asks).
pub fn text<S: AsRef<OsStr>>(what: &str, args: &[S], cwd: Option<&Path>) -> Result<String, SecurityError> {
    run(what, args, cwd, None).map(|o| String::from_utf8_lossy(&o).into_owned())
}

/// A new ECDSA P-256 private key, PKCS#8 PEM (as SROS2 writes `key.pem`), never on disk
/// until the caller writes it (0600).
pub fn new_key() -> Result<Vec<u8>, SecurityError> {
    run(
        "generate an ECDSA P-256 key",
        &["genpkey", "-algorithm", "EC", "-pkeyopt", "ec_paramgen_curve:P-256"],
        None,
        None,
    )
}

/// What `openssl x509` says of a certificate: its subject as CycloneDDS compares it (RFC 2253,
/// `CN=/robot_a`), serial (hex), validity.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CertInfo {
    pub subject: String,
    pub issuer: String,
    pub serial: String,
    pub not_before: super::time::Unix,
    pub not_after: super::time::Unix,
}

/// Reads `cert` (PEM).
pub fn cert_info(cert: &Path) -> Result<CertInfo, SecurityError> {
    let out = text(
        "read a certificate",
        &[
            OsStr::new("x509"),
            OsStr::new("-noout"),
            OsStr::new("-in"),
            cert.as_os_str(),
            OsStr::new("-subject"),
            OsStr::new("-issuer"),
            OsStr::new("-serial"),
            OsStr::new("-startdate"),
            OsStr::new("-enddate"),
            OsStr::new("-nameopt"),
            OsStr::new("RFC2253"),
            OsStr::new("-dateopt"),
            OsStr::new("iso_8601"),
        ],
        None,
    )?;
    let field = |name: &str| -> Result<String, SecurityError> {
        out.lines()
            .find_map(|l| l.strip_prefix(name).and_then(|r| r.strip_prefix('=')))
            .map(|v| v.trim().to_string())
            .ok_or_else(|| SecurityError::Openssl {
                what: format!("read the {name} of {}", cert.display()),
                detail: out.trim().replace('\n', "; "),
            })
    };
    let date = |name: &str| -> Result<super::time::Unix, SecurityError> {
        let v = field(name)?;
        super::time::parse(&v).ok_or_else(|| SecurityError::Openssl {
            what: format!("read the {name} of {}", cert.display()),
            detail: format!("unreadable date {v:?}"),
        })
    };
    Ok(CertInfo {
        subject: field("subject")?,
        issuer: field("issuer")?,
        serial: field("serial")?,
        not_before: date("notBefore")?,
        not_after: date("notAfter")?,
    })
}

/// Signs `document` (S/MIME, detached, text: what `ros2 security` and CycloneDDS use for
/// governance and permissions) with the permissions CA.
pub fn smime_sign(document: &Path, ca_cert: &Path, ca_key: &Path) -> Result<Vec<u8>, SecurityError> {
    run(
        "sign a document with the permissions CA",
        &[
            OsStr::new("smime"),
            OsStr::new("-sign"),
            OsStr::new("-text"),
            OsStr::new("-in"),
            document.as_os_str(),
            OsStr::new("-signer"),
            ca_cert.as_os_str(),
            OsStr::new("-inkey"),
            ca_key.as_os_str(),
        ],
        None,
        None,
    )
}

/// The signed document in `p7s` if the permissions CA `ca_cert` signed it (as CycloneDDS
/// checks it: the signer's chain to that CA; dates are the caller's business).
pub fn smime_verify(p7s: &Path, ca_cert: &Path) -> Result<String, SecurityError> {
    let out = run(
        "verify a signed document",
        &[
            OsStr::new("smime"),
            OsStr::new("-verify"),
            OsStr::new("-text"),
            OsStr::new("-in"),
            p7s.as_os_str(),
            OsStr::new("-CAfile"),
            ca_cert.as_os_str(),
            OsStr::new("-no_check_time"),
        ],
        None,
        None,
    )?;
    Ok(String::from_utf8_lossy(&out).into_owned())
}

/// The signed content of `p7s` without checking who signed it.
pub fn smime_content(p7s: &Path) -> Result<String, SecurityError> {
    let out = run(
        "read a signed document",
        &[
            OsStr::new("smime"),
            OsStr::new("-verify"),
            OsStr::new("-noverify"),
            OsStr::new("-text"),
            OsStr::new("-in"),
            p7s.as_os_str(),
        ],
        None,
        None,
    )?;
    Ok(String::from_utf8_lossy(&out).into_owned())
}
