//! The public port of the live view: serves the page, hands WebSocket
//! upgrades to the Foxglove SDK's server (see the module doc of
//! [`super`] for why a front at all).
//!
//! Per connection: read the request head (at most [`MAX_HEAD`] bytes, within
//! [`HEAD_TIMEOUT`]), parse it with `httparse`; an `Upgrade: websocket`
//! request is forwarded byte for byte — the head already read, then both
//! directions until either side closes — to the SDK server on loopback;
//! `GET /` gets the page; anything else a short error. One request per
//! connection (`Connection: close`): the page is one response.
//!
//! Subprotocols: the SDK's server negotiates only [`SUBPROTOCOLS`]
//! (`foxglove.sdk.v1`, `foxglove.sdk.v1.1`). Older clients offer only
//! `foxglove.websocket.v1`, the former name of the protocol; the SDK
//! refuses them, and so does this front, but with a 400 that says which
//! subprotocols are served (the SDK's own 400 says only "missing expected
//! sec-websocket-protocol header"). Why not rename on the fly: Foxglove
//! keeps the two names apart on purpose (the same protocol today, not
//! promised to stay so), and a view that half works is worse than a clear
//! refusal. Each accepted viewer is logged here, with its real address
//! (the SDK sees every client as 127.0.0.1).

use std::net::SocketAddr;
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};

/// The page, compiled in.
pub const PAGE: &str = include_str!("page.html");

/// Longest request head accepted.
pub const MAX_HEAD: usize = 16 * 1024;
/// A client must send its request head within this long.
pub const HEAD_TIMEOUT: Duration = Duration::from_secs(10);

/// The WebSocket subprotocols the SDK's server negotiates (foxglove 0.30:
/// `websocket::handshake`).
pub const SUBPROTOCOLS: [&str; 2] = ["foxglove.sdk.v1", "foxglove.sdk.v1.1"];

/// The body of the refusal of an upgrade that offers none of [`SUBPROTOCOLS`].
pub const REFUSAL: &str = "this live view speaks the Foxglove WebSocket subprotocol foxglove.sdk.v1 or \
                           foxglove.sdk.v1.1; the client offered neither (foxglove.websocket.v1, the \
                           older name, is not served): use a current Foxglove app or the page at /\n";

/// Accepts connections on `listener` until the runtime ends.
pub async fn serve(listener: TcpListener, backend: SocketAddr) {
    loop {
        match listener.accept().await {
            Ok((stream, peer)) => {
                tokio::spawn(async move {
                    if let Err(e) = connection(stream, peer, backend).await {
                        tracing::debug!(%peer, "live view connection ended: {e}");
                    }
                });
            }
            Err(e) => {
                // Out of descriptors and the like: wait rather than spin.
                tracing::warn!("live view: accept failed: {e}");
                tokio::time::sleep(Duration::from_millis(100)).await;
            }
        }
    }
}

/// What a request head asks for.
#[derive(Debug, PartialEq, Eq)]
pub enum Request {
    /// A WebSocket upgrade offering one of [`SUBPROTOCOLS`]: forward to the SDK server.
    Upgrade,
    /// A WebSocket upgrade offering none of [`SUBPROTOCOLS`].
    NoSubprotocol,
    /// The page (`GET /` or `HEAD /`; `head_only` for HEAD).
    Page { head_only: bool },
    /// A path we do not serve.
    NotFound,
    /// A method other than GET and HEAD.
    BadMethod,
}

/// Classifies a complete request head; `None` while it is incomplete, an
/// error when it is not HTTP.
pub fn classify(head: &[u8]) -> Result<Option<Request>, httparse::Error> {
    let mut headers = [httparse::EMPTY_HEADER; 64];
    let mut req = httparse::Request::new(&mut headers);
    if req.parse(head)?.is_partial() {
        return Ok(None);
    }
    let upgrade = req
        .headers
        .iter()
        .any(|h| h.name.eq_ignore_ascii_case("upgrade") && h.value.eq_ignore_ascii_case(b"websocket"));
    let served = req
        .headers
        .iter()
        .filter(|h| h.name.eq_ignore_ascii_case("sec-websocket-protocol"))
        .flat_map(|h| std::str::from_utf8(h.value).unwrap_or_default().split(','))
        .any(|p| SUBPROTOCOLS.contains(&p.trim()));
    let method = req.method.unwrap_or_default();
    let path = req.path.unwrap_or_default().split('?').next().unwrap_or_default();
    Ok(Some(match (method, path) {
        _ if upgrade && served => Request::Upgrade,
        _ if upgrade => Request::NoSubprotocol,
        ("GET" | "HEAD", "/" | "/index.html") => Request::Page { head_only: method == "HEAD" },
        ("GET" | "HEAD", _) => Request::NotFound,
        _ => Request::BadMethod,
    }))
}

async fn connection(mut stream: TcpStream, peer: SocketAddr, backend: SocketAddr) -> std::io::Result<()> {
    let mut head = Vec::with_capacity(1024);
    let request = tokio::time::timeout(HEAD_TIMEOUT, read_head(&mut stream, &mut head))
        .await
        .map_err(|_| std::io::Error::new(std::io::ErrorKind::TimedOut, "no request head in time"))??;
    match request {
        Some(Request::Upgrade) => {
            tracing::info!(%peer, "live view: a viewer connected");
            let mut sdk = TcpStream::connect(backend).await?;
            sdk.write_all(&head).await?;
            tokio::io::copy_bidirectional(&mut stream, &mut sdk).await?;
            Ok(())
        }
        Some(Request::Page { head_only }) => {
            let body = if head_only { "" } else { PAGE };
            respond(&mut stream, "200 OK", "text/html; charset=utf-8", PAGE.len(), body).await
        }
        Some(Request::NoSubprotocol) => {
            tracing::info!(%peer, "live view: refused a WebSocket client that offers no foxglove.sdk.v1");
            respond(&mut stream, "400 Bad Request", "text/plain", REFUSAL.len(), REFUSAL).await
        }
        Some(Request::NotFound) => {
            respond(&mut stream, "404 Not Found", "text/plain", 10, "not found\n").await
        }
        Some(Request::BadMethod) => {
            respond(&mut stream, "405 Method Not Allowed", "text/plain", 19, "method not allowed\n").await
        }
        None => respond(&mut stream, "400 Bad Request", "text/plain", 12, "bad request\n").await,
    }
}

/// Reads until the head is complete; `None` when it is not HTTP or too long.
async fn read_head(stream: &mut TcpStream, head: &mut Vec<u8>) -> std::io::Result<Option<Request>> {
    let mut chunk = [0u8; 2048];
    loop {
        let n = stream.read(&mut chunk).await?;
        if n == 0 {
            return Err(std::io::Error::new(std::io::ErrorKind::UnexpectedEof, "closed before a request"));
        }
        head.extend_from_slice(&chunk[..n]);
        match classify(head) {
            Ok(Some(request)) => return Ok(Some(request)),
            Ok(None) if head.len() < MAX_HEAD => {}
            Ok(None) | Err(_) => return Ok(None),
        }
    }
}

async fn respond(
    stream: &mut TcpStream,
    status: &str,
    content_type: &str,
    length: usize,
    body: &str,
) -> std::io::Result<()> {
    let head = format!(
        "HTTP/1.1 {status}\r\nContent-Type: {content_type}\r\nContent-Length: {length}\r\n\
         Cache-Control: no-store\r\nConnection: close\r\n\r\n"
    );
    stream.write_all(head.as_bytes()).await?;
    stream.write_all(body.as_bytes()).await?;
    stream.shutdown().await
}
