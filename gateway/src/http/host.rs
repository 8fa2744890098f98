//! Which requests the HTTP server answers (docs/dashboard.md, "Security"; docs/sources.md
//! §11). A browser page on a domain its owner rebinds to this machine's address (DNS
//! rebinding) sends that domain in `Host` and, opening the WebSocket, in `Origin` too, so
//! comparing the two proves nothing. Every request's `Host` must name this server: a loopback
//! name or address, the address the connection reached, or a name the profile lists
//! (`[http] allowed_hosts`); a page opening the WebSocket must then come from that same
//! origin. Both are checked before the server does anything else with the request.
//!
//! The port in `Host` is not compared with the bound port: a browser always sends the port it
//! connected to, so it differs only behind a port forward or a proxy (`ssh -L 9000:...`), and
//! the name alone is what a rebinding page cannot fake. The WebSocket's `Origin` must have the
//! port of `Host`: another port on this machine is another site (another local web app).

use std::net::{IpAddr, Ipv6Addr};
use std::sync::atomic::{AtomicU64, Ordering};

/// A host as a request or the profile names it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Host {
    /// A DNS name: lower case, without its trailing dot.
    Name(String),
    /// An IP address (an IPv4-mapped IPv6 address as its IPv4 address).
    Ip(IpAddr),
}

impl Host {
    /// An IP address (IPv6 bare or in brackets) or a DNS name (dot-separated labels of
    /// letters, digits, `-` and `_`; a trailing dot is dropped, case folded).
    pub fn parse(s: &str) -> Result<Host, String> {
        if let Ok(ip) = s.parse::<IpAddr>() {
            return Ok(Host::Ip(ip.to_canonical()));
        }
        if let Some(inner) = s.strip_prefix('[').and_then(|r| r.strip_suffix(']')) {
            return inner
                .parse::<Ipv6Addr>()
                .map(|a| Host::Ip(IpAddr::V6(a).to_canonical()))
                .map_err(|_| format!("`{s}` is not an IPv6 address in brackets"));
        }
        let name = s.strip_suffix('.').unwrap_or(s);
        let label_ok = |l: &str| {
            !l.is_empty() && l.len() <= 63 && l.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_')
        };
        if name.is_empty() || name.len() > 253 || !name.split('.').all(label_ok) {
            return Err(format!(
                "`{s}` is neither an IP address nor a host name (letters, digits, `-`, `_` and dots)"
            ));
        }
        // A browser reads a name whose last label is a number as an IPv4 address (`127.1`).
        if name
            .rsplit('.')
            .next()
            .is_some_and(|l| l.bytes().all(|b| b.is_ascii_digit()))
        {
            return Err(format!("`{s}` is not an IPv4 address in dotted-decimal form"));
        }
        Ok(Host::Name(name.to_ascii_lowercase()))
    }
}

impl std::fmt::Display for Host {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Host::Name(n) => f.write_str(n),
            Host::Ip(IpAddr::V6(a)) => write!(f, "[{a}]"),
            Host::Ip(a) => write!(f, "{a}"),
        }
    }
}

/// A `Host` header's value, or the host and port of an `Origin`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Authority {
    pub host: Host,
    pub port: Option<u16>,
}

impl Authority {
    /// `host[:port]`, an IPv6 address in brackets; no user information, no path.
    pub fn parse(s: &str) -> Result<Authority, String> {
        let bad = |why: &str| format!("`{s}`: {why}");
        let (host, port) = match s.strip_prefix('[') {
            Some(rest) => {
                let end = rest.find(']').ok_or_else(|| bad("no `]`"))?;
                let port = &rest[end + 1..];
                let port = match port.strip_prefix(':') {
                    Some(p) => Some(p),
                    None if port.is_empty() => None,
                    None => return Err(bad("text after `]`")),
                };
                (&s[..end + 2], port)
            }
            None => match s.split_once(':') {
                Some((h, p)) => (h, Some(p)),
                None => (s, None),
            },
        };
        let port = match port {
            None => None,
            Some(p) if (1..=5).contains(&p.len()) && p.bytes().all(|b| b.is_ascii_digit()) => Some(
                p.parse::<u16>()
                    .ok()
                    .filter(|p| *p != 0)
                    .ok_or_else(|| bad("port out of range"))?,
            ),
            Some(_) => return Err(bad("the port is not a number")),
        };
        Ok(Authority {
            host: Host::parse(host).map_err(|e| bad(&e))?,
            port,
        })
    }
}

impl std::fmt::Display for Authority {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.port {
            Some(p) => write!(f, "{}:{p}", self.host),
            None => write!(f, "{}", self.host),
        }
    }
}

/// Why a request is refused, before anything else is done with it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Refusal {
    #[error("no Host header (HTTP/1.1 requires one)")]
    NoHost,
    #[error("more than one Host header")]
    TwoHosts,
    #[error("malformed Host {0}")]
    BadHost(String),
    #[error(
        "Host {0} is not a name this server answers to: localhost, a loopback address, the \
         address the connection reached, or a name in [http] allowed_hosts"
    )]
    NotOurs(String),
    #[error("Origin {origin:?} is not the page's own ({host}): cross-origin WebSocket refused")]
    Origin { origin: String, host: String },
}

impl Refusal {
    /// The response's status: 400 for a malformed request, 421 (Misdirected Request, RFC 9110
    /// §15.5.20) for a host that is not this server, 403 for another site's page.
    pub fn status(&self) -> u16 {
        match self {
            Refusal::NoHost | Refusal::TwoHosts | Refusal::BadHost(_) => 400,
            Refusal::NotOurs(_) => 421,
            Refusal::Origin { .. } => 403,
        }
    }

    /// Its `reason` label in `/metrics` and its key in the rate-limited log.
    pub fn reason(&self) -> &'static str {
        match self {
            Refusal::Origin { .. } => "origin",
            _ => "host",
        }
    }
}

/// Requests refused, by [`Refusal::reason`], and without the token (`token`; `/metrics`).
#[derive(Debug, Default)]
pub struct Refused {
    pub host: AtomicU64,
    pub origin: AtomicU64,
    pub token: AtomicU64,
}

impl Refused {
    pub fn count(&self, r: &Refusal) {
        match r {
            Refusal::Origin { .. } => &self.origin,
            _ => &self.host,
        }
        .fetch_add(1, Ordering::Relaxed);
    }
}

/// The names the server answers to besides the built-in ones, decided at bind time.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Allowed {
    /// `[http] allowed_hosts`.
    pub extra: Vec<Host>,
}

impl Allowed {
    /// Whether `host` names this server, for a connection that reached it at `local`:
    /// `localhost` and `*.localhost` (RFC 6761: never resolved by DNS), a loopback or
    /// unspecified address (Linux connects `0.0.0.0` to this machine), `local` itself (an
    /// address of this machine the client used), or one of [`Allowed::extra`].
    pub fn names(&self, host: &Host, local: IpAddr) -> bool {
        let built_in = match host {
            Host::Name(n) => n == "localhost" || n.ends_with(".localhost"),
            Host::Ip(ip) => ip.is_loopback() || ip.is_unspecified() || *ip == local.to_canonical(),
        };
        built_in || self.extra.contains(host)
    }

    /// A request's `Host` headers (`hosts`, every one it sent) checked for a connection that
    /// reached `local`. `Ok(None)`: an HTTP/1.0 request without `Host`, which no browser sends
    /// (so no page can be behind it) and which HTTP/1.0 allows.
    pub fn check(&self, hosts: &[&str], http10: bool, local: IpAddr) -> Result<Option<Authority>, Refusal> {
        let value = match hosts {
            [] if http10 => return Ok(None),
            [] => return Err(Refusal::NoHost),
            [one] => one.trim(),
            _ => return Err(Refusal::TwoHosts),
        };
        let a = Authority::parse(value).map_err(Refusal::BadHost)?;
        if self.names(&a.host, local) {
            Ok(Some(a))
        } else {
            Err(Refusal::NotOurs(format!("{value:?}")))
        }
    }
}

/// A page opening the WebSocket: its `Origin` (a browser always sends one) must be the origin
/// `Host` names: `http` or `https`, the same host, the same port (an absent port is the
/// scheme's default). No `Origin`: not a browser page, accepted. `null` (a sandboxed or file
/// page) is refused.
pub fn same_origin(origin: Option<&str>, host: Option<&Authority>) -> Result<(), Refusal> {
    let Some(origin) = origin.map(str::trim) else {
        return Ok(());
    };
    let refused = || Refusal::Origin {
        origin: origin.to_string(),
        host: host.map_or_else(|| "no Host".into(), ToString::to_string),
    };
    let (default_port, rest) = match origin.split_once("://") {
        Some((scheme, rest)) if scheme.eq_ignore_ascii_case("http") => (80, rest),
        Some((scheme, rest)) if scheme.eq_ignore_ascii_case("https") => (443, rest),
        _ => return Err(refused()),
    };
    let (Some(host), Ok(o)) = (host, Authority::parse(rest)) else {
        return Err(refused());
    };
    let port = |p: Option<u16>| p.unwrap_or(default_port);
    if o.host == host.host && port(o.port) == port(host.port) {
        Ok(())
    } else {
        Err(refused())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::Ipv4Addr;

    const LO: IpAddr = IpAddr::V4(Ipv4Addr::LOCALHOST);

    fn check(a: &Allowed, host: &str, local: IpAddr) -> Result<Option<Authority>, Refusal> {
        a.check(&[host], false, local)
    }

    #[test]
    fn loopback_names_and_addresses_are_answered_with_any_port_and_case() {
        let a = Allowed::default();
        for h in [
            "localhost",
            "localhost:8880",
            "LocalHost:8880",
            "localhost.:8880",
            "dashboard.localhost:8880",
            "127.0.0.1:8880",
            "127.0.0.1",
            "127.8.9.1:8880",
            "[::1]:8880",
            "[::1]",
            "[0:0:0:0:0:0:0:1]:8880",
            "[::ffff:127.0.0.1]:8880",
            "0.0.0.0:8880",
            "[::]:8880",
            "127.0.0.1:9000",
        ] {
            assert!(check(&a, h, LO).is_ok_and(|x| x.is_some()), "{h}");
        }
        let got = check(&a, " LOCALHOST.:8880 ", LO).unwrap().unwrap();
        assert_eq!(
            got,
            Authority {
                host: Host::Name("localhost".into()),
                port: Some(8880)
            }
        );
    }

    #[test]
    fn other_names_are_misdirected_requests_421() {
        let a = Allowed::default();
        for h in [
            "evil.example:8880",
            "evil.example",
            "localhost.evil.example:8880",
            "127.0.0.1.evil.example:8880",
            "localhostx:8880",
            "xlocalhost:8880",
            "10.0.0.5:8880",
            "[fe80::1]:8880",
            "[::2]:8880",
        ] {
            let r = check(&a, h, LO).unwrap_err();
            assert!(matches!(r, Refusal::NotOurs(_)), "{h}: {r:?}");
            assert_eq!((r.status(), r.reason()), (421, "host"), "{h}");
        }
    }

    #[test]
    fn malformed_hosts_are_bad_requests_400() {
        let a = Allowed::default();
        for h in [
            "127.0.0.1@evil.example:8880",
            "evil.example@127.0.0.1:8880",
            "user:pw@localhost:8880",
            "localhost:8880@evil.example",
            "::1",
            "::1:8880",
            "[::1",
            "[::1]x",
            "[::1]:",
            "[127.0.0.1]:8880",
            "[fe80::1%25eth0]:8880",
            "localhost:",
            "localhost:0",
            "localhost:65536",
            "localhost:88a0",
            "localhost:8880:1",
            "local host:8880",
            "localhost/x:8880",
            "localhost..:8880",
            ".localhost:8880",
            "127.1:8880",
            "0x7f.0.0.1:8880",
            "2130706433:8880",
            "",
            ":8880",
        ] {
            let r = check(&a, h, LO).unwrap_err();
            assert!(matches!(r, Refusal::BadHost(_)), "{h}: {r:?}");
            assert_eq!(r.status(), 400, "{h}");
        }
    }

    #[test]
    fn the_address_the_connection_reached_and_the_profiles_names_are_answered() {
        let lan: IpAddr = "192.168.1.10".parse().unwrap();
        let a = Allowed {
            extra: vec![
                Host::parse("Robot.Example.").unwrap(),
                Host::parse("10.0.0.5").unwrap(),
                Host::parse("fd00::5").unwrap(),
            ],
        };
        assert!(
            check(&a, "192.168.1.10:8880", lan).is_ok(),
            "the connection's own address"
        );
        let mapped: IpAddr = "::ffff:192.168.1.10".parse().unwrap();
        assert!(check(&a, "192.168.1.10:8880", mapped).is_ok(), "dual-stack socket");
        assert!(
            check(&a, "192.168.1.11:8880", lan).is_err(),
            "another address than the one reached"
        );
        assert!(check(&a, "robot.example:8880", lan).is_ok());
        assert!(check(&a, "ROBOT.example.", lan).is_ok());
        assert!(check(&a, "10.0.0.5:8880", lan).is_ok());
        assert!(check(&a, "[fd00::5]:8880", lan).is_ok());
        assert!(check(&a, "www.robot.example:8880", lan).is_err(), "no wildcard");
        assert!(check(&a, "robot.example.evil.example:8880", lan).is_err());
        assert!(check(&Allowed::default(), "robot.example:8880", lan).is_err());
    }

    #[test]
    fn host_is_required_once_except_in_http_1_0() {
        let a = Allowed::default();
        assert_eq!(a.check(&[], false, LO), Err(Refusal::NoHost));
        assert_eq!(a.check(&[], true, LO), Ok(None), "HTTP/1.0 without Host");
        assert!(
            a.check(&["evil.example"], true, LO).is_err(),
            "HTTP/1.0 with one is checked"
        );
        assert_eq!(
            a.check(&["localhost:8880", "evil.example:8880"], false, LO),
            Err(Refusal::TwoHosts)
        );
        assert_eq!(Refusal::NoHost.status(), 400);
    }

    #[test]
    fn profile_entries_parse_as_names_or_addresses() {
        assert_eq!(Host::parse("Robot.LAN."), Ok(Host::Name("robot.lan".into())));
        assert_eq!(Host::parse("hand_pc"), Ok(Host::Name("hand_pc".into())));
        assert_eq!(Host::parse("::1"), Ok(Host::Ip("::1".parse().unwrap())));
        assert_eq!(Host::parse("[fd00::5]"), Ok(Host::Ip("fd00::5".parse().unwrap())));
        assert_eq!(
            Host::parse("::ffff:10.0.0.5"),
            Ok(Host::Ip("10.0.0.5".parse().unwrap()))
        );
        for bad in [
            "",
            ".",
            "robot.lan:8880",
            "http://robot.lan",
            "*.robot.lan",
            "robot lan",
            "a..b",
            "10.0.0",
            "[10.0.0.5]",
        ] {
            assert!(Host::parse(bad).is_err(), "{bad:?}");
        }
        assert!(Host::parse(&"a".repeat(64)).is_err(), "a label of 64");
        assert!(Host::parse(&["a"; 130].join(".")).is_err(), "longer than 253");
    }

    fn host(s: &str) -> Option<Authority> {
        Some(Authority::parse(s).unwrap())
    }

    #[test]
    fn only_the_pages_own_origin_opens_the_websocket() {
        let h = host("127.0.0.1:8880");
        assert_eq!(same_origin(None, h.as_ref()), Ok(()), "no Origin: not a browser page");
        assert_eq!(same_origin(Some("http://127.0.0.1:8880"), h.as_ref()), Ok(()));
        assert_eq!(same_origin(Some("HTTP://127.0.0.1:8880"), h.as_ref()), Ok(()));
        let lh = host("localhost:8880");
        assert_eq!(same_origin(Some("http://LOCALHOST:8880"), lh.as_ref()), Ok(()));
        assert_eq!(same_origin(Some("http://localhost.:8880"), lh.as_ref()), Ok(()));
        let v6 = host("[::1]:8880");
        assert_eq!(same_origin(Some("http://[::1]:8880"), v6.as_ref()), Ok(()));
        // Default ports: Host without one is the scheme's.
        assert_eq!(
            same_origin(Some("http://localhost"), host("localhost").as_ref()),
            Ok(())
        );
        assert_eq!(
            same_origin(Some("http://localhost:80"), host("localhost").as_ref()),
            Ok(())
        );
        assert_eq!(
            same_origin(Some("https://robot.example"), host("robot.example").as_ref()),
            Ok(())
        );
        for (origin, h) in [
            ("http://evil.example:8880", "127.0.0.1:8880"),
            ("http://127.0.0.1:9999", "127.0.0.1:8880"),
            ("http://localhost:3000", "localhost:8880"),
            ("http://localhost:8880", "127.0.0.1:8880"),
            ("http://127.0.0.1:8880.evil.example", "127.0.0.1:8880"),
            ("http://127.0.0.1:8880@evil.example", "127.0.0.1:8880"),
            ("http://evil.example@127.0.0.1:8880", "127.0.0.1:8880"),
            ("http://127.0.0.1:8880/", "127.0.0.1:8880"),
            ("ws://127.0.0.1:8880", "127.0.0.1:8880"),
            ("file://", "127.0.0.1:8880"),
            ("null", "127.0.0.1:8880"),
            ("127.0.0.1:8880", "127.0.0.1:8880"),
            ("https://localhost", "localhost:80"),
        ] {
            let r = same_origin(Some(origin), host(h).as_ref()).unwrap_err();
            assert_eq!((r.status(), r.reason()), (403, "origin"), "{origin} for {h}");
        }
        assert!(
            same_origin(Some("http://127.0.0.1:8880"), None).is_err(),
            "an Origin without Host (HTTP/1.0)"
        );
    }

    #[test]
    fn refusals_are_counted_by_reason() {
        let r = Refused::default();
        r.count(&Refusal::NotOurs("x".into()));
        r.count(&Refusal::NoHost);
        r.count(&Refusal::Origin {
            origin: "o".into(),
            host: "h".into(),
        });
        assert_eq!(
            (r.host.load(Ordering::Relaxed), r.origin.load(Ordering::Relaxed)),
            (2, 1)
        );
    }
}
