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

use std::net::SocketAddr;
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};

/// Longest request head accepted.
pub const MAX_HEAD: usize = 16 * 1024;
/// A client must send its request head within this long.
pub const HEAD_TIMEOUT: Duration = Duration::from_secs(10);

/// Accepts connections on `listener` until the runtime ends.
pub async fn serve(listener: TcpListener, backend: SocketAddr) {
    loop {
        match listener.accept().await {
            Ok((stream, peer)) => {
                tokio::spawn(async move {
                    if let Err(e) = connection(stream, backend).await {
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
    /// A WebSocket upgrade: forward to the SDK server.
    Upgrade,
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
    let method = req.method.unwrap_or_default();
    let path = req.path.unwrap_or_default().split('?').next().unwrap_or_default();
    Ok(Some(match (method, path) {
        _ if upgrade => Request::Upgrade,
        ("GET" | "HEAD", "/" | "/index.html") => Request::Page { head_only: method == "HEAD" },
        ("GET" | "HEAD", _) => Request::NotFound,
        _ => Request::BadMethod,
    }))
}

async fn connection(mut stream: TcpStream, backend: SocketAddr) -> std::io::Result<()> {
    let mut head = Vec::with_capacity(1024);
    let request = tokio::time::timeout(HEAD_TIMEOUT, read_head(&mut stream, &mut head))
        .await
        .map_err(|_| std::io::Error::new(std::io::ErrorKind::TimedOut, "no request head in time"))??;
    match request {
        Some(Request::Upgrade) => {
            let mut sdk = TcpStream::connect(backend).await?;
            sdk.write_all(&head).await?;
            tokio::io::copy_bidirectional(&mut stream, &mut sdk).await?;
            Ok(())
        }
        Some(Request::Page { head_only }) => {
            let body = if head_only { "" } else { super::PAGE };
            respond(&mut stream, "200 OK", "text/html; charset=utf-8", super::PAGE.len(), body).await
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
