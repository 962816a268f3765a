//! The naming scheme and its character rules.

use super::*;

fn swarm() -> Swarm {
    Swarm::new("lab-1").expect("valid swarm")
}

#[test]
fn builds_every_topic_name() {
    let s = swarm();
    let r = RobotId(3);
    assert_eq!(s.to_agent(r).name().as_str(), "bycoms/lab-1/robot/3/to_agent");
    assert_eq!(s.sensor(r).name().as_str(), "bycoms/lab-1/robot/3/sensor");
    assert_eq!(s.pose(r).name().as_str(), "bycoms/lab-1/robot/3/pose");
    assert_eq!(s.from_agent(r).name().as_str(), "bycoms/lab-1/robot/3/from_agent");
    assert_eq!(s.gate().name().as_str(), "bycoms/lab-1/gate");
}

#[test]
fn the_robots_topics_of_a_kind_share_one_doorbell_and_nothing_else_does() {
    let s = swarm();
    let from = s.from_agent(RobotId(3)).name().doorbell();
    let to = s.to_agent(RobotId(3)).name().doorbell();
    assert_eq!(from.as_str(), "bycoms/lab-1/from_agents");
    assert_eq!(to.as_str(), "bycoms/lab-1/to_agents");
    assert_eq!(s.pose(RobotId(3)).name().doorbell().as_str(), "bycoms/lab-1/poses");
    assert_eq!(s.sensor(RobotId(3)).name().doorbell(), to);
    for topic in
        [*s.from_agent(RobotId(3)).name(), *s.pose(RobotId(3)).name(), *s.to_agent(RobotId(3)).name()]
    {
        assert_eq!(topic.doorbell_member(), Some(3), "{topic}");
    }
    assert_eq!(s.from_agent(RobotId(u32::MAX)).name().doorbell_member(), Some(u32::MAX));
    assert_eq!(s.sensor(RobotId(u32::MAX)).name().doorbell_member(), Some(u32::MAX));
    assert_eq!(from.doorbell_member(), None);
    assert_eq!(to.doorbell_member(), None);
    assert_eq!(s.from_agent(RobotId(u32::MAX)).name().doorbell(), from);
    let other = Swarm::new("lab-2").expect("valid swarm");
    assert_ne!(other.from_agent(RobotId(3)).name().doorbell(), from);
    assert_ne!(other.to_agent(RobotId(3)).name().doorbell(), to);
    for topic in [*s.gate().name(), *s.operator().name(), from, to] {
        assert_eq!(topic.doorbell(), topic, "{topic}");
    }
    for raw in [
        "a/b/robot/1/from_agent",
        "bycoms/x/robot//from_agent",
        "from_agent",
        "bycoms/robot/1/from_agent",
        "bycoms/x/robot/1x/pose",
        "bycoms/x/y/robot/1/to_agent",
        "bycoms/x/robot/1/posed",
    ] {
        if let Ok(name) = TopicName::parse(raw) {
            assert_eq!(name.doorbell(), name, "{raw}");
            assert_eq!(name.doorbell_member(), None, "{raw}");
        }
    }
    let long = Swarm::new(&"s".repeat(SWARM_NAME_MAX)).expect("max-length swarm is valid");
    assert!(long.from_agent(RobotId(u32::MAX)).name().doorbell().as_str().ends_with("/from_agents"));
    assert!(long.to_agent(RobotId(u32::MAX)).name().doorbell().as_str().ends_with("/to_agents"));
}

#[test]
fn longest_swarm_and_robot_id_still_fit() {
    let long = "s".repeat(SWARM_NAME_MAX);
    let s = Swarm::new(&long).expect("max-length swarm is valid");
    let name = *s.to_agent(RobotId(u32::MAX)).name();
    assert!(name.as_str().ends_with("/robot/4294967295/to_agent"));
    assert!(name.as_str().len() <= TOPIC_NAME_MAX);
}

#[test]
fn swarm_rejects_special_characters() {
    for (bad, ch) in [
        ("a*b", '*'),
        ("a$b", '$'),
        ("a#b", '#'),
        ("a?b", '?'),
        ("a b", ' '),
        ("a@b", '@'),
        ("a.b", '.'),
        ("aéb", 'é'),
        ("a\0b", '\0'),
    ] {
        assert_eq!(Swarm::new(bad), Err(NameError::InvalidChar { ch, at: 1 }), "{bad:?}");
    }
    assert_eq!(Swarm::new("a/b"), Err(NameError::InvalidChar { ch: '/', at: 1 }));
    assert_eq!(Swarm::new(""), Err(NameError::Empty));
    let too_long = "s".repeat(SWARM_NAME_MAX + 1);
    assert_eq!(
        Swarm::new(&too_long),
        Err(NameError::TooLong { len: SWARM_NAME_MAX + 1, max: SWARM_NAME_MAX })
    );
    assert!(Swarm::new("Lab_2-west").is_ok());
}

#[test]
fn topic_name_rejects_empty_chunks() {
    for bad in ["/a", "a/", "a//b", "/"] {
        assert_eq!(TopicName::parse(bad), Err(NameError::EmptyChunk), "{bad:?}");
    }
    assert_eq!(TopicName::parse(""), Err(NameError::Empty));
    assert_eq!(TopicName::parse("a/**"), Err(NameError::InvalidChar { ch: '*', at: 2 }));
    assert_eq!(TopicName::parse("iox2://x"), Err(NameError::InvalidChar { ch: ':', at: 4 }));
    let long = "a".repeat(TOPIC_NAME_MAX + 1);
    assert!(matches!(TopicName::parse(&long), Err(NameError::TooLong { .. })));
    assert_eq!(TopicName::parse("a/b-c/d_1").map(|n| n.to_string()), Ok("a/b-c/d_1".into()));
}

#[test]
fn errors_explain_themselves() {
    let msg = NameError::InvalidChar { ch: '*', at: 1 }.to_string();
    assert!(msg.contains("'*'") && msg.contains("byte 1"), "{msg}");
}

#[test]
fn everything_pattern_covers_the_swarm() {
    assert_eq!(swarm().everything().as_str(), "bycoms/lab-1/**");
    let long = "s".repeat(SWARM_NAME_MAX);
    let s = Swarm::new(&long).expect("max-length swarm is valid");
    assert_eq!(s.everything().as_str(), format!("bycoms/{long}/**"));
}

#[test]
fn route_reads_every_topic_back() {
    let s = swarm();
    let r = RobotId(42);
    assert_eq!(s.route(s.to_agent(r).name().as_str()), Some(Route::ToAgent(r)));
    assert_eq!(s.route(s.sensor(r).name().as_str()), Some(Route::Sensor(r)));
    assert_eq!(s.route(s.pose(r).name().as_str()), Some(Route::Pose(r)));
    assert_eq!(s.route(s.from_agent(r).name().as_str()), Some(Route::FromAgent(r)));
    assert_eq!(s.route(s.gate().name().as_str()), Some(Route::Gate));
    assert_eq!(s.route(s.operator().name().as_str()), Some(Route::Operator));
}

#[test]
fn route_rejects_foreign_and_malformed_names() {
    let s = swarm();
    for name in [
        "bycoms/lab-2/gate",
        "bycoms/lab-1x/gate",
        "bycoms/lab-1/robot/007/pose",
        "bycoms/lab-1/robot/4294967296/pose",
        "bycoms/lab-1/robot/3/other",
        "bycoms/lab-1/robot//pose",
        "other/lab-1/gate",
        "bycoms/lab-1",
    ] {
        assert_eq!(s.route(name), None, "{name}");
    }
}
