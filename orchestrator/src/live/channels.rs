//! The live view's Foxglove channels, and what a viewer gets when it
//! subscribes.
//!
//! Two kinds of channel, all under `bycoms/<swarm>/`:
//!
//! * **The scene** — exactly what the recording's decoded channels carry
//!   ([`bycoms_record::scene`]: `scene` SceneUpdate, `tf`, `log`, `gate/json`,
//!   `beacon/json`, `robot/<k>/state`, `robot/<k>/pose/json`,
//!   `robot/<k>/mode`, `robot/<k>/telemetry`), one
//!   SDK channel per topic, created when its first message comes. Foxglove's
//!   3D, Log, Plot and Raw Messages panels show them as they are.
//! * **The page's two** — `live/world` (terrain rows, start, goal, ε) and
//!   `live/state` ([`LiveState`]: robots, trails, beacons, the gate, the
//!   verdict), JSON with JSON schemas, because a self-contained page cannot
//!   ship a protobuf decoder for the SceneUpdate. The page also reads the
//!   scene's `gate/json` and `robot/<k>/pose/json`: one live stream for both.
//!   `live/state`'s robot states are the scene's `robot/<k>/state`, as the
//!   launch core said them.
//!
//! Why "latched" by hand: the protocol has no history, so on every
//! subscription to `live/world`, `live/state` or `scene` the current value
//! (for `scene`: [`Scene::snapshot`]) is sent to that subscriber only
//! (`log_to_sink`); the SDK registers the subscription before it calls the
//! listener, so nothing falls between the two.

use super::state::{LiveState, WorldView};
use bycoms_launch::recording::now_ns;
use bycoms_launch::{LaunchConfig, World};
use bycoms_record::scene::json::json_schema;
use bycoms_record::scene::{Out, SharedScene};
use bycoms_record::schema;
use foxglove::websocket::{ChannelView, Client, ServerListener};
use foxglove::{Context, RawChannel, Schema, SinkId};
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, MutexGuard};

/// The page's topic of the world, for swarm `swarm`.
pub fn world_topic(swarm: &str) -> String {
    format!("bycoms/{swarm}/live/world")
}

/// The page's topic of the whole state, for swarm `swarm`.
pub fn state_topic(swarm: &str) -> String {
    format!("bycoms/{swarm}/live/state")
}

/// The channels and the state behind them.
pub struct Channels {
    context: Arc<Context>,
    inner: Mutex<Inner>,
}

#[derive(Default)]
struct Inner {
    channels: BTreeMap<String, Arc<RawChannel>>,
    /// Set by [`Channels::world`]; nothing is sent before.
    run: Option<Run>,
    state: LiveState,
}

struct Run {
    world_topic: String,
    state_topic: String,
    world: Vec<u8>,
    /// The run's scene (fed by the launch), for snapshots to late viewers.
    scene: Option<SharedScene>,
}

fn to_json<T: Serialize>(value: &T) -> Option<Vec<u8>> {
    serde_json::to_vec(value).map_err(|e| tracing::warn!("live view: a message did not serialise: {e}")).ok()
}

impl Inner {
    /// The channel of `topic`, created with `schema` on first use.
    fn channel(
        &mut self,
        context: &Arc<Context>,
        topic: &str,
        encoding: &str,
        schema: Option<Schema>,
    ) -> Option<Arc<RawChannel>> {
        if let Some(c) = self.channels.get(topic) {
            return Some(Arc::clone(c));
        }
        let built = context.channel_builder(topic).message_encoding(encoding).schema(schema).build_raw();
        match built {
            Ok(c) => {
                self.channels.insert(topic.to_owned(), Arc::clone(&c));
                Some(c)
            }
            Err(e) => {
                tracing::warn!("live view: no channel {topic}: {e}");
                None
            }
        }
    }

    /// Sends scene messages (to `sink` only, or to every subscriber).
    fn send_scene(&mut self, context: &Arc<Context>, outs: Vec<Out>, sink: Option<SinkId>) {
        for out in outs {
            let Some(channel) =
                self.channel(context, &out.topic, &out.message.encoding(), out.message.schema())
            else {
                continue;
            };
            if !channel.has_sinks() {
                continue;
            }
            match out.message.encode() {
                Ok(bytes) => channel.log_to_sink(&bytes, sink),
                Err(e) => tracing::warn!("live view: {e}"),
            }
        }
    }

    fn send_state(&mut self, context: &Arc<Context>, sink: Option<SinkId>) {
        let Some(topic) = self.run.as_ref().map(|r| r.state_topic.clone()) else { return };
        let schema = Schema::new(schema::LIVE_STATE, "jsonschema", json_schema::<LiveState>());
        let (Some(channel), Some(bytes)) =
            (self.channel(context, &topic, "json", Some(schema)), to_json(&self.state))
        else {
            return;
        };
        channel.log_to_sink(&bytes, sink);
    }
}

impl Channels {
    /// No channel yet: they come with the world.
    pub fn new(context: &Arc<Context>) -> Self {
        Self { context: Arc::clone(context), inner: Mutex::new(Inner::default()) }
    }

    fn inner(&self) -> MutexGuard<'_, Inner> {
        // A panic while holding the lock leaves plain data: keep using it.
        self.inner.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// The run's world: opens the page's channels; `scene` is the run's
    /// scene, whose output comes through [`Channels::scene`].
    pub fn world(&self, swarm: &str, world: &World, cfg: &LaunchConfig, scene: Option<&SharedScene>) {
        let Some(bytes) = to_json(&WorldView::new(world, cfg)) else { return };
        let scene = scene.cloned();
        let mut inner = self.inner();
        let run =
            Run { world_topic: world_topic(swarm), state_topic: state_topic(swarm), world: bytes, scene };
        let schema = Schema::new(schema::LIVE_WORLD, "jsonschema", json_schema::<WorldView>());
        if let Some(channel) = inner.channel(&self.context, &run.world_topic, "json", Some(schema)) {
            channel.log(&run.world);
        }
        inner.run = Some(run);
        inner.send_state(&self.context, None);
    }

    /// What the run's scene produced (the world, poses, reports, gate
    /// events), to every subscriber; the page's state is folded from the
    /// same messages, and sent after every gate decision among them.
    pub fn scene(&self, outs: &[Out]) {
        let mut inner = self.inner();
        let decided = inner.state.take(outs);
        inner.send_scene(&self.context, outs.to_vec(), None);
        if decided {
            inner.send_state(&self.context, None);
        }
    }

    /// The run ended.
    pub fn ended(&self, success: bool, verdict: &str) {
        let mut inner = self.inner();
        inner.state.ended(success, verdict);
        inner.send_state(&self.context, None);
    }
}

impl ServerListener for Channels {
    fn on_subscribe(&self, client: Client, channel: ChannelView) {
        let Some(sink) = client.sink_id() else { return };
        let topic = channel.topic();
        let mut inner = self.inner();
        let Some(run) = inner.run.as_ref() else { return };
        if topic == run.world_topic {
            if let Some(c) = inner.channels.get(topic) {
                c.log_to_sink(&run.world, Some(sink));
            }
        } else if topic == run.state_topic {
            inner.send_state(&self.context, Some(sink));
        } else if let Some(scene) = run.scene.clone() {
            let scene = scene.lock();
            if scene.topics().scene() == topic {
                let outs = scene.snapshot(now_ns()).into_iter().filter(|o| o.topic == topic).collect();
                drop(scene);
                inner.send_scene(&self.context, outs, Some(sink));
            }
        }
    }
}
