//! The gateway's HTTP server (`[http]`, docs/dashboard.md): the live dashboard (embedded
//! page, a WebSocket of JSON frames), `/metrics` (Prometheus text) and `/healthz`. Bound to
//! loopback unless the profile chooses another address; accepts no command unless the
//! profile's `commands = true`, and then only through the page's own front (the same
//! clamps, ownership and watchdog as any client). Answers only requests whose `Host` names it
//! and, on the WebSocket, pages of that origin (`host.rs`: DNS rebinding); then, when the
//! profile names a token (`[http] token_file`, required off loopback), only requests that
//! present it (`token.rs`), on every route. Commands need the token too: without one the page's
//! front is not started. Never on a device path: it reads the devices' state channels and
//! lock-free counters.

mod assets;
mod feed;
pub mod host;
mod metrics;
pub mod token;
mod web_front;
mod ws;

use std::collections::HashMap;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::discovery::Snapshot;
use handgate_idl::handgate::GatewayStatus_;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{broadcast, watch};

use crate::plan::{HttpPlan, Plan};
use crate::runtime::fronts::RateLimitedLog;
use crate::runtime::DeviceSlot;

pub use web_front::PageCommand;

/// HTTP server errors (start-up).
#[derive(Debug, thiserror::Error)]
pub enum HttpError {
    #[error(
        "cannot listen on {addr}: {source} (another process has the port? set [http] port, \
         `--http-port 0` for any free port, or [http] enabled = false)"
    )]
    Bind {
        addr: SocketAddr,
        #[source]
        source: std::io::Error,
    },
    #[error("[http] token_file: {0}")]
    Token(#[from] token::TokenError),
}

/// A front as the page lists it.
#[derive(Debug, Clone)]
pub struct FrontInfo {
    pub name: String,
    pub kind: String,
    pub cmd_topic: Option<String>,
    pub state_topic: String,
    pub devices: Vec<String>,
}

/// What the server shows and serves: the fleet, its latest status, the page's front.
pub struct Fleet {
    pub profile: String,
    pub devices: Vec<Arc<DeviceSlot>>,
    pub fronts: Vec<FrontInfo>,
    pub status: watch::Receiver<Arc<GatewayStatus_>>,
    /// The latest status extension (per front: command and state rates; `/metrics`).
    pub status_ext: watch::Receiver<Arc<handgate_idl::handgate::GatewayStatusExt_>>,
    pub discovery: watch::Receiver<Arc<Snapshot>>,
    /// The runtime's clock origin (sample times are seconds since it).
    pub started: Instant,
    /// Pages connected now.
    pub clients: AtomicUsize,
    /// Requests refused for their `Host`, `Origin` or token.
    pub refused: host::Refused,
    /// The fleet page's latest look (`[http] fleet_domains`); `None`: no fleet page.
    pub lab: Option<watch::Receiver<Arc<crate::fleet::Fleet>>>,
}

impl Fleet {
    pub fn new(
        plan: &Plan,
        devices: &[Arc<DeviceSlot>],
        discovery: watch::Receiver<Arc<Snapshot>>,
        status: watch::Receiver<Arc<GatewayStatus_>>,
    ) -> Self {
        let fronts = plan
            .fronts
            .iter()
            .map(|f| FrontInfo {
                name: f.name.clone(),
                kind: f.kind().as_str().to_string(),
                cmd_topic: f.cmd_topic().map(str::to_string),
                state_topic: f.state_topic().to_string(),
                devices: if f.bindings.is_empty() {
                    f.devices.clone()
                } else {
                    f.bindings.iter().map(|b| b.device.clone()).collect()
                },
            })
            .collect();
        Self {
            profile: plan.profile.clone(),
            devices: devices.to_vec(),
            fronts,
            status,
            // The runtime sets its own; until then (and in tests) an extension with no front.
            status_ext: watch::channel(Arc::default()).1,
            discovery,
            started: crate::runtime::epoch(),
            clients: AtomicUsize::new(0),
            refused: host::Refused::default(),
            lab: None,
        }
    }
}

/// Pages served at once at most (each costs a socket and its share of the frames).
const MAX_CLIENTS: usize = 16;
/// Longest request head accepted, bytes.
const MAX_HEAD: usize = 8 * 1024;
/// How long a client may take to send its request head.
const HEAD_TIMEOUT: Duration = Duration::from_secs(5);

/// `[http]`'s socket and token, from [`bind`].
pub struct Bound {
    listener: std::net::TcpListener,
    token: Option<token::Token>,
}

/// Binds `[http]`'s address (an error names it and the fixes) and reads its token file (read
/// once, here): called before any device opens, so a taken port or a bad token file stops the
/// start without touching hardware.
pub fn bind(h: &HttpPlan) -> Result<Bound, HttpError> {
    let token = h.token_file.as_deref().map(token::Token::load).transpose()?;
    if token.is_none() && !h.addr.ip().to_canonical().is_loopback() {
        // The profile's validation refuses this; a plan built otherwise is refused here too.
        return Err(HttpError::Bind {
            addr: h.addr,
            source: std::io::Error::other("a non-loopback address needs [http] token_file"),
        });
    }
    let listener = std::net::TcpListener::bind(h.addr)
        .and_then(|l| l.set_nonblocking(true).map(|_| l))
        .map_err(|source| HttpError::Bind { addr: h.addr, source })?;
    Ok(Bound { listener, token })
}

/// Serves `[http]` on `bound` (from [`bind`]) until shutdown.
pub fn spawn(
    h: &HttpPlan,
    bound: Bound,
    fleet: Fleet,
    by_name: &HashMap<String, Arc<DeviceSlot>>,
    shutdown: watch::Receiver<bool>,
) -> Result<Vec<tokio::task::JoinHandle<()>>, HttpError> {
    let Bound { listener, token } = bound;
    let listener = TcpListener::from_std(listener).map_err(|source| HttpError::Bind { addr: h.addr, source })?;
    let local = listener.local_addr().unwrap_or(h.addr);
    // Commands only with a token (the plan says so; the token read is what counts).
    let commands = h.commands && token.is_some();
    let token_required = token.is_some();
    if local.ip().is_loopback() {
        tracing::info!(url = %format!("http://{local}/"), commands, token_required, "http: listening");
    } else {
        tracing::warn!(url = %format!("http://{local}/"), commands, token_required,
            "http: listening on a non-loopback address ([http] bind): the dashboard and /metrics are reachable from the network (token required; in clear without TLS in front)");
    }
    if h.commands_need_token || (h.commands && !commands) {
        tracing::warn!(
            "http: [http] commands = true but no [http] token_file: the dashboard accepts no command (docs/dashboard.md, \"Security\")"
        );
    }
    let fleet = Arc::new(fleet);
    let mut tasks = Vec::new();
    let (frames, _) = broadcast::channel::<Arc<str>>(FRAME_QUEUE);
    tasks.push(feed::spawn(
        fleet.clone(),
        h.sample_hz,
        frames.clone(),
        shutdown.clone(),
    ));
    let page = if commands {
        let (front, task) =
            web_front::spawn(&fleet, by_name, h.command_watchdog, shutdown.clone()).map_err(|e| HttpError::Bind {
                addr: local,
                source: std::io::Error::other(e.to_string()),
            })?;
        tasks.push(task);
        Some(Arc::new(front))
    } else {
        None
    };
    let server = Server {
        fleet,
        frames,
        page,
        sample_hz: h.sample_hz,
        allowed: host::Allowed {
            extra: h.allowed_hosts.clone(),
        },
        no_commands: if h.commands_need_token || (h.commands && !commands) {
            "the dashboard accepts no command: [http] commands = true needs [http] token_file (a token), and the profile names none"
        } else {
            "the dashboard accepts no command: set [http] commands = true (and [http] token_file) in the profile"
        },
        token,
        log: RateLimitedLog::default(),
        token_log: std::sync::Mutex::default(),
    };
    let server = Arc::new(server);
    let mut stop = shutdown.clone();
    tasks.push(tokio::spawn(async move {
        loop {
            tokio::select! {
                r = listener.accept() => match r {
                    Ok((stream, peer)) => {
                        let s = server.clone();
                        let sd = shutdown.clone();
                        tokio::spawn(async move {
                            if let Err(e) = s.connection(stream, peer, sd).await {
                                tracing::debug!(%peer, error = %e, "http: connection ended");
                            }
                        });
                    }
                    Err(e) => {
                        tracing::warn!(error = %e, "http: accept failed");
                        tokio::time::sleep(Duration::from_millis(100)).await;
                    }
                },
                _ = stop.changed() => break,
            }
        }
    }));
    Ok(tasks)
}

/// Frames queued per page before a slow page skips some.
const FRAME_QUEUE: usize = 256;

pub(crate) struct Server {
    fleet: Arc<Fleet>,
    frames: broadcast::Sender<Arc<str>>,
    page: Option<Arc<web_front::PageFront>>,
    sample_hz: f64,
    /// The names it answers to besides the built-in ones (`[http] allowed_hosts`).
    allowed: host::Allowed,
    /// Why a page's command is refused when the page's front is off.
    no_commands: &'static str,
    /// `[http] token_file`'s token: every request must present it.
    token: Option<token::Token>,
    /// Refused requests' log lines.
    log: RateLimitedLog,
    /// Requests refused for their token: log lines per peer address.
    token_log: std::sync::Mutex<token::PeerLog>,
}

/// One parsed request head.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Request {
    pub method: String,
    pub path: String,
    /// HTTP/1.`minor`.
    pub minor: u8,
    pub headers: Vec<(String, String)>,
}

impl Request {
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers_named(name).first().copied()
    }

    /// Every value of the header `name`, in order.
    pub fn headers_named(&self, name: &str) -> Vec<&str> {
        self.headers
            .iter()
            .filter(|(k, _)| k.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
            .collect()
    }

    /// Parses a complete request head (`None`: incomplete; `Err`: malformed).
    pub fn parse(buf: &[u8]) -> Result<Option<(Request, usize)>, String> {
        let mut headers = [httparse::EMPTY_HEADER; 48];
        let mut req = httparse::Request::new(&mut headers);
        match req.parse(buf) {
            Ok(httparse::Status::Complete(n)) => Ok(Some((
                Request {
                    method: req.method.unwrap_or("").to_string(),
                    path: req.path.unwrap_or("/").to_string(),
                    minor: req.version.unwrap_or(1),
                    headers: req
                        .headers
                        .iter()
                        .map(|h| (h.name.to_string(), String::from_utf8_lossy(h.value).into_owned()))
                        .collect(),
                },
                n,
            ))),
            Ok(httparse::Status::Partial) => Ok(None),
            Err(e) => Err(e.to_string()),
        }
    }
}

pub(crate) struct Response {
    pub status: u16,
    pub content_type: &'static str,
    pub body: Vec<u8>,
    /// Further header lines (`Name: value`).
    pub extra: Vec<String>,
}

impl Response {
    pub fn new(status: u16, content_type: &'static str, body: impl Into<Vec<u8>>) -> Self {
        Self {
            status,
            content_type,
            body: body.into(),
            extra: Vec::new(),
        }
    }

    pub fn header(mut self, line: String) -> Self {
        self.extra.push(line);
        self
    }

    pub fn text(status: u16, body: impl Into<String>) -> Self {
        Self::new(status, "text/plain; charset=utf-8", body.into().into_bytes())
    }

    fn head(&self) -> String {
        let reason = match self.status {
            200 => "OK",
            303 => "See Other",
            400 => "Bad Request",
            401 => "Unauthorized",
            403 => "Forbidden",
            404 => "Not Found",
            405 => "Method Not Allowed",
            421 => "Misdirected Request",
            431 => "Request Header Fields Too Large",
            503 => "Service Unavailable",
            _ => "Error",
        };
        let extra: String = self.extra.iter().map(|l| format!("{l}\r\n")).collect();
        format!(
            "HTTP/1.1 {} {reason}\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-store\r\n\
             X-Content-Type-Options: nosniff\r\n{extra}Connection: close\r\n\r\n",
            self.status,
            self.content_type,
            self.body.len()
        )
    }
}

impl Server {
    async fn connection(
        self: Arc<Self>,
        mut stream: TcpStream,
        peer: SocketAddr,
        shutdown: watch::Receiver<bool>,
    ) -> std::io::Result<()> {
        let _ = stream.set_nodelay(true);
        let mut buf = Vec::with_capacity(1024);
        let parsed = tokio::time::timeout(HEAD_TIMEOUT, async {
            loop {
                let mut chunk = [0u8; 1024];
                let n = stream.read(&mut chunk).await?;
                if n == 0 {
                    return Ok::<_, std::io::Error>(None);
                }
                buf.extend_from_slice(&chunk[..n]);
                match Request::parse(&buf) {
                    Ok(Some((r, _))) => return Ok(Some(Ok(r))),
                    Ok(None) if buf.len() > MAX_HEAD => return Ok(Some(Err(431))),
                    Ok(None) => continue,
                    Err(_) => return Ok(Some(Err(400))),
                }
            }
        })
        .await;
        let req = match parsed {
            Ok(Ok(Some(Ok(r)))) => r,
            Ok(Ok(Some(Err(code)))) => {
                return write(&mut stream, Response::text(code, "bad request\n"), false).await;
            }
            _ => return Ok(()),
        };
        // Whom the request is for, before anything else (DNS rebinding: host.rs).
        let local = stream
            .local_addr()
            .map(|a| a.ip())
            .unwrap_or(IpAddr::V4(Ipv4Addr::UNSPECIFIED));
        let hosts = req.headers_named("host");
        let host = match self.allowed.check(&hosts, req.minor == 0, local) {
            Ok(h) => h,
            Err(r) => return self.refuse(&mut stream, peer, r).await,
        };
        // Then who asks: the token, on every route (token.rs).
        if let Some(t) = &self.token {
            let auth = req.headers_named("authorization");
            let cookies = req.headers_named("cookie");
            match t.check(&req.path, &auth, &cookies) {
                token::Verdict::Pass => {}
                token::Verdict::SetCookie { clean, cookie } if req.method == "GET" || req.method == "HEAD" => {
                    // The page opened with `?token=`: the cookie, and the URL without the token.
                    let r = Response::text(303, "")
                        .header(format!("Location: {clean}"))
                        .header(format!("Set-Cookie: {cookie}"));
                    return write(&mut stream, r, false).await;
                }
                _ => return self.refuse_token(&mut stream, peer, &req).await,
            }
        }
        let head_only = req.method == "HEAD";
        if req.method != "GET" && !head_only {
            return write(&mut stream, Response::text(405, "only GET\n"), false).await;
        }
        let path = req.path.split('?').next().unwrap_or("/").to_string();
        if path == "/ws" {
            if let Err(r) = host::same_origin(req.header("origin"), host.as_ref()) {
                return self.refuse(&mut stream, peer, r).await;
            }
            let Some(key) = req.header("sec-websocket-key").map(str::to_string) else {
                return write(&mut stream, Response::text(400, "WebSocket upgrade expected\n"), false).await;
            };
            if self.fleet.clients.load(Ordering::Relaxed) >= MAX_CLIENTS {
                return write(&mut stream, Response::text(503, "too many dashboard clients\n"), false).await;
            }
            return ws::serve(self, stream, peer, &key, shutdown).await;
        }
        let resp = self.route(&path);
        write(&mut stream, resp, head_only).await
    }

    /// Answers a refused request with its status and reason; counted, and logged at most once
    /// a second per reason (with how many were not logged).
    async fn refuse(&self, stream: &mut TcpStream, peer: SocketAddr, r: host::Refusal) -> std::io::Result<()> {
        self.fleet.refused.count(&r);
        if let Some(suppressed) = self.log.admit(r.reason(), Instant::now()) {
            tracing::warn!(%peer, suppressed, "http: refused a request: {r}");
        }
        write(stream, Response::text(r.status(), format!("{r}\n")), false).await
    }

    /// Answers a request without the token: 401, nothing about the token in it but how to
    /// present one; counted, and logged at most once per [`token::LOG_EVERY`] per peer address.
    async fn refuse_token(&self, stream: &mut TcpStream, peer: SocketAddr, req: &Request) -> std::io::Result<()> {
        self.fleet.refused.token.fetch_add(1, Ordering::Relaxed);
        let logged = self
            .token_log
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .admit(peer.ip().to_canonical(), Instant::now());
        if let Some(suppressed) = logged {
            let path = req.path.split('?').next().unwrap_or("/");
            tracing::warn!(%peer, path, suppressed,
                "http: refused a request without the right token ([http] token_file; counted in handgate_http_refused_total{{reason=\"token\"}})");
        }
        let browser = req.header("accept").is_some_and(|a| a.contains("text/html"));
        let r = if browser {
            Response::new(401, "text/html; charset=utf-8", assets::LOGIN_PAGE)
        } else {
            Response::text(401, "unauthorized\n")
        };
        write(
            stream,
            r.header("WWW-Authenticate: Bearer realm=\"handgate\"".into()),
            false,
        )
        .await
    }

    fn route(&self, path: &str) -> Response {
        match path {
            "/metrics" => Response::new(
                200,
                "text/plain; version=0.0.4; charset=utf-8",
                metrics::render(&self.fleet, self.page.is_some()),
            ),
            "/healthz" => {
                let (ok, text) = metrics::health(&self.fleet, Instant::now());
                Response::text(if ok { 200 } else { 503 }, text)
            }
            "/api/hello" => Response::new(
                200,
                "application/json",
                feed::hello(&self.fleet, self.page.is_some(), self.sample_hz),
            ),
            "/api/status" => Response::new(200, "application/json", feed::status(&self.fleet)),
            "/api/fleet" | "/fleet" => match &self.fleet.lab {
                None => Response::text(404, "no fleet page: set [http] fleet_domains\n"),
                Some(lab) => {
                    let f = lab.borrow().clone();
                    if path == "/fleet" {
                        Response::new(200, "text/html; charset=utf-8", crate::fleet::page(&f))
                    } else {
                        Response::new(200, "application/json", serde_json::to_vec(&*f).unwrap_or_default())
                    }
                }
            },
            _ => match assets::get(path) {
                Some((ty, bytes)) => Response::new(200, ty, bytes.to_vec()),
                None => Response::text(404, "not found\n"),
            },
        }
    }
}

async fn write(stream: &mut TcpStream, r: Response, head_only: bool) -> std::io::Result<()> {
    stream.write_all(r.head().as_bytes()).await?;
    if !head_only {
        stream.write_all(&r.body).await?;
    }
    stream.shutdown().await
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn request_heads_parse_incomplete_and_malformed_ones_are_told_apart() {
        let (r, n) = Request::parse(b"GET /metrics HTTP/1.1\r\nHost: 127.0.0.1:8880\r\n\r\nrest")
            .unwrap()
            .unwrap();
        assert_eq!(
            (r.method.as_str(), r.path.as_str(), r.minor, n),
            ("GET", "/metrics", 1, 47)
        );
        assert_eq!(r.header("HOST"), Some("127.0.0.1:8880"));
        assert_eq!(Request::parse(b"GET /metrics HTTP/1.1\r\nHost: x").unwrap(), None);
        assert!(Request::parse(b"GET /\x01 HTTP/1.1\r\n\r\n").is_err());
    }

    #[test]
    fn every_host_header_is_seen_and_the_version_read() {
        let (r, _) = Request::parse(b"GET / HTTP/1.0\r\nHost: localhost\r\nhost: evil.example\r\n\r\n")
            .unwrap()
            .unwrap();
        assert_eq!(r.minor, 0);
        assert_eq!(r.headers_named("Host"), ["localhost", "evil.example"]);
        let (r, _) = Request::parse(b"GET / HTTP/1.0\r\n\r\n").unwrap().unwrap();
        assert_eq!((r.minor, r.header("host")), (0, None));
    }
}
