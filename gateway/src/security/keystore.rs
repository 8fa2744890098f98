//! The lab's keystore in the SROS2 layout (`ros2 security create_keystore` /
//! `create_enclave`, docs/security-keystore.md):
//!
//! ```text
//! DIR/public/ca.cert.pem            the lab CA (identity CA and permissions CA are one)
//! DIR/public/identity_ca.cert.pem   -> ca.cert.pem
//! DIR/public/permissions_ca.cert.pem -> ca.cert.pem
//! DIR/public/crl.pem                the identity CA's revocation list
//! DIR/private/ca.key.pem            its key (+ identity_ca.key.pem, permissions_ca.key.pem ->)
//! DIR/private/ca.cnf, index.txt, serial, crlnumber, newcerts/   openssl ca's database
//! DIR/enclaves/governance.xml, governance.p7s
//! DIR/enclaves/NAME/{cert.pem,key.pem,identity_ca.cert.pem,permissions_ca.cert.pem,
//!                    governance.p7s,permissions.xml,permissions.p7s}
//! ```
//!
//! An enclave directory is self-contained (copies, not links): it is what a robot or an
//! operator's machine receives.

use std::fs;
use std::io::Write;
use std::os::unix::fs::{OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};

use super::openssl::{self, CertInfo};
use super::time::{self, Unix};
use super::xml::{self, Domains, Role};
use super::SecurityError;

/// The `openssl ca` configuration written at `init` (paths relative to `private/`, where every
/// `openssl ca` runs).
const CA_CNF: &str = "# handgate security: the lab CA's `openssl ca` configuration. Paths are relative to
# this directory (private/), where handgate runs openssl.
[ ca ]
default_ca = lab_ca

[ lab_ca ]
dir = .
database = ./index.txt
new_certs_dir = ./newcerts
serial = ./serial
crlnumber = ./crlnumber
certificate = ../public/ca.cert.pem
private_key = ./ca.key.pem
default_md = sha256
default_days = 365
default_crl_days = 30
policy = policy_cn
unique_subject = no
email_in_dn = no
copy_extensions = none
preserve = no

[ policy_cn ]
commonName = supplied

[ req ]
distinguished_name = req_dn

[ req_dn ]

[ ca_ext ]
basicConstraints = critical, CA:TRUE
keyUsage = critical, digitalSignature, keyCertSign, cRLSign
subjectKeyIdentifier = hash

[ crl_ext ]
authorityKeyIdentifier = keyid:always
";

/// Default validity of the lab CA, days.
pub const DEFAULT_CA_DAYS: u32 = 3650;
/// Default validity of an identity, days.
pub const DEFAULT_DAYS: u32 = 365;
/// Default CA name.
pub const DEFAULT_CA_NAME: &str = "handgate lab CA";

/// A subject alternative name of an identity's certificate (for TLS uses of it, e.g. Zenoh).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum San {
    Dns(String),
    Ip(std::net::IpAddr),
}

impl San {
    /// `DNS:name` or `IP:address`.
    pub fn parse(s: &str) -> Result<San, SecurityError> {
        let bad = || SecurityError::BadSan(s.to_string());
        let (kind, value) = s.split_once(':').ok_or_else(bad)?;
        match kind.to_ascii_uppercase().as_str() {
            "DNS" => {
                let ok = !value.is_empty()
                    && value
                        .chars()
                        .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '.' | '*'));
                ok.then(|| San::Dns(value.to_string())).ok_or_else(bad)
            }
            "IP" => value.parse().map(San::Ip).map_err(|_| bad()),
            _ => Err(bad()),
        }
    }

    fn openssl(&self) -> String {
        match self {
            San::Dns(d) => format!("DNS:{d}"),
            San::Ip(a) => format!("IP:{a}"),
        }
    }
}

/// How long a new certificate is valid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Validity {
    /// From now, for this many days.
    Days(u32),
    /// Exactly this span (tests make expired and not-yet-valid identities with it).
    Span { not_before: Unix, not_after: Unix },
}

impl Validity {
    fn span(self, now: Unix) -> Result<(Unix, Unix), SecurityError> {
        let (nb, na) = match self {
            Validity::Days(0) => return Err(SecurityError::BadDays),
            Validity::Days(d) => (now, now + i64::from(d) * 86_400),
            Validity::Span { not_before, not_after } => (not_before, not_after),
        };
        if na <= nb {
            return Err(SecurityError::EmptyValidity {
                not_before: time::rfc3339(nb),
                not_after: time::rfc3339(na),
            });
        }
        Ok((nb, na))
    }
}

/// What `issue` is asked for.
#[derive(Debug, Clone)]
pub struct IssueRequest {
    /// The enclave name (`robot_a`, `/robot_a`, `ops/alice`).
    pub name: String,
    pub role: Role,
    /// The robots' DDS domains; empty: none for a gateway or an operator (refused), every
    /// domain for an observer.
    pub robots: Vec<u32>,
    pub validity: Validity,
    pub sans: Vec<San>,
}

/// An enclave name: its canonical form (`/ops/alice`) and its directory under `enclaves/`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EnclaveName {
    /// With its leading `/`, as SROS2 names it and as the certificate's CN.
    pub name: String,
    /// Relative to `enclaves/`.
    pub dir: PathBuf,
}

impl EnclaveName {
    /// `robot_a`, `/robot_a`, `ops/alice`: tokens of letters, digits and `_`, none empty or
    /// starting with a digit (ROS's namespace rules, which SROS2's enclave names follow).
    pub fn parse(s: &str) -> Result<Self, SecurityError> {
        let bad = |why| SecurityError::BadName {
            name: s.to_string(),
            why,
        };
        let body = s.strip_prefix('/').unwrap_or(s);
        if body.is_empty() {
            return Err(bad("is empty"));
        }
        if body.len() > 200 {
            return Err(bad("is longer than 200 characters"));
        }
        for token in body.split('/') {
            if token.is_empty() {
                return Err(bad("has an empty token (`//` or a trailing `/`)"));
            }
            if token.starts_with(|c: char| c.is_ascii_digit()) {
                return Err(bad("has a token starting with a digit"));
            }
            if !token.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(bad("has a character other than a-z, A-Z, 0-9, `_` and `/`"));
            }
        }
        Ok(EnclaveName {
            name: format!("/{body}"),
            dir: PathBuf::from(body),
        })
    }

    /// The certificate's subject for `openssl -subj` (`/CN=\/ops\/alice`).
    fn subj(&self) -> String {
        format!("/CN={}", self.name.replace('/', "\\/"))
    }
}

/// One enclave as `list` shows it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EnclaveInfo {
    pub name: String,
    pub subject: String,
    pub serial: String,
    pub not_before: Unix,
    pub not_after: Unix,
    /// `None`: permissions not written by handgate (an SROS2 policy's).
    pub role: Option<Role>,
    /// The granted domains, as the permissions list them (`11, 12`, `0-230`).
    pub robots: String,
    pub revoked: bool,
}

/// What `issue` and `renew` made.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Issued {
    pub name: String,
    pub dir: PathBuf,
    pub cert: CertInfo,
}

/// A keystore directory.
#[derive(Debug, Clone)]
pub struct Keystore {
    pub dir: PathBuf,
}

/// One line of `openssl ca`'s `index.txt`.
#[derive(Debug, Clone, PartialEq, Eq)]
struct IndexEntry {
    status: char,
    serial: String,
    subject: String,
}

fn read_index(path: &Path) -> Result<Vec<IndexEntry>, SecurityError> {
    let text = fs::read_to_string(path).map_err(SecurityError::io(path))?;
    Ok(text
        .lines()
        .filter_map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            (f.len() >= 6).then(|| IndexEntry {
                status: f[0].chars().next().unwrap_or('?'),
                serial: f[3].to_ascii_uppercase(),
                subject: f[5].to_string(),
            })
        })
        .collect())
}

/// Writes `data` to `path` with `mode` (a private key: 0600 from its creation), replacing it
/// atomically (written beside it, then renamed).
fn write_file(path: &Path, data: &[u8], mode: u32) -> Result<(), SecurityError> {
    let tmp = path.with_extension(format!("tmp{}", std::process::id()));
    let result = (|| {
        let mut f = fs::OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .mode(mode)
            .open(&tmp)?;
        // The mode applies at creation only: a leftover file keeps its own.
        f.set_permissions(fs::Permissions::from_mode(mode))?;
        f.write_all(data)?;
        f.sync_all()?;
        fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = fs::remove_file(&tmp);
        SecurityError::Io {
            path: path.to_path_buf(),
            error: e,
        }
    })
}

fn mkdir(path: &Path) -> Result<(), SecurityError> {
    fs::create_dir_all(path).map_err(SecurityError::io(path))
}

fn symlink(target: &str, link: &Path) -> Result<(), SecurityError> {
    std::os::unix::fs::symlink(target, link).map_err(SecurityError::io(link))
}

/// A scratch directory under `private/`, removed when dropped.
struct Scratch(PathBuf);

impl Scratch {
    fn new(private: &Path) -> Result<Self, SecurityError> {
        static N: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let p = private.join(format!("tmp.{}.{n}", std::process::id()));
        let _ = fs::remove_dir_all(&p);
        fs::create_dir(&p).map_err(SecurityError::io(&p))?;
        fs::set_permissions(&p, fs::Permissions::from_mode(0o700)).map_err(SecurityError::io(&p))?;
        Ok(Scratch(p))
    }
}

/// The keystore's lock (`private/lock`, holding the owner's pid): `openssl ca`'s database
/// (index.txt, serial, crlnumber) takes one writer at a time. Released when dropped.
struct Lock(PathBuf);

/// How long an operation waits for another one on the same keystore.
const LOCK_WAIT: std::time::Duration = std::time::Duration::from_secs(60);

impl Lock {
    fn take(private: &Path) -> Result<Self, SecurityError> {
        let path = private.join("lock");
        let deadline = std::time::Instant::now() + LOCK_WAIT;
        loop {
            match fs::OpenOptions::new().write(true).create_new(true).open(&path) {
                Ok(mut f) => {
                    let _ = writeln!(f, "{}", std::process::id());
                    return Ok(Lock(path));
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    // A lock left by a process that is gone is taken over.
                    let owner = fs::read_to_string(&path)
                        .ok()
                        .and_then(|s| s.trim().parse::<u32>().ok());
                    if owner
                        .is_some_and(|pid| pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists())
                    {
                        let _ = fs::remove_file(&path);
                        continue;
                    }
                    if std::time::Instant::now() >= deadline {
                        return Err(SecurityError::Locked(path));
                    }
                    std::thread::sleep(std::time::Duration::from_millis(20));
                }
                Err(e) => return Err(SecurityError::Io { path, error: e }),
            }
        }
    }
}

impl Drop for Lock {
    fn drop(&mut self) {
        let _ = fs::remove_file(&self.0);
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.0);
    }
}

impl Keystore {
    pub fn public(&self) -> PathBuf {
        self.dir.join("public")
    }
    pub fn private(&self) -> PathBuf {
        self.dir.join("private")
    }
    pub fn enclaves(&self) -> PathBuf {
        self.dir.join("enclaves")
    }
    /// The lab CA's certificate.
    pub fn ca_cert(&self) -> PathBuf {
        self.public().join("ca.cert.pem")
    }
    fn ca_key(&self) -> PathBuf {
        self.private().join("ca.key.pem")
    }
    /// The identity CA's revocation list.
    pub fn crl(&self) -> PathBuf {
        self.public().join("crl.pem")
    }
    pub fn governance(&self) -> PathBuf {
        self.enclaves().join("governance.p7s")
    }
    /// The directory of enclave `name`.
    pub fn enclave_dir(&self, name: &EnclaveName) -> PathBuf {
        self.enclaves().join(&name.dir)
    }

    /// Creates the keystore in `dir` (created if absent; refused when it holds one already):
    /// the lab CA (ECDSA P-256, SHA-256, `days` long), the governance signed by it, an empty
    /// revocation list.
    pub fn init(dir: &Path, ca_name: &str, days: u32, now: Unix) -> Result<Keystore, SecurityError> {
        if days == 0 {
            return Err(SecurityError::BadDays);
        }
        if ca_name.is_empty()
            || !ca_name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, ' ' | '-' | '_' | '.'))
        {
            return Err(SecurityError::BadCaName(ca_name.to_string()));
        }
        let ks = Keystore { dir: dir.to_path_buf() };
        for p in [
            ks.ca_cert(),
            ks.ca_key(),
            ks.governance(),
            ks.private().join("index.txt"),
            ks.private().join("ca.cnf"),
        ] {
            if p.symlink_metadata().is_ok() {
                return Err(SecurityError::KeystoreExists(dir.to_path_buf()));
            }
        }
        let subs = [ks.public(), ks.private(), ks.enclaves()];
        for d in &subs {
            if fs::read_dir(d).is_ok_and(|mut e| e.next().is_some()) {
                return Err(SecurityError::NotEmpty(d.clone()));
            }
        }
        // Made in a directory of its own beside them, then moved in: a failure (openssl
        // missing) leaves nothing behind that a second `init` would refuse.
        mkdir(dir)?;
        let stage = Keystore {
            dir: dir.join(format!(".handgate-init.{}", std::process::id())),
        };
        let _ = fs::remove_dir_all(&stage.dir);
        let built = stage.build(ca_name, days, now).and_then(|()| {
            for (from, to) in [stage.public(), stage.private(), stage.enclaves()].iter().zip(&subs) {
                let _ = fs::remove_dir(to);
                fs::rename(from, to).map_err(SecurityError::io(to))?;
            }
            Ok(())
        });
        let _ = fs::remove_dir_all(&stage.dir);
        built.map(|()| ks)
    }

    /// The keystore's files in `self.dir` (see [`Keystore::init`]).
    fn build(&self, ca_name: &str, days: u32, now: Unix) -> Result<(), SecurityError> {
        let private = self.private();
        for d in [
            self.public(),
            private.clone(),
            private.join("newcerts"),
            self.enclaves(),
        ] {
            mkdir(&d)?;
        }
        fs::set_permissions(&private, fs::Permissions::from_mode(0o700)).map_err(SecurityError::io(&private))?;
        write_file(&private.join("ca.cnf"), CA_CNF.as_bytes(), 0o644)?;
        write_file(&private.join("index.txt"), b"", 0o644)?;
        write_file(&private.join("serial"), b"1000\n", 0o644)?;
        write_file(&private.join("crlnumber"), b"1000\n", 0o644)?;
        write_file(&self.ca_key(), &openssl::new_key()?, 0o600)?;
        symlink("ca.key.pem", &private.join("identity_ca.key.pem"))?;
        symlink("ca.key.pem", &private.join("permissions_ca.key.pem"))?;
        openssl::run(
            "create the lab CA's certificate",
            &[
                "req",
                "-x509",
                "-new",
                "-config",
                "ca.cnf",
                "-extensions",
                "ca_ext",
                "-key",
                "ca.key.pem",
                "-subj",
                &format!("/CN={ca_name}"),
                "-sha256",
                "-days",
                &days.to_string(),
                "-out",
                "../public/ca.cert.pem",
            ],
            Some(&private),
            None,
        )?;
        symlink("ca.cert.pem", &self.public().join("identity_ca.cert.pem"))?;
        symlink("ca.cert.pem", &self.public().join("permissions_ca.cert.pem"))?;
        let gov_xml = self.enclaves().join("governance.xml");
        write_file(&gov_xml, xml::governance().as_bytes(), 0o644)?;
        let signed = openssl::smime_sign(&gov_xml, &self.ca_cert(), &self.ca_key())?;
        write_file(&self.governance(), &signed, 0o644)?;
        self.write_crl(now)
    }

    /// The keystore in `dir`, if it is one.
    pub fn open(dir: &Path) -> Result<Keystore, SecurityError> {
        let ks = Keystore { dir: dir.to_path_buf() };
        if !(ks.ca_cert().is_file() && ks.ca_key().is_file() && ks.private().join("ca.cnf").is_file()) {
            return Err(SecurityError::NoKeystore(dir.to_path_buf()));
        }
        Ok(ks)
    }

    /// Regenerates `public/crl.pem`, valid until the CA expires (an expired list would make
    /// every handshake fail).
    fn write_crl(&self, now: Unix) -> Result<(), SecurityError> {
        let ca = openssl::cert_info(&self.ca_cert())?;
        let days = ((ca.not_after - now + 86_399) / 86_400).max(1);
        let tmp = self.private().join(format!("crl.pem.tmp{}", std::process::id()));
        let r = openssl::run(
            "write the revocation list",
            &[
                "ca",
                "-batch",
                "-config",
                "ca.cnf",
                "-gencrl",
                "-crlexts",
                "crl_ext",
                "-crldays",
                &days.to_string(),
                "-out",
                tmp.to_str().unwrap_or_default(),
            ],
            Some(&self.private()),
            None,
        );
        if let Err(e) = r {
            let _ = fs::remove_file(&tmp);
            return Err(e);
        }
        let crl = fs::read(&tmp).map_err(SecurityError::io(&tmp))?;
        let _ = fs::remove_file(&tmp);
        write_file(&self.crl(), &crl, 0o644)
    }

    /// Issues enclave `req.name`: a key, a certificate of subject `CN=/name` signed by the lab
    /// CA, and permissions for its role on its robots' domains signed by the permissions CA.
    pub fn issue(&self, req: &IssueRequest, now: Unix) -> Result<Issued, SecurityError> {
        let name = EnclaveName::parse(&req.name)?;
        let domains = domains_for(req.role, &req.robots)?;
        let (nb, na) = req.validity.span(now)?;
        let _lock = Lock::take(&self.private())?;
        let dir = self.enclave_dir(&name);
        if dir.join("cert.pem").symlink_metadata().is_ok() {
            return Err(SecurityError::EnclaveExists(name.name));
        }
        self.make(&name, req.role, domains, (nb, na), &req.sans)
    }

    /// Renews enclave `name`: a new key and certificate (new serial, `days` from now, the same
    /// subject and SANs) and its permissions re-signed for the new validity, the same role and
    /// robots. The old certificate stays valid until it expires unless revoked.
    pub fn renew(&self, name: &str, days: u32, now: Unix) -> Result<Issued, SecurityError> {
        let name = EnclaveName::parse(name)?;
        let _lock = Lock::take(&self.private())?;
        let dir = self.enclave_dir(&name);
        let cert = dir.join("cert.pem");
        if !cert.is_file() {
            return Err(SecurityError::NoEnclave(name.name));
        }
        let (role, domains) = self.grant_of(&dir, &name.name)?;
        let sans = sans_of(&cert)?;
        let span = Validity::Days(days).span(now)?;
        self.make(&name, role, domains, span, &sans)
    }

    /// The role and domains of the permissions in enclave `dir` (`permissions.xml`, else the
    /// signed document's content).
    fn grant_of(&self, dir: &Path, name: &str) -> Result<(Role, Domains), SecurityError> {
        let doc = permissions_text(dir)?;
        let grants = xml::read_permissions(&doc);
        let commands = handgate_adapters::fronts::command_topic_patterns();
        let [g] = grants.as_slice() else {
            return Err(SecurityError::ForeignPermissions(name.to_string()));
        };
        let [rule] = g.allow.as_slice() else {
            return Err(SecurityError::ForeignPermissions(name.to_string()));
        };
        let role = Role::recognise(&rule.publish, &commands)
            .ok_or_else(|| SecurityError::ForeignPermissions(name.to_string()))?;
        let domains = match rule.domains.ids() {
            Some(ids) => Domains::Ids(ids),
            None if rule.domains == xml::governance_domains(&xml::governance()) => Domains::All,
            None => return Err(SecurityError::ForeignPermissions(name.to_string())),
        };
        Ok((role, domains))
    }

    /// Writes enclave `name` (key, certificate, permissions, the CA's public files).
    fn make(
        &self,
        name: &EnclaveName,
        role: Role,
        domains: Domains,
        (nb, na): (Unix, Unix),
        sans: &[San],
    ) -> Result<Issued, SecurityError> {
        let private = self.private();
        let scratch = Scratch::new(&private)?;
        let s = &scratch.0;
        let key = s.join("key.pem");
        write_file(&key, &openssl::new_key()?, 0o600)?;
        let csr = s.join("csr.pem");
        openssl::run(
            "make a certificate request",
            &[
                "req".as_ref(),
                "-new".as_ref(),
                "-key".as_ref(),
                key.as_os_str(),
                "-subj".as_ref(),
                name.subj().as_ref(),
                "-out".as_ref(),
                csr.as_os_str(),
            ] as &[&std::ffi::OsStr],
            None,
            None,
        )?;
        let mut ext = String::from(
            "[ identity ]\nbasicConstraints = critical, CA:FALSE\nkeyUsage = critical, digitalSignature, keyAgreement\n\
             extendedKeyUsage = serverAuth, clientAuth\nsubjectKeyIdentifier = hash\nauthorityKeyIdentifier = keyid\n",
        );
        if !sans.is_empty() {
            let v: Vec<String> = sans.iter().map(San::openssl).collect();
            ext.push_str(&format!("subjectAltName = {}\n", v.join(", ")));
        }
        let extfile = s.join("ext.cnf");
        write_file(&extfile, ext.as_bytes(), 0o644)?;
        let cert = s.join("cert.pem");
        openssl::run(
            "sign the certificate with the lab CA",
            &[
                "ca".as_ref(),
                "-batch".as_ref(),
                "-config".as_ref(),
                "ca.cnf".as_ref(),
                "-notext".as_ref(),
                "-in".as_ref(),
                csr.as_os_str(),
                "-out".as_ref(),
                cert.as_os_str(),
                "-startdate".as_ref(),
                time::asn1(nb).as_ref(),
                "-enddate".as_ref(),
                time::asn1(na).as_ref(),
                "-extfile".as_ref(),
                extfile.as_os_str(),
                "-extensions".as_ref(),
                "identity".as_ref(),
            ] as &[&std::ffi::OsStr],
            Some(&private),
            None,
        )?;
        let info = openssl::cert_info(&cert)?;
        let grant = xml::Grant {
            name: name.name.clone(),
            subject: info.subject.clone(),
            not_before: info.not_before,
            not_after: info.not_after,
            domains,
            role,
        };
        let perm_xml = s.join("permissions.xml");
        let commands = handgate_adapters::fronts::command_topic_patterns();
        write_file(&perm_xml, xml::permissions(&grant, &commands).as_bytes(), 0o644)?;
        let signed = openssl::smime_sign(&perm_xml, &self.ca_cert(), &self.ca_key())?;
        let perm_p7s = s.join("permissions.p7s");
        write_file(&perm_p7s, &signed, 0o644)?;

        let dir = self.enclave_dir(name);
        mkdir(&dir)?;
        let ca = fs::read(self.ca_cert()).map_err(SecurityError::io(self.ca_cert()))?;
        let gov = fs::read(self.governance()).map_err(SecurityError::io(self.governance()))?;
        write_file(&dir.join("identity_ca.cert.pem"), &ca, 0o644)?;
        write_file(&dir.join("permissions_ca.cert.pem"), &ca, 0o644)?;
        write_file(&dir.join("governance.p7s"), &gov, 0o644)?;
        // The key first: a certificate never sits beside another certificate's key for long.
        for (f, mode) in [
            ("key.pem", 0o600),
            ("cert.pem", 0o644),
            ("permissions.xml", 0o644),
            ("permissions.p7s", 0o644),
        ] {
            let from = s.join(f);
            let to = dir.join(f);
            fs::rename(&from, &to).map_err(SecurityError::io(&to))?;
            fs::set_permissions(&to, fs::Permissions::from_mode(mode)).map_err(SecurityError::io(&to))?;
        }
        Ok(Issued {
            name: name.name.clone(),
            dir,
            cert: info,
        })
    }

    /// Revokes every certificate issued to enclave `name` that is not revoked yet (the current
    /// one and those a renewal replaced) and rewrites `public/crl.pem`. Returns the serials
    /// revoked now (empty: all were already).
    pub fn revoke(&self, name: &str, now: Unix) -> Result<Vec<String>, SecurityError> {
        let name = EnclaveName::parse(name)?;
        let _lock = Lock::take(&self.private())?;
        let cert = self.enclave_dir(&name).join("cert.pem");
        if !cert.is_file() {
            return Err(SecurityError::NoEnclave(name.name));
        }
        let serial = openssl::cert_info(&cert)?.serial.to_ascii_uppercase();
        let index = read_index(&self.private().join("index.txt"))?;
        let Some(subject) = index.iter().find(|e| e.serial == serial).map(|e| e.subject.clone()) else {
            return Err(SecurityError::Openssl {
                what: format!(
                    "find {}'s certificate (serial {serial}) in private/index.txt",
                    name.name
                ),
                detail: "not issued by this keystore's CA".into(),
            });
        };
        let mut revoked = Vec::new();
        for e in index.iter().filter(|e| e.subject == subject && e.status == 'V') {
            let file = format!("newcerts/{}.pem", e.serial);
            openssl::run(
                "revoke the certificate",
                &["ca", "-batch", "-config", "ca.cnf", "-revoke", &file],
                Some(&self.private()),
                None,
            )?;
            revoked.push(e.serial.clone());
        }
        if !revoked.is_empty() || !self.crl().is_file() {
            self.write_crl(now)?;
        }
        Ok(revoked)
    }

    /// Every enclave with a certificate, sorted by name.
    pub fn list(&self) -> Result<Vec<EnclaveInfo>, SecurityError> {
        let index = read_index(&self.private().join("index.txt"))?;
        let commands = handgate_adapters::fronts::command_topic_patterns();
        let mut dirs = Vec::new();
        walk(&self.enclaves(), &mut dirs)?;
        let mut out = Vec::new();
        for dir in dirs {
            let rel = dir.strip_prefix(self.enclaves()).unwrap_or(&dir);
            let name = format!("/{}", rel.display());
            let cert = openssl::cert_info(&dir.join("cert.pem"))?;
            let serial = cert.serial.to_ascii_uppercase();
            let (role, robots) = match permissions_text(&dir) {
                Ok(doc) => {
                    let grants = xml::read_permissions(&doc);
                    let g = grants.iter().find(|g| xml::same_subject(&g.subject, &cert.subject));
                    let rule = g.and_then(|g| g.allow.first());
                    (
                        rule.and_then(|r| Role::recognise(&r.publish, &commands)),
                        rule.map(|r| r.domains.describe()).unwrap_or_else(|| "?".into()),
                    )
                }
                Err(_) => (None, "?".into()),
            };
            out.push(EnclaveInfo {
                name,
                subject: cert.subject,
                revoked: index.iter().any(|e| e.serial == serial && e.status == 'R'),
                serial,
                not_before: cert.not_before,
                not_after: cert.not_after,
                role,
                robots,
            });
        }
        out.sort_by(|a, b| a.name.cmp(&b.name));
        Ok(out)
    }
}

/// The grant's domains for `role` and `robots`.
fn domains_for(role: Role, robots: &[u32]) -> Result<Domains, SecurityError> {
    if let Some(&bad) = robots.iter().find(|&&d| d > xml::MAX_DOMAIN) {
        return Err(SecurityError::BadDomain(bad));
    }
    if robots.is_empty() {
        return match role {
            Role::Observer => Ok(Domains::All),
            r => Err(SecurityError::NoRobot(r.as_str())),
        };
    }
    let mut ids = robots.to_vec();
    ids.sort_unstable();
    ids.dedup();
    Ok(Domains::Ids(ids))
}

/// The permissions document of enclave `dir`: `permissions.xml`, else the content of
/// `permissions.p7s`.
fn permissions_text(dir: &Path) -> Result<String, SecurityError> {
    let xml = dir.join("permissions.xml");
    match fs::read_to_string(&xml) {
        Ok(t) => Ok(t),
        Err(_) => openssl::smime_content(&dir.join("permissions.p7s")),
    }
}

/// The subject alternative names of `cert`.
fn sans_of(cert: &Path) -> Result<Vec<San>, SecurityError> {
    let out = openssl::text(
        "read the certificate's alternative names",
        &[
            "x509".as_ref(),
            "-noout".as_ref(),
            "-in".as_ref(),
            cert.as_os_str(),
            "-ext".as_ref(),
            "subjectAltName".as_ref(),
        ] as &[&std::ffi::OsStr],
        None,
    )?;
    let mut v = Vec::new();
    for line in out.lines().skip(1) {
        for item in line.split(',') {
            let item = item.trim();
            if let Some(d) = item.strip_prefix("DNS:") {
                v.push(San::Dns(d.to_string()));
            } else if let Some(a) = item.strip_prefix("IP Address:") {
                if let Ok(ip) = a.parse() {
                    v.push(San::Ip(ip));
                }
            }
        }
    }
    Ok(v)
}

/// Every directory under `dir` holding a `cert.pem`.
fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> Result<(), SecurityError> {
    let entries = match fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => {
            return Err(SecurityError::Io {
                path: dir.into(),
                error: e,
            })
        }
    };
    for e in entries {
        let e = e.map_err(SecurityError::io(dir))?;
        let p = e.path();
        if e.file_type().map_err(SecurityError::io(&p))?.is_dir() {
            if p.join("cert.pem").is_file() {
                out.push(p.clone());
            }
            walk(&p, out)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn enclave_names() {
        let n = EnclaveName::parse("robot_a").unwrap();
        assert_eq!((n.name.as_str(), n.dir.as_path()), ("/robot_a", Path::new("robot_a")));
        assert_eq!(EnclaveName::parse("/robot_a").unwrap(), n);
        let o = EnclaveName::parse("ops/alice").unwrap();
        assert_eq!(
            (o.name.as_str(), o.dir.as_path()),
            ("/ops/alice", Path::new("ops/alice"))
        );
        assert_eq!(o.subj(), "/CN=\\/ops\\/alice");
        for bad in ["", "/", "a//b", "a/", "../x", "a/.", "1robot", "a b", "a-b"] {
            assert!(EnclaveName::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn domains_per_role() {
        assert_eq!(
            domains_for(Role::Gateway, &[12, 11, 12]).unwrap(),
            Domains::Ids(vec![11, 12])
        );
        assert!(matches!(
            domains_for(Role::Operator, &[]),
            Err(SecurityError::NoRobot("operator"))
        ));
        assert!(matches!(
            domains_for(Role::Gateway, &[]),
            Err(SecurityError::NoRobot("gateway"))
        ));
        assert_eq!(domains_for(Role::Observer, &[]).unwrap(), Domains::All);
        assert!(matches!(
            domains_for(Role::Observer, &[231]),
            Err(SecurityError::BadDomain(231))
        ));
    }

    #[test]
    fn sans_parse() {
        assert_eq!(San::parse("DNS:robot-a.lab").unwrap(), San::Dns("robot-a.lab".into()));
        assert_eq!(San::parse("ip:10.0.0.2").unwrap().openssl(), "IP:10.0.0.2");
        assert_eq!(San::parse("IP:::1").unwrap().openssl(), "IP:::1");
        for bad in ["robot", "DNS:", "DNS:a b", "IP:300.1.1.1", "URI:x"] {
            assert!(San::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn init_refuses_a_keystore_and_leaves_no_stage() {
        let dir = std::env::temp_dir().join(format!("handgate-init-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        let ks = Keystore::init(&dir, "t CA", 1, time::now()).expect("init");
        let mut names: Vec<String> = fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["enclaves", "private", "public"]);
        assert_eq!(fs::metadata(ks.ca_key()).unwrap().permissions().mode() & 0o777, 0o600);
        assert_eq!(fs::metadata(ks.private()).unwrap().permissions().mode() & 0o777, 0o700);
        assert_eq!(
            fs::read_link(ks.public().join("identity_ca.cert.pem")).unwrap(),
            Path::new("ca.cert.pem")
        );
        assert!(ks.crl().is_file() && ks.governance().is_file());
        assert!(matches!(
            Keystore::init(&dir, "t CA", 1, time::now()),
            Err(SecurityError::KeystoreExists(_))
        ));
        // A directory with other files in public/ is not taken either.
        let other = dir.join("other");
        fs::create_dir_all(other.join("public")).unwrap();
        fs::write(other.join("public/x"), b"x").unwrap();
        assert!(matches!(
            Keystore::init(&other, "t CA", 1, time::now()),
            Err(SecurityError::NotEmpty(_))
        ));
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn renew_revoke_list() {
        let dir = std::env::temp_dir().join(format!("handgate-renew-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        let now = time::now();
        let ks = Keystore::init(&dir, "t CA", 30, now).expect("init");
        let req = |name: &str, role, robots: Vec<u32>| IssueRequest {
            name: name.into(),
            role,
            robots,
            validity: Validity::Days(10),
            sans: vec![San::Dns("gw.lab".into())],
        };
        let first = ks.issue(&req("ops/gw", Role::Gateway, vec![4, 3]), now).expect("issue");
        assert_eq!(first.cert.subject, "CN=/ops/gw");
        assert!(matches!(
            ks.issue(&req("/ops/gw", Role::Operator, vec![1]), now),
            Err(SecurityError::EnclaveExists(n)) if n == "/ops/gw"
        ));
        ks.issue(&req("watch", Role::Observer, vec![]), now).expect("observer");
        let renewed = ks.renew("ops/gw", 20, now + 60).expect("renew");
        assert_ne!(renewed.cert.serial, first.cert.serial);
        assert_eq!(renewed.cert.subject, first.cert.subject);
        assert_eq!(renewed.cert.not_after, now + 60 + 20 * 86_400);
        assert_eq!(
            sans_of(&renewed.dir.join("cert.pem")).unwrap(),
            vec![San::Dns("gw.lab".into())]
        );
        let key_mode = fs::metadata(renewed.dir.join("key.pem")).unwrap().permissions().mode();
        assert_eq!(key_mode & 0o777, 0o600);
        let list = ks.list().expect("list");
        let names: Vec<(&str, Option<Role>, &str, bool)> = list
            .iter()
            .map(|e| (e.name.as_str(), e.role, e.robots.as_str(), e.revoked))
            .collect();
        assert_eq!(
            names,
            [
                ("/ops/gw", Some(Role::Gateway), "3, 4", false),
                ("/watch", Some(Role::Observer), "0-230", false)
            ]
        );
        ks.renew("watch", 5, now).expect("an observer of every domain renews");
        // Revoking revokes the renewed certificate and the one it replaced; again: nothing.
        let mut revoked = ks.revoke("/ops/gw", now).expect("revoke");
        revoked.sort();
        let mut both = vec![first.cert.serial.clone(), renewed.cert.serial.clone()];
        both.sort();
        assert_eq!(revoked, both);
        assert!(ks.revoke("ops/gw", now).expect("again").is_empty());
        assert!(ks.list().unwrap().iter().any(|e| e.name == "/ops/gw" && e.revoked));
        assert!(matches!(ks.revoke("nobody", now), Err(SecurityError::NoEnclave(_))));
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn parallel_issues_share_the_database() {
        let dir = std::env::temp_dir().join(format!("handgate-parallel-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        let ks = Keystore::init(&dir, "t CA", 30, time::now()).expect("init");
        let serials: Vec<String> = std::thread::scope(|s| {
            let hs: Vec<_> = (0..4)
                .map(|i| {
                    let ks = &ks;
                    s.spawn(move || {
                        let req = IssueRequest {
                            name: format!("robot_{i}"),
                            role: Role::Gateway,
                            robots: vec![11],
                            validity: Validity::Days(1),
                            sans: vec![],
                        };
                        ks.issue(&req, time::now()).expect("issue").cert.serial
                    })
                })
                .collect();
            hs.into_iter().map(|h| h.join().unwrap()).collect()
        });
        let mut unique = serials.clone();
        unique.sort();
        unique.dedup();
        assert_eq!(unique.len(), 4, "{serials:?}");
        assert_eq!(read_index(&ks.private().join("index.txt")).unwrap().len(), 4);
        assert!(!ks.private().join("lock").exists());
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn validity_spans() {
        assert_eq!(Validity::Days(2).span(100).unwrap(), (100, 100 + 2 * 86_400));
        assert!(matches!(Validity::Days(0).span(100), Err(SecurityError::BadDays)));
        assert!(Validity::Span {
            not_before: 5,
            not_after: 5
        }
        .span(0)
        .is_err());
    }
}
