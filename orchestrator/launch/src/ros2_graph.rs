//! The launch's way into a ROS 2 graph: which zenoh session, and whether
//! a graph is really there (issue 32: "a wrong mode must be detected and
//! reported, never silent").
//!
//! Why a session choice: rmw_zenoh's router (`rmw_zenohd`) does not
//! forward between peers, it only introduces them; a process that is not
//! a ROS node reaches the graph reliably as a zenoh *client* of that
//! router, which routes its samples both ways. So with `[ros2] router =
//! "tcp/HOST:7447"` (`--ros2-router`) the launch opens its own client
//! session to the lab's `rmw_zenohd` for everything ROS 2 (publishing,
//! the ROS 2 mocap source); without it the launch's own zenoh session (a
//! router listening on `transport.listen`) is the graph's router, and the
//! lab's nodes (or their `rmw_zenohd`) connect to it.
//!
//! What goes wrong silently otherwise, and how it is said here:
//! * no router at the endpoint: the client session cannot open, the launch
//!   ends before anything starts, naming the endpoint and `rmw_zenohd`;
//! * a router that answers but is not the graph's (another domain, a plain
//!   zenohd the ROS nodes do not use, nodes still on DDS): no `@ros2_lv`
//!   token of another session → a warning at open, naming the domain and
//!   what to check;
//! * a mocap topic nobody publishes, or published with another type or
//!   type hash (samples on another key are never seen): [`GraphWatch`]
//!   warns once, after `mocap.ros2.graph_timeout`, per topic.
//!
//! What is not said, and why (issue 51): rmw_zenoh's router config sets
//! `routing.router.peers_failover_brokering: false`, so the router does
//! not carry data between two *peers* (rmw_zenoh #929: a zenoh tool in peer
//! mode sees no ROS 2 topic). It cannot hide ours: the launch is a
//! *client* of the lab's router (`ros2.router`), which a router always
//! routes for, or a *router* itself. And the launch cannot learn the
//! setting anyway: zenoh 1.10's admin space (`@/<zid>/router`, answered
//! only by a router with `adminspace.enabled`, off by default) tells the
//! router's id, version, metadata, locators and sessions but not its
//! configuration (`@/<zid>/router/config/**` takes only puts, with write
//! permission), and zenoh 1.9 and later ignore the setting (deprecated, "no
//! effect"). The test `a_routers_admin_space_does_not_tell_its_failover_brokering`
//! pins both facts against a router with the setting off.

use super::agents::ros2_robots::Graph;
use super::ros2::Ros2Config;
use bycoms_protocol::bus::zenoh::{Mode, ZenohBus};
use bycoms_ros2::rmw_zenoh::{graph_key_expr, EntityKind, TokenView};
use std::collections::BTreeMap;
use std::time::Duration;
use zenoh::Wait;

/// How long the graph is asked for its tokens when the session opens.
const GRAPH_QUERY: Duration = Duration::from_secs(2);

/// A launch's ROS 2 settings (its `[ros2]` table, or the defaults) and
/// session, when it publishes (`[ros2]`) or reads its poses from ROS 2
/// (`mocap.source = "ros2"`); no session otherwise.
pub fn for_launch(
    cfg: &super::LaunchConfig,
    launch: Option<&ZenohBus>,
) -> anyhow::Result<(Ros2Config, Option<zenoh::Session>)> {
    let settings = cfg.ros2.clone().unwrap_or_default();
    let wanted = cfg.ros2.is_some() || cfg.mocap.source == bycoms_mocap::MocapSource::Ros2;
    let session = if wanted { session(&settings, launch)? } else { None };
    Ok((settings, session))
}

/// Where ROS 2 robots' agents join the graph: the lab's router
/// (`ros2.router`), else the launch's own zenoh endpoint (`endpoints`, its
/// listen endpoints as reachable); `None` without either.
pub fn for_agents(cfg: &Ros2Config, endpoints: &[String]) -> Option<Graph> {
    let router = cfg.router.clone().or_else(|| endpoints.first().cloned())?;
    Some(Graph { router, domain_id: cfg.domain_id, namespace: cfg.namespace.clone() })
}

/// The zenoh session ROS 2 traffic goes over: a client session to
/// `cfg.router` when it is set, else the launch's own (`launch`, if it runs
/// zenoh); `None` when neither exists (refused earlier by the config check).
pub fn session(cfg: &Ros2Config, launch: Option<&ZenohBus>) -> anyhow::Result<Option<zenoh::Session>> {
    let Some(router) = &cfg.router else {
        return Ok(launch.map(|z| z.session().clone()));
    };
    let config = bycoms_runtime::zenoh_config(Mode::Client, Vec::new(), vec![router.clone()], None);
    let bus = ZenohBus::open(config).map_err(|e| {
        anyhow::anyhow!(
            "ros2: no zenoh router answers at {router} (ros2.router, --ros2-router): {e}. \
             Start the lab's router (`ros2 run rmw_zenoh_cpp rmw_zenohd`) or give its endpoint"
        )
    })?;
    let session = bus.session().clone();
    tracing::info!(%router, zid = %session.zid(), "ros2: connected to the ROS 2 router as a zenoh client");
    let others = graph_members(&session, cfg.domain_id);
    if others == 0 {
        tracing::warn!(
            %router,
            domain_id = cfg.domain_id,
            "ros2: the router at {router} answers but no ROS 2 node of domain {} is in its graph (no \
             @ros2_lv token): is ROS_DOMAIN_ID {} on the lab's nodes, do they run rmw_zenoh \
             (RMW_IMPLEMENTATION=rmw_zenoh_cpp) and is this their rmw_zenohd?",
            cfg.domain_id,
            cfg.domain_id
        );
    } else {
        tracing::info!(tokens = others, "ros2: the ROS 2 graph is there");
    }
    Ok(Some(session))
}

/// Tokens of the domain's graph held by other sessions right now.
fn graph_members(session: &zenoh::Session, domain_id: u32) -> usize {
    let own = session.zid().to_string();
    let Ok(replies) = session.liveliness().get(graph_key_expr(domain_id)).timeout(GRAPH_QUERY).wait() else {
        return 0;
    };
    let mut n = 0;
    while let Ok(reply) = replies.recv() {
        let foreign = reply.result().ok().and_then(|s| TokenView::parse(s.key_expr().as_str()));
        n += usize::from(foreign.is_some_and(|t| t.zid != own));
    }
    n
}

/// One topic the launch subscribes to and needs a publisher of.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Wanted {
    /// The topic (`/vrpn_mocap/robot1/pose`).
    pub topic: String,
    /// Its DDS type name (`geometry_msgs::msg::dds_::PoseStamped_`).
    pub dds_type: String,
    /// Its type hash.
    pub type_hash: String,
}

/// Whether the topics the launch reads have publishers in the graph,
/// sans-IO: tokens in (as the liveliness subscriber sees them come and
/// go), warnings out once the timeout has passed (each said once).
#[derive(Debug)]
pub struct GraphWatch {
    domain_id: u32,
    own_zid: String,
    wanted: Vec<Wanted>,
    timeout: Duration,
    /// Alive publisher tokens of other sessions: token → what it says.
    publishers: BTreeMap<String, TokenView>,
    /// Any token of another session seen at all.
    graph_seen: bool,
    checked: bool,
}

impl GraphWatch {
    /// Watches for publishers of `wanted` in `domain_id`, ignoring the
    /// tokens of the session `own_zid` (the launch's own).
    pub fn new(domain_id: u32, own_zid: String, wanted: Vec<Wanted>, timeout: Duration) -> Self {
        Self {
            domain_id,
            own_zid,
            wanted,
            timeout,
            publishers: BTreeMap::new(),
            graph_seen: false,
            checked: false,
        }
    }

    /// A token appeared (`alive`) or went.
    pub fn token(&mut self, key: &str, alive: bool) {
        let Some(view) = TokenView::parse(key) else { return };
        if view.zid == self.own_zid || view.domain_id != self.domain_id {
            return;
        }
        self.graph_seen = true;
        if view.kind != EntityKind::Publisher {
            return;
        }
        if alive {
            self.publishers.insert(key.to_string(), view);
        } else {
            self.publishers.remove(key);
        }
    }

    /// What is wrong `elapsed` after the watch began: nothing before the
    /// timeout, then (once) a warning per wanted topic without a matching
    /// publisher, saying why.
    pub fn check(&mut self, elapsed: Duration) -> Vec<String> {
        if self.checked || elapsed < self.timeout {
            return Vec::new();
        }
        self.checked = true;
        let secs = self.timeout.as_secs_f64();
        let d = self.domain_id;
        if !self.graph_seen {
            return vec![format!(
                "ros2: no ROS 2 node of domain {d} seen within {secs} s: is ROS_DOMAIN_ID {d} (ros2.domain_id) \
                 the lab's, do its nodes run rmw_zenoh (RMW_IMPLEMENTATION=rmw_zenoh_cpp), and do they \
                 reach this launch's router (or ros2.router its rmw_zenohd)?"
            )];
        }
        self.wanted.iter().filter_map(|w| self.missing(w, secs)).collect()
    }

    fn missing(&self, w: &Wanted, secs: f64) -> Option<String> {
        let on_topic: Vec<&TokenView> = self.publishers.values().filter(|p| p.topic == w.topic).collect();
        if on_topic.iter().any(|p| p.dds_type == w.dds_type && p.type_hash == w.type_hash) {
            return None;
        }
        let topic = &w.topic;
        Some(match on_topic.first() {
            Some(p) => format!(
                "ros2: {topic} is published as {} {} by node {}, not as {} {}: its samples are on another key \
                 and never arrive (another message type, or a ROS distribution with another type hash)",
                p.dds_type, p.type_hash, p.node, w.dds_type, w.type_hash
            ),
            None => {
                let mut seen: Vec<&str> = self
                    .publishers
                    .values()
                    .filter(|p| p.dds_type == w.dds_type)
                    .map(|p| p.topic.as_str())
                    .collect();
                seen.sort_unstable();
                seen.dedup();
                format!(
                    "ros2: nobody publishes {topic} in domain {} after {secs} s (mocap.ros2.topics); \
                     topics of its type that are published: {seen:?}",
                    self.domain_id
                )
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_ros2::msgs::{PoseStamped, RosMessage};
    use bycoms_ros2::rmw_zenoh::{dds_type_name, liveliness_token, Endpoint, Node, Qos};

    const POSE: &str = "geometry_msgs/msg/PoseStamped";

    fn node(zid: &str) -> Node {
        Node {
            domain_id: 0,
            zid: zid.into(),
            id: 0,
            enclave: "/".into(),
            namespace: "/".into(),
            name: "vrpn_mocap".into(),
        }
    }

    fn publisher(zid: &str, topic: &str, hash: &str) -> String {
        let e = Endpoint {
            id: 3,
            kind: EntityKind::Publisher,
            topic: topic.into(),
            ros_type: POSE.into(),
            type_hash: hash.into(),
            qos: Qos::best_effort(1),
        };
        liveliness_token(&node(zid), Some(&e)).expect("token")
    }

    fn watch(topics: &[&str]) -> GraphWatch {
        let wanted = topics
            .iter()
            .map(|t| Wanted {
                topic: (*t).into(),
                dds_type: dds_type_name(POSE),
                type_hash: PoseStamped::DESCRIPTION.rihs01(),
            })
            .collect();
        GraphWatch::new(0, "00ff".into(), wanted, Duration::from_secs(5))
    }

    /// Nothing is said before the timeout, nor when every topic has its
    /// publisher; the launch's own tokens and another domain's do not count.
    #[test]
    fn a_graph_with_every_publisher_is_silent() {
        let hash = PoseStamped::DESCRIPTION.rihs01();
        let mut w = watch(&["/r1", "/r2"]);
        w.token(&publisher("00ff", "/r2", &hash), true); // our own
        w.token(&publisher("a1", "/r1", &hash).replacen("/0/", "/7/", 1), true); // domain 7
        assert_eq!(w.check(Duration::from_secs(4)), Vec::<String>::new(), "before the timeout");
        w.token(&publisher("a1", "/r1", &hash), true);
        w.token(&publisher("a1", "/r2", &hash), true);
        assert_eq!(w.check(Duration::from_secs(5)), Vec::<String>::new());
    }

    /// The three wrong set-ups, each named: no graph at all, a topic
    /// nobody publishes (the published ones listed), a topic published
    /// with another type hash. Said once; a publisher that went is gone.
    #[test]
    fn no_graph_a_missing_topic_and_a_wrong_type_hash_are_each_said_once() {
        let mut empty = watch(&["/r1"]);
        let said = empty.check(Duration::from_secs(5));
        assert!(said.len() == 1 && said[0].contains("no ROS 2 node of domain 0"), "{said:?}");
        assert!(said[0].contains("RMW_IMPLEMENTATION=rmw_zenoh_cpp"), "{said:?}");
        assert_eq!(empty.check(Duration::from_secs(50)), Vec::<String>::new(), "once");

        let hash = PoseStamped::DESCRIPTION.rihs01();
        let mut w = watch(&["/r1", "/r2", "/r3"]);
        w.token(&publisher("a1", "/r1", &hash), true);
        let wrong = format!("RIHS01_{}", "ab".repeat(32));
        w.token(&publisher("a1", "/r2", &wrong), true);
        let gone = publisher("a1", "/r3", &hash);
        w.token(&gone, true);
        w.token(&gone, false);
        w.token(&publisher("a1", "/other", &hash), true);
        let said = w.check(Duration::from_secs(6));
        assert_eq!(said.len(), 2, "{said:?}");
        assert!(said[0].contains("/r2 is published as") && said[0].contains(&wrong), "{said:?}");
        assert!(said[1].contains("nobody publishes /r3") && said[1].contains("\"/other\""), "{said:?}");
    }

    /// Issue 51, item 4: a lab router with `peers_failover_brokering` off
    /// and its admin space on (rmw_zenoh's router config, with `adminspace`
    /// enabled) tells a client of it, on `@/<zid>/router`, its version and
    /// sessions (the launch's among them, a client) but not that setting,
    /// and nothing at all under `@/<zid>/router/config/**`: the launch
    /// cannot learn it (module docs). Should a zenoh release expose it, this
    /// fails and the warning can be built.
    #[test]
    fn a_routers_admin_space_does_not_tell_its_failover_brokering() {
        let endpoint = crate::transport::with_free_port("tcp/127.0.0.1:0").expect("a free port");
        let mut config = zenoh::Config::default();
        for (key, value) in [
            ("mode", "\"router\"".to_owned()),
            ("listen/endpoints", format!("[\"{endpoint}\"]")),
            ("scouting/multicast/enabled", "false".to_owned()),
            ("adminspace/enabled", "true".to_owned()),
            ("routing/router/peers_failover_brokering", "false".to_owned()),
        ] {
            config.insert_json5(key, &value).unwrap_or_else(|e| panic!("{key}: {e}"));
        }
        let router = zenoh::open(config).wait().expect("the lab's router");
        let cfg = Ros2Config { router: Some(endpoint), ..Ros2Config::default() };
        let client = session(&cfg, None).expect("a router answers").expect("a session");
        let ask = |key: String| -> Vec<String> {
            let replies = client.get(key).timeout(Duration::from_secs(5)).wait().expect("a query");
            let mut got = vec![];
            while let Ok(reply) = replies.recv() {
                let sample = reply.into_result().expect("a sample");
                got.push(sample.payload().try_to_string().expect("JSON text").into_owned());
            }
            got
        };
        let state = ask(format!("@/{}/router", router.zid()));
        assert_eq!(state.len(), 1, "the router's state: {state:?}");
        let json: serde_json::Value = serde_json::from_str(&state[0]).expect("JSON");
        assert!(json["version"].as_str().is_some_and(|v| v.starts_with("v1.10")), "{json}");
        let client_zid = client.zid().to_string();
        let sessions = json["sessions"].as_array().expect("sessions");
        assert!(
            sessions.iter().any(|s| s["peer"] == client_zid.as_str() && s["whatami"] == "client"),
            "{json}"
        );
        assert!(!state[0].contains("brokering") && !state[0].contains("routing"), "no configuration: {json}");
        assert_eq!(ask(format!("@/{}/router/config/**", router.zid())), Vec::<String>::new());
    }

    /// Over loopback: no router at the endpoint is an error naming it and
    /// `rmw_zenohd` (soon, not a hang); a router with a node of the domain
    /// is joined, its graph seen (and another domain's is not).
    #[test]
    fn no_router_is_an_error_naming_it_and_a_router_with_a_graph_is_joined() {
        use bycoms_protocol::bus::zenoh::{Mode, ZenohBus};
        let endpoint = crate::transport::with_free_port("tcp/127.0.0.1:0").expect("a free port");
        let cfg = Ros2Config { router: Some(endpoint.clone()), ..Ros2Config::default() };
        let began = std::time::Instant::now();
        let err = session(&cfg, None).expect_err("nothing listens there").to_string();
        assert!(err.contains(&format!("no zenoh router answers at {endpoint}")), "{err}");
        assert!(err.contains("rmw_zenohd"), "{err}");
        assert!(began.elapsed() < Duration::from_secs(10), "said within {:?}", began.elapsed());

        let config = bycoms_runtime::zenoh_config(Mode::Router, vec![endpoint.clone()], Vec::new(), None);
        let router = ZenohBus::open(config).expect("the lab's router");
        let token = format!("@ros2_lv/0/{}/0/0/NN/%/%/driver", router.session().zid());
        let _node = router.session().liveliness().declare_token(token).wait().expect("token");
        let joined = session(&cfg, None).expect("a router answers").expect("a session");
        assert_eq!(graph_members(&joined, 0), 1, "the driver's node");
        assert_eq!(graph_members(&joined, 7), 0, "no node of domain 7");
    }
}
