//! The live view of a launch (`orchestrator launch --serve ADDR`): the run's
//! scene over the Foxglove WebSocket protocol, and a self-contained page that
//! draws it in a browser, both on one port.
//!
//! Why this shape:
//!
//! * **The Foxglove SDK serves the stream.** `foxglove::WebSocketServer`
//!   speaks the protocol Foxglove's app speaks (`foxglove.sdk.v1`), with
//!   per-client queues that drop the oldest message for a slow client, so a
//!   stalled browser never stalls the launch: logging a message only
//!   enqueues it.
//! * **A small front owns the public port.** The SDK's server binds and
//!   accepts on its own listener and answers every request with a WebSocket
//!   handshake — it cannot serve a page. So [`front`] (tokio) listens on
//!   ADDR, reads each request's head, serves `GET /` itself (the page is a
//!   string compiled into the binary: no install, no internet) and
//!   byte-proxies WebSocket upgrades, head included, to the SDK server on an
//!   internal loopback port. Proxying bytes (rather than re-implementing the
//!   protocol) keeps one implementation of the stream; the cost is one
//!   loopback hop and the SDK seeing every client as 127.0.0.1.
//! * **The scene is [`bycoms_record::scene`]'s**, the very messages the recording's
//!   decoded channels hold (SceneUpdate, FrameTransforms, Log, JSON), so a
//!   lab sees the same thing live in Foxglove and later in the file.
//! * **The page speaks the same protocol.** It connects to the same port as
//!   a Foxglove client would and subscribes to JSON channels of
//!   [`channels`], so the browser and the Foxglove app watch one live
//!   stream. A viewer that connects late gets the world and the current
//!   state (robots, trails, beacons, the gate) as soon as it subscribes.
//! * **Its own tokio runtime.** The launch loop is synchronous; the view
//!   runs on two worker threads of its own, stopped when the launch ends.
//! * **Above the launch.** The view reads the launch's world, config and
//!   summary; the launch knows it only by its seam
//!   (`launch::observe::View`), started by [`serve`], which
//!   `orchestrator launch` hands to `launch::run_serving`
//!   (ARCHITECTURE.md, "Crates of the orchestrator").

mod channels;
mod front;
pub mod state;
#[cfg(test)]
mod tests;

pub use channels::{state_topic, world_topic};

use bycoms_launch::observe::{Observer, View};
use bycoms_launch::{LaunchConfig, Summary, World};
use bycoms_record::scene::{Out, SharedScene};
use channels::Channels;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// How long the view keeps serving after the end when viewers are
/// connected: the SDK's stop drops what is still queued for a client, and
/// the last state (the verdict) is the one message a viewer must get.
pub const FINAL_DRAIN: Duration = Duration::from_millis(500);

/// Why the live view could not start.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    /// The tokio runtime could not be built.
    #[error("cannot start the live view's threads: {0}")]
    Runtime(#[source] std::io::Error),
    /// ADDR could not be bound.
    #[error("cannot listen on {addr:?} for the live view: {source}")]
    Bind {
        /// The address asked for.
        addr: String,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The Foxglove server could not start.
    #[error("cannot start the Foxglove WebSocket server: {0}")]
    Foxglove(#[from] foxglove::FoxgloveError),
}

/// A running live view; clones share it. Ends with [`LiveView::shutdown`]
/// (or when the last clone is dropped).
#[derive(Clone)]
pub struct LiveView {
    inner: Arc<Inner>,
}

struct Inner {
    addr: SocketAddr,
    /// The channels' context: dropping it closes every channel.
    _context: Arc<foxglove::Context>,
    channels: Arc<Channels>,
    server: Mutex<Option<foxglove::WebSocketServerHandle>>,
    runtime: Mutex<Option<tokio::runtime::Runtime>>,
}

impl LiveView {
    /// Starts serving on `addr` (`host:port`; port 0 picks a free port, see
    /// [`LiveView::local_addr`]).
    pub fn start(addr: &str) -> Result<Self, LiveError> {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("live-view")
            .enable_all()
            .build()
            .map_err(LiveError::Runtime)?;
        let context = foxglove::Context::new();
        let channels = Arc::new(Channels::new(&context));
        let (listener, server) = runtime.block_on(async {
            let listener = tokio::net::TcpListener::bind(addr)
                .await
                .map_err(|source| LiveError::Bind { addr: addr.to_string(), source })?;
            let server = context
                .websocket_server()
                .name("bycoms live view")
                .bind("127.0.0.1", 0)
                .listener(Arc::clone(&channels) as Arc<dyn foxglove::websocket::ServerListener>)
                .start()
                .await?;
            Ok::<_, LiveError>((listener, server))
        })?;
        let bound =
            listener.local_addr().map_err(|source| LiveError::Bind { addr: addr.to_string(), source })?;
        let backend = SocketAddr::from(([127, 0, 0, 1], server.port()));
        runtime.spawn(front::serve(listener, backend));
        tracing::debug!(%bound, %backend, "live view started");
        Ok(Self {
            inner: Arc::new(Inner {
                addr: bound,
                _context: context,
                channels,
                server: Mutex::new(Some(server)),
                runtime: Mutex::new(Some(runtime)),
            }),
        })
    }

    /// The address actually bound (the port chosen when 0 was asked for).
    pub fn local_addr(&self) -> SocketAddr {
        self.inner.addr
    }

    /// Where a person points a browser or Foxglove, in one line.
    pub fn banner(&self) -> String {
        let a = self.local_addr();
        format!("live view: http://{a}/ in a browser, or ws://{a} in Foxglove (Open connection)")
    }

    /// The run ended: the page shows the verdict.
    pub fn ended(&self, summary: &Summary) {
        self.inner.channels.ended(summary.success, &summary.line());
    }

    /// Stops serving: lets queued messages go out ([`FINAL_DRAIN`] when
    /// viewers are connected), closes every connection (waiting up to a
    /// second) and ends the view's threads.
    pub fn shutdown(self) {
        let server = self.inner.server.lock().ok().and_then(|mut s| s.take());
        let runtime = self.inner.runtime.lock().ok().and_then(|mut r| r.take());
        let Some(runtime) = runtime else { return };
        if let Some(server) = server {
            if server.client_count() > 0 {
                std::thread::sleep(FINAL_DRAIN);
            }
            let stopping = server.stop();
            runtime.block_on(async {
                if tokio::time::timeout(Duration::from_secs(1), stopping.wait()).await.is_err() {
                    tracing::debug!("live view clients did not close within 1 s");
                }
            });
        }
        runtime.shutdown_timeout(Duration::from_millis(500));
    }
}

impl Observer for LiveView {
    fn world(&mut self, swarm: &str, world: &World, cfg: &LaunchConfig, scene: Option<&SharedScene>) {
        self.inner.channels.world(swarm, world, cfg, scene);
    }

    fn scene(&mut self, outs: &[Out]) {
        self.inner.channels.scene(outs);
    }
}

/// Starts the live view on `addr`, behind the launch's seam.
pub fn serve(addr: &str) -> anyhow::Result<Box<dyn View>> {
    Ok(Box::new(LiveView::start(addr)?))
}

impl View for LiveView {
    fn banner(&self) -> String {
        LiveView::banner(self)
    }

    fn observer(&self) -> Box<dyn Observer> {
        Box::new(self.clone())
    }

    fn end(self: Box<Self>, summary: &Summary) {
        self.ended(summary);
        (*self).shutdown();
    }
}
