//! The dashboard's WebSocket (`/ws`): the RFC 6455 upgrade, then `hello`, the shared frames
//! and, when the profile allows it, the page's commands.

use std::net::SocketAddr;
use std::sync::atomic::Ordering;
use std::sync::Arc;

use futures_util::{SinkExt, StreamExt};
use serde_json::json;
use sha1::{Digest, Sha1};
use tokio::io::AsyncWriteExt;
use tokio::net::TcpStream;
use tokio::sync::{broadcast, watch};
use tokio_tungstenite::tungstenite::protocol::{Role, WebSocketConfig};
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::WebSocketStream;

use super::web_front::PageCommand;
use super::Server;

/// Largest frame a page may send, bytes (its commands are a few dozen).
const MAX_PAGE_FRAME: usize = 4096;

/// `Sec-WebSocket-Accept` for a client's `Sec-WebSocket-Key` (RFC 6455 §4.2.2).
pub fn accept_key(key: &str) -> String {
    let mut h = Sha1::new();
    h.update(key.trim().as_bytes());
    h.update(b"258EAFA5-E914-47DA-95CA-C5AB0DC85B11");
    base64(&h.finalize())
}

/// Standard base64 with padding.
fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
        for i in 0..4 {
            if i <= c.len() {
                out.push(A[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Completes the upgrade and serves one page until it leaves or the gateway stops.
pub(super) async fn serve(
    server: Arc<Server>,
    mut stream: TcpStream,
    peer: SocketAddr,
    key: &str,
    mut shutdown: watch::Receiver<bool>,
) -> std::io::Result<()> {
    let head = format!(
        "HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Accept: {}\r\n\r\n",
        accept_key(key)
    );
    stream.write_all(head.as_bytes()).await?;
    let config = WebSocketConfig::default()
        .max_message_size(Some(MAX_PAGE_FRAME))
        .max_frame_size(Some(MAX_PAGE_FRAME));
    let mut ws = WebSocketStream::from_raw_socket(stream, Role::Server, Some(config)).await;
    let fleet = &server.fleet;
    fleet.clients.fetch_add(1, Ordering::Relaxed);
    let _guard = ClientGuard(server.clone());
    let mut frames = server.frames.subscribe();
    tracing::info!(%peer, "dashboard page connected");
    let hello = super::feed::hello(fleet, server.page.is_some(), server.sample_hz);
    let first = [hello, super::feed::status(fleet)];
    for f in first {
        ws.send(Message::text(f)).await.map_err(std::io::Error::other)?;
    }
    let conn = super::web_front::next_connection_id();
    loop {
        tokio::select! {
            f = frames.recv() => match f {
                Ok(f) => ws.send(Message::text(f.to_string())).await.map_err(std::io::Error::other)?,
                // A slow page skips frames; it never holds the others back.
                Err(broadcast::error::RecvError::Lagged(_)) => continue,
                Err(broadcast::error::RecvError::Closed) => break,
            },
            m = ws.next() => match m {
                Some(Ok(Message::Text(t))) => {
                    if let Some(reply) = command(&server, conn, peer, t.as_str()) {
                        ws.send(Message::text(reply)).await.map_err(std::io::Error::other)?;
                    }
                }
                Some(Ok(Message::Close(_))) | None => break,
                Some(Ok(_)) => {}
                Some(Err(e)) => return Err(std::io::Error::other(e)),
            },
            _ = shutdown.changed() => {
                let _ = ws.close(None).await;
                break;
            }
        }
    }
    tracing::info!(%peer, "dashboard page left");
    Ok(())
}

struct ClientGuard(Arc<Server>);

impl Drop for ClientGuard {
    fn drop(&mut self) {
        self.0.fleet.clients.fetch_sub(1, Ordering::Relaxed);
    }
}

/// A page's frame: a command handed to the page's front, or the reason it is refused.
fn command(server: &Server, conn: u64, peer: SocketAddr, text: &str) -> Option<String> {
    let parsed = PageCommand::parse(text);
    let device = parsed.as_ref().map(|c| c.device().to_string()).unwrap_or_default();
    let refused = |reason: String| Some(json!({"type": "refused", "device": device, "reason": reason}).to_string());
    let cmd = match parsed {
        Ok(c) => c,
        Err(e) => return refused(e),
    };
    let Some(front) = &server.page else {
        return refused(server.no_commands.into());
    };
    match front.submit(conn, peer, cmd) {
        Ok(()) => None,
        Err(reason) => refused(reason),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accept_key_matches_rfc_6455s_example() {
        assert_eq!(accept_key("dGhlIHNhbXBsZSBub25jZQ=="), "s3pPLMBiTxaQ9kYGzzhZRbK+xOo=");
    }

    #[test]
    fn base64_pads_every_length() {
        assert_eq!(base64(b""), "");
        assert_eq!(base64(b"f"), "Zg==");
        assert_eq!(base64(b"fo"), "Zm8=");
        assert_eq!(base64(b"foo"), "Zm9v");
        assert_eq!(base64(b"foobar"), "Zm9vYmFy");
    }
}
