use super::*;
use bycoms_protocol::bus::zenoh::{Mode, ZenohBus, ZenohConfig};
use bycoms_ros2::msgs::{PoseStamped, Twist};
use bycoms_ros2::rmw_zenoh::{graph_key_expr, TokenView};
use std::collections::BTreeSet;
use std::time::{Duration, Instant};
use zenoh::query::ConsolidationMode;
use zenoh::sample::SampleKind;

/// Every wait of these tests is bounded by this.
const WAIT: Duration = Duration::from_secs(10);
const DOMAIN: u32 = 7;

/// A router on a free loopback port (the lab's `rmw_zenohd`) and a client
/// of it (the agent's session).
fn router_and_client() -> (ZenohBus, ZenohBus) {
    let router_config = |endpoint: &str| ZenohConfig {
        mode: Mode::Router,
        listen: vec![endpoint.to_owned()],
        ..ZenohConfig::default()
    };
    let (router, endpoint) = ZenohBus::loopback_router(router_config).expect("a loopback router");
    let client =
        ZenohBus::open(ZenohConfig { mode: Mode::Client, connect: vec![endpoint], ..ZenohConfig::default() })
            .expect("a client of the router");
    (router, client)
}

/// The tokens of `DOMAIN` `sub` reports, put (`true`) or deleted, until
/// `done` says enough or [`WAIT`] has passed.
fn tokens_until(
    sub: &zenoh::pubsub::Subscriber<zenoh::handlers::FifoChannelHandler<zenoh::sample::Sample>>,
    mut done: impl FnMut(&[(String, bool)]) -> bool,
) -> Vec<(String, bool)> {
    let deadline = Instant::now() + WAIT;
    let mut seen = Vec::new();
    while !done(&seen) {
        match sub.recv_deadline(deadline) {
            Ok(Some(s)) => seen.push((s.key_expr().as_str().to_owned(), s.kind() == SampleKind::Put)),
            _ => break,
        }
    }
    seen
}

/// The way an agent uses it: a node `bycoms_robot_3` in `/bycoms`, one
/// `cmd_vel` publisher of Twist; a ROS 2 subscriber on another session
/// gets each command as CDR that decodes back to it, with rmw_zenoh's
/// attachment (the publisher's GID, sequence numbers 1, 2, 3), and the
/// graph lists the node and the publisher while they live.
#[test]
fn a_published_twist_arrives_decodable_with_its_attachment_and_tokens() {
    let (router, client) = router_and_client();
    let graph = router.session().liveliness().declare_subscriber(graph_key_expr(DOMAIN)).history(true);
    let graph = graph.wait().expect("a graph subscriber");
    let session = client.session();
    let mut node = Ros2Node::declare(session, DOMAIN, "/bycoms", "bycoms_robot_3").expect("the node");
    let mut cmd_vel = node
        .publisher(session, "/bycoms/robot_3/cmd_vel", Twist::DESCRIPTION, Qos::reliable(10))
        .expect("the publisher");
    let data = router.session().declare_subscriber(cmd_vel.wire().key_expr.clone()).wait().expect("sub");

    assert!(cmd_vel.wait_matching(WAIT), "the route to the subscriber within {WAIT:?}");
    let sent = [Twist::planar(0.2, 0.0), Twist::planar(0.0, -1.0), Twist::planar(-0.1, 0.5)];
    for twist in &sent {
        cmd_vel.publish(twist).expect("sent");
    }
    for (i, twist) in sent.iter().enumerate() {
        let sample = data.recv_timeout(WAIT).expect("the channel").expect("a sample in time");
        assert_eq!(Twist::from_cdr(&sample.payload().to_bytes()).as_ref(), Ok(twist));
        let attachment = sample.attachment().expect("an attachment").to_bytes();
        let attachment = Attachment::decode(&attachment).expect("rmw_zenoh's attachment");
        assert_eq!((attachment.sequence_number, attachment.gid), (i as i64 + 1, cmd_vel.wire().gid));
        assert!(attachment.source_timestamp_ns > 1_600_000_000_000_000_000, "the system clock");
    }

    let both = |seen: &[(String, bool)]| seen.iter().filter(|(_, put)| *put).count() >= 2;
    let views: Vec<TokenView> =
        tokens_until(&graph, both).iter().filter_map(|(t, _)| TokenView::parse(t)).collect();
    let zid = session.zid().to_string();
    let node_view = views.iter().find(|v| v.kind == EntityKind::Node).expect("the node's token");
    assert_eq!((node_view.node.as_str(), node_view.zid.as_str()), ("bycoms_robot_3", zid.as_str()));
    let publisher = views.iter().find(|v| v.kind == EntityKind::Publisher).expect("the publisher's token");
    assert_eq!(
        (publisher.topic.as_str(), publisher.type_hash.clone()),
        ("/bycoms/robot_3/cmd_vel", Twist::DESCRIPTION.rihs01())
    );
    assert_eq!(publisher.dds_type, "geometry_msgs::msg::dds_::Twist_");

    // The node's token lives while a publisher of it does.
    drop(node);
    let own = session.liveliness().get(graph_key_expr(DOMAIN)).timeout(WAIT).wait().expect("a query");
    let mut live = BTreeSet::new();
    while let Ok(reply) = own.recv() {
        live.extend(
            reply.result().ok().and_then(|s| TokenView::parse(s.key_expr().as_str())).map(|v| v.kind.code()),
        );
    }
    assert_eq!(live, BTreeSet::from(["MP", "NN"]), "both tokens, the node dropped");
    drop(cmd_vel);
    let gone = |seen: &[(String, bool)]| seen.iter().filter(|(_, put)| !*put).count() >= 2;
    let deleted = tokens_until(&graph, gone);
    assert_eq!(deleted.iter().filter(|(_, put)| !*put).count(), 2, "both withdrawn: {deleted:?}");
}

/// What a caller could get wrong is refused, in words: a name that is
/// not ROS 2's, a session that is not the node's, a message of another type.
#[test]
fn bad_names_another_session_and_another_type_are_refused() {
    let (router, client) = router_and_client();
    let session = client.session();
    for (ns, name) in [("bycoms", "n"), ("/bycoms/", "n"), ("/", "a/b"), ("/", "3n"), ("/", "")] {
        let err = Ros2Node::declare(session, DOMAIN, ns, name).expect_err("refused");
        assert!(matches!(err, Ros2Error::Name { .. }), "{ns:?} {name:?}: {err}");
    }
    let mut node = Ros2Node::declare(session, DOMAIN, "/", "bycoms_robot_1").expect("the node");
    assert_eq!((node.node().namespace.as_str(), node.node().id), ("/", 0));
    let err =
        node.publisher(session, "cmd_vel", Twist::DESCRIPTION, Qos::reliable(10)).expect_err("relative");
    assert_eq!(err.to_string(), "ros2: topic \"cmd_vel\" is not a ROS 2 name (`/a/b`: letters, digits, `_`)");
    let other = node.publisher(router.session(), "/cmd_vel", Twist::DESCRIPTION, Qos::reliable(10));
    assert!(matches!(other, Err(Ros2Error::OtherSession { .. })), "another session");
    let mut cmd_vel = node.publisher(session, "/cmd_vel", Twist::DESCRIPTION, Qos::reliable(10)).expect("ok");
    let err = cmd_vel.publish(&PoseStamped::default()).expect_err("another type");
    assert_eq!(
        err.to_string(),
        "ros2: /cmd_vel publishes geometry_msgs/msg/Twist, not geometry_msgs/msg/PoseStamped"
    );
    let first = cmd_vel.publish(&Twist::default()).expect("no subscriber: put and dropped");
    assert_eq!(first.sequence_number, 1);
    let second = node.publisher(session, "/cmd_vel_2", Twist::DESCRIPTION, Qos::reliable(10)).expect("ok");
    assert!(second.wire().token.contains("/0/2/MP/"), "the second entity: {}", second.wire().token);
}

/// A transient-local publisher keeps its last `depth` samples and answers
/// a late joiner's history query (as zenoh-ext's advanced subscriber asks
/// it: `<key>/@adv/**`, `_max`, replies on the topic's key accepted) with
/// the very samples: payload, attachment, timestamp; its cache's token is
/// in the graph. A volatile one has neither.
#[test]
fn a_latched_publisher_answers_a_late_joiner_with_its_last_samples() {
    let (router, client) = router_and_client();
    let session = client.session();
    let mut node = Ros2Node::declare(session, DOMAIN, "/", "bycoms").expect("the node");
    let mut map =
        node.publisher(session, "/map", PoseStamped::DESCRIPTION, Qos::transient_local(2)).expect("map");
    let volatile =
        node.publisher(session, "/pose", PoseStamped::DESCRIPTION, Qos::reliable(10)).expect("pose");
    assert!(map.latched() && !volatile.latched());
    let sent: Vec<Attachment> = (0..3u8).map(|i| map.put(&[0, 1, 0, 0, i]).expect("put")).collect();
    let key = map.wire().key_expr.clone();
    let late = router.session();
    // The cache's token, declared after its queryable on the same session:
    // once the router has it, it has the queryable too (what a late
    // joiner's publisher detection relies on).
    let tokens = late.liveliness().declare_subscriber(format!("{key}/@adv/pub/**")).history(true);
    let tokens = tokens.wait().expect("a token subscriber");
    let token = tokens.recv_timeout(WAIT).ok().flatten().expect("the cache's token");
    assert_eq!(token.key_expr().as_str(), format!("{key}/@adv/pub/{}/uhlc/_", session.zid()));
    let ask = |params: &str| -> Vec<zenoh::sample::Sample> {
        // Every reply, as the advanced subscriber asks (no consolidation: all have the topic's key).
        let get = late.get(format!("{key}/@adv/**?_anyke{params}")).consolidation(ConsolidationMode::None);
        let replies = get.timeout(WAIT).wait().expect("get");
        let mut samples = vec![];
        while let Ok(reply) = replies.recv() {
            samples.push(reply.into_result().expect("a sample, not an error"));
        }
        samples
    };
    let history = ask(";_max=2");
    let payloads: Vec<Vec<u8>> = history.iter().map(|s| s.payload().to_bytes().to_vec()).collect();
    assert_eq!(payloads, [vec![0, 1, 0, 0, 1], vec![0, 1, 0, 0, 2]], "the newest two, oldest first");
    for (sample, attachment) in history.iter().zip(&sent[1..]) {
        assert_eq!(sample.key_expr().as_str(), key, "on the topic's key");
        let got = sample.attachment().map(|a| a.to_bytes().to_vec());
        assert_eq!(got, Some(attachment.encode().to_vec()), "its rmw_zenoh attachment");
        let stamp = sample.timestamp().expect("a timestamp");
        assert_eq!(stamp.get_id(), &TimestampId::from(session.zid()), "the session's id");
    }
    assert!(history[0].timestamp() < history[1].timestamp(), "timestamps increase");
    assert_eq!(ask(";_max=1").len(), 1);
    assert_eq!(ask(";_sn=5..").len(), 0, "our samples have no sequence number");
    let none = late.get(format!("{}/@adv/**?_anyke", volatile.wire().key_expr)).timeout(WAIT).wait();
    assert!(none.expect("get").recv().is_err(), "a volatile publisher keeps nothing");
}
