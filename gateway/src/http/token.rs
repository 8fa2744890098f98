//! The HTTP server's token (`[http] token_file`, docs/dashboard.md "Security"): required on
//! every route when configured, and always when the server listens on anything but loopback.
//! A client proves it with `Authorization: Bearer <token>` (scripts, Prometheus) or with the
//! cookie the server sets once a page was opened with `?token=<token>` (a browser: it cannot
//! set a header on the WebSocket's upgrade, but sends the cookie). Compared in constant time:
//! the SHA-256 digests of both, equal byte by byte without an early exit.

use std::collections::HashMap;
use std::net::IpAddr;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use sha2::{Digest, Sha256};

/// Shortest token accepted, bytes.
pub const MIN_TOKEN_LEN: usize = 16;
/// Longest token file read, bytes (a token is a line; a larger file is not one).
const MAX_TOKEN_FILE: u64 = 4096;
/// The cookie a page gets once opened with the token.
pub const COOKIE: &str = "handgate_token";

/// Why a token file is refused (at `handgate check` and at start).
#[derive(Debug, thiserror::Error)]
pub enum TokenError {
    #[error("cannot read the token file {path}: {source}")]
    Unreadable {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("the token file {path} is not a regular file")]
    NotAFile { path: PathBuf },
    #[error(
        "the token file {path} may be read or written by its group or others (mode {mode:03o}): \
         chmod 600 it"
    )]
    Permissions { path: PathBuf, mode: u32 },
    #[error("the token file {path} is larger than {MAX_TOKEN_FILE} bytes: it should hold one line, the token")]
    TooLarge { path: PathBuf },
    #[error(
        "the token in {path} is {len} bytes, fewer than {MIN_TOKEN_LEN} (make one with \
         `head -c 32 /dev/urandom | base64 > FILE`)"
    )]
    TooShort { path: PathBuf, len: usize },
    #[error(
        "the token in {path} has a character other than visible ASCII, or one of space \" , ; \\ \
         (it travels in a header, a cookie and a URL): base64 or hex is fine"
    )]
    BadCharacter { path: PathBuf },
}

/// The token, held only as its digest.
#[derive(Clone, PartialEq, Eq)]
pub struct Token {
    digest: [u8; 32],
}

impl std::fmt::Debug for Token {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Token(..)")
    }
}

fn digest(bytes: &[u8]) -> [u8; 32] {
    Sha256::digest(bytes).into()
}

/// Whether `b` may be in a token: visible ASCII, without the characters a cookie value or a
/// header list would split on (RFC 6265 cookie-octet).
fn token_char(b: u8) -> bool {
    b.is_ascii_graphic() && !matches!(b, b'"' | b',' | b';' | b'\\')
}

impl Token {
    /// A token from its text (the file's, without its trailing newline).
    pub fn parse(text: &[u8], path: &Path) -> Result<Token, TokenError> {
        if text.len() < MIN_TOKEN_LEN {
            return Err(TokenError::TooShort {
                path: path.to_path_buf(),
                len: text.len(),
            });
        }
        if !text.iter().all(|b| token_char(*b)) {
            return Err(TokenError::BadCharacter {
                path: path.to_path_buf(),
            });
        }
        Ok(Token { digest: digest(text) })
    }

    /// Reads `path`: a regular file, no access for group or others, one line holding the
    /// token (trailing whitespace dropped), at least [`MIN_TOKEN_LEN`] bytes.
    pub fn load(path: &Path) -> Result<Token, TokenError> {
        use std::os::unix::fs::PermissionsExt;
        let unreadable = |source| TokenError::Unreadable {
            path: path.to_path_buf(),
            source,
        };
        let meta = std::fs::metadata(path).map_err(unreadable)?;
        if !meta.is_file() {
            return Err(TokenError::NotAFile {
                path: path.to_path_buf(),
            });
        }
        let mode = meta.permissions().mode() & 0o777;
        if mode & 0o077 != 0 {
            return Err(TokenError::Permissions {
                path: path.to_path_buf(),
                mode,
            });
        }
        if meta.len() > MAX_TOKEN_FILE {
            return Err(TokenError::TooLarge {
                path: path.to_path_buf(),
            });
        }
        let bytes = std::fs::read(path).map_err(unreadable)?;
        let end = bytes
            .iter()
            .rposition(|b| !b.is_ascii_whitespace())
            .map_or(0, |i| i + 1);
        Token::parse(&bytes[..end], path)
    }

    /// Whether `candidate` is the token: the digests compared in constant time (every byte
    /// looked at, no early exit), so the time taken says nothing of how much matched.
    pub fn verify(&self, candidate: &[u8]) -> bool {
        let d = digest(candidate);
        let diff = self.digest.iter().zip(d.iter()).fold(0u8, |acc, (a, b)| acc | (a ^ b));
        std::hint::black_box(diff) == 0
    }
}

/// What a request presented, and what it is owed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Verdict {
    /// The right token in `Authorization` or the cookie.
    Pass,
    /// The right token in the query (`?token=`): the page is redirected to `clean` (the same
    /// path and other parameters, without the token) with the cookie set (`cookie`: the
    /// `Set-Cookie` value).
    SetCookie { clean: String, cookie: String },
    /// Nothing, or a wrong token: 401.
    Refuse,
}

/// Percent-decodes a query value (`+` is kept: a token holds no space, and base64 has `+`).
fn percent_decode(s: &str) -> Vec<u8> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16).map(|d| d as u8);
        if b[i] == b'%' && i + 2 < b.len() {
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push(h << 4 | l);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    out
}

impl Token {
    /// The verdict on a request for `target` (path and query as sent) with these
    /// `Authorization` and `Cookie` headers (every one sent). The right token in the query
    /// comes first: that URL is always redirected to its clean form.
    pub fn check(&self, target: &str, authorization: &[&str], cookies: &[&str]) -> Verdict {
        let (path, query) = target.split_once('?').unwrap_or((target, ""));
        let mut found = None;
        let mut rest = Vec::new();
        for param in query.split('&').filter(|p| !p.is_empty()) {
            match param.split_once('=') {
                Some(("token", v)) => {
                    let v = percent_decode(v);
                    if self.verify(&v) {
                        found = Some(v);
                    }
                }
                _ => rest.push(param),
            }
        }
        // Verified, so visible ASCII.
        if let Some(text) = found.and_then(|v| String::from_utf8(v).ok()) {
            // A path of this server only (`//host/...` would send the page elsewhere).
            let path = if path.starts_with('/') && !path.starts_with("//") {
                path
            } else {
                "/"
            };
            let clean = if rest.is_empty() {
                path.to_string()
            } else {
                format!("{path}?{}", rest.join("&"))
            };
            return Verdict::SetCookie {
                clean,
                cookie: set_cookie(&text),
            };
        }
        for a in authorization {
            let a = a.trim();
            if let Some((scheme, t)) = a.split_once(' ') {
                if scheme.eq_ignore_ascii_case("bearer") && self.verify(t.trim().as_bytes()) {
                    return Verdict::Pass;
                }
            }
        }
        for header in cookies {
            for pair in header.split(';') {
                if let Some((name, value)) = pair.trim().split_once('=') {
                    if name == COOKIE && self.verify(value.as_bytes()) {
                        return Verdict::Pass;
                    }
                }
            }
        }
        Verdict::Refuse
    }
}

/// The `Set-Cookie` value for a page that presented the token: the token itself (the page's
/// script cannot read it: HttpOnly; other sites' requests do not carry it: SameSite=Strict),
/// for this browser session.
fn set_cookie(text: &str) -> String {
    format!("{COOKIE}={text}; Path=/; HttpOnly; SameSite=Strict")
}

/// How often at most a refused peer address is logged.
pub const LOG_EVERY: Duration = Duration::from_secs(10);
/// Peer addresses remembered at most (a scan of many addresses logs no more than this many
/// lines per [`LOG_EVERY`]).
const MAX_PEERS: usize = 256;

/// Which refused requests are logged: at most one per peer address per [`LOG_EVERY`], and
/// at most [`MAX_PEERS`] addresses remembered; the rest are counted (in `/metrics`) but not
/// logged. A plain state machine: every call takes `now`.
#[derive(Debug, Default)]
pub struct PeerLog {
    /// Per address: when it was last logged, and its refusals since.
    last: HashMap<IpAddr, (Instant, u64)>,
}

impl PeerLog {
    /// `Some(n)`: log this refusal of `peer` (`n` of its refusals were not logged since its
    /// last line); `None`: do not.
    pub fn admit(&mut self, peer: IpAddr, now: Instant) -> Option<u64> {
        if let Some(e) = self.last.get_mut(&peer) {
            if now.duration_since(e.0) >= LOG_EVERY {
                let suppressed = e.1;
                *e = (now, 0);
                return Some(suppressed);
            }
            e.1 += 1;
            return None;
        }
        if self.last.len() >= MAX_PEERS {
            self.last.retain(|_, (t, _)| now.duration_since(*t) < LOG_EVERY);
            if self.last.len() >= MAX_PEERS {
                return None;
            }
        }
        self.last.insert(peer, (now, 0));
        Some(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "c2VjcmV0LXRva2VuLWZvci10ZXN0cw+/=";

    fn token() -> Token {
        Token::parse(TEXT.as_bytes(), Path::new("t")).unwrap()
    }

    #[test]
    fn only_the_same_bytes_verify() {
        let t = token();
        assert!(t.verify(TEXT.as_bytes()));
        let mut wrong = TEXT.as_bytes().to_vec();
        wrong[0] ^= 1;
        assert!(!t.verify(&wrong), "same length, one bit off");
        assert!(!t.verify(&TEXT.as_bytes()[..TEXT.len() - 1]), "a prefix");
        assert!(!t.verify(format!("{TEXT}x").as_bytes()), "longer");
        assert!(!t.verify(b""));
    }

    #[test]
    fn header_cookie_and_query_are_read_and_the_query_redirects_to_the_clean_url() {
        let t = token();
        let bearer = format!("Bearer {TEXT}");
        assert_eq!(t.check("/metrics", &[&bearer], &[]), Verdict::Pass);
        assert_eq!(t.check("/metrics", &[&format!("bearer  {TEXT} ")], &[]), Verdict::Pass);
        assert_eq!(t.check("/metrics", &[&format!("Basic {TEXT}")], &[]), Verdict::Refuse);
        assert_eq!(t.check("/metrics", &["Bearer nope"], &[]), Verdict::Refuse);
        let cookie = format!("theme=dark; {COOKIE}={TEXT}; x=1");
        assert_eq!(t.check("/ws", &[], &[&cookie]), Verdict::Pass);
        assert_eq!(
            t.check("/ws", &[], &[&format!("other_{COOKIE}={TEXT}")]),
            Verdict::Refuse
        );
        assert_eq!(t.check("/ws", &[], &[&format!("{COOKIE}=x")]), Verdict::Refuse);
        // `+`, `/` and `=` as typed, or percent-encoded as a form sends them.
        let encoded = TEXT.replace('+', "%2B").replace('/', "%2f").replace('=', "%3D");
        for q in [TEXT.to_string(), encoded] {
            let cookie = format!("{COOKIE}={TEXT}; Path=/; HttpOnly; SameSite=Strict");
            assert_eq!(
                t.check(&format!("/?token={q}"), &[], &[]),
                Verdict::SetCookie {
                    clean: "/".into(),
                    cookie: cookie.clone()
                }
            );
            assert_eq!(
                t.check(&format!("/fleet?a=1&token={q}&b=2"), &[], &[]),
                Verdict::SetCookie {
                    clean: "/fleet?a=1&b=2".into(),
                    cookie
                }
            );
        }
        assert!(
            matches!(t.check(&format!("//evil.example/?token={TEXT}"), &[], &[]),
                Verdict::SetCookie { clean, .. } if clean == "/"),
            "never redirected off this server"
        );
        assert_eq!(t.check("/?token=wrong", &[], &[]), Verdict::Refuse);
        assert_eq!(t.check("/?tokenx=1", &[], &[]), Verdict::Refuse);
        assert_eq!(t.check("/", &[], &[]), Verdict::Refuse);
        assert_eq!(t.check("/?token=%", &[], &[]), Verdict::Refuse);
    }

    #[test]
    fn files_are_refused_when_missing_short_shared_or_odd() {
        use std::os::unix::fs::PermissionsExt;
        let dir = std::env::temp_dir().join(format!("handgate-token-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let write = |name: &str, text: &str, mode: u32| {
            let p = dir.join(name);
            std::fs::write(&p, text).unwrap();
            std::fs::set_permissions(&p, std::fs::Permissions::from_mode(mode)).unwrap();
            p
        };
        let ok = write("ok", &format!("{TEXT}\n"), 0o600);
        assert_eq!(Token::load(&ok).unwrap(), token(), "the trailing newline dropped");
        let ok = write("ok-ro", &format!("{TEXT}\r\n"), 0o400);
        assert_eq!(Token::load(&ok).unwrap(), token());
        let e = Token::load(&dir.join("missing")).unwrap_err();
        assert!(matches!(e, TokenError::Unreadable { .. }), "{e}");
        assert!(e.to_string().contains("missing"), "{e}");
        let e = Token::load(&write("group", TEXT, 0o640)).unwrap_err();
        assert!(
            e.to_string().contains("chmod 600") && e.to_string().contains("640"),
            "{e}"
        );
        assert!(Token::load(&write("other", TEXT, 0o604)).is_err());
        assert!(Token::load(&write("other-w", TEXT, 0o602)).is_err());
        let e = Token::load(&write("empty", "\n", 0o600)).unwrap_err();
        assert!(matches!(e, TokenError::TooShort { len: 0, .. }), "{e}");
        let e = Token::load(&write("short", "0123456789abcde\n", 0o600)).unwrap_err();
        assert!(matches!(e, TokenError::TooShort { len: 15, .. }), "{e}");
        assert!(Token::load(&write("sixteen", "0123456789abcdef\n", 0o600)).is_ok());
        let e = Token::load(&write("space", "0123456789 abcdef", 0o600)).unwrap_err();
        assert!(matches!(e, TokenError::BadCharacter { .. }), "{e}");
        assert!(Token::load(&write("semi", "0123456789;abcdef", 0o600)).is_err());
        assert!(Token::load(&write("two", "0123456789abcdef\nsecond-line-here", 0o600)).is_err());
        assert!(matches!(Token::load(&dir).unwrap_err(), TokenError::NotAFile { .. }));
        let big = "a".repeat(5000);
        assert!(matches!(
            Token::load(&write("big", &big, 0o600)).unwrap_err(),
            TokenError::TooLarge { .. }
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_peer_is_logged_once_per_interval_with_what_was_not() {
        let mut l = PeerLog::default();
        let t0 = Instant::now();
        let a: IpAddr = "10.0.0.1".parse().unwrap();
        let b: IpAddr = "10.0.0.2".parse().unwrap();
        assert_eq!(l.admit(a, t0), Some(0));
        assert_eq!(l.admit(a, t0 + Duration::from_millis(10)), None);
        assert_eq!(l.admit(b, t0 + Duration::from_millis(20)), Some(0), "another peer");
        for i in 0..100 {
            assert_eq!(l.admit(a, t0 + Duration::from_millis(100 + i)), None);
        }
        assert_eq!(l.admit(a, t0 + LOG_EVERY), Some(101));
        assert_eq!(l.admit(a, t0 + LOG_EVERY), None);
    }

    #[test]
    fn many_peers_log_no_more_than_the_remembered_ones() {
        let mut l = PeerLog::default();
        let t0 = Instant::now();
        let peer = |i: usize| IpAddr::from([10, 1, (i / 256) as u8, (i % 256) as u8]);
        let logged = (0..1000).filter(|i| l.admit(peer(*i), t0).is_some()).count();
        assert_eq!(logged, MAX_PEERS);
        // After the interval the old ones are forgotten and new peers are logged again.
        assert_eq!(l.admit(peer(5000), t0 + LOG_EVERY), Some(0));
    }
}
