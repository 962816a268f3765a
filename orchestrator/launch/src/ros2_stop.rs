//! `launch --ros2`: the stop service, `std_srvs/srv/Trigger` on
//! `<namespace>/emergency` (issue 32 item 4): a ROS 2 node (or
//! `ros2 service call /emergency std_srvs/srv/Trigger`) stops every robot
//! at once, as `orchestrator stop --now` does.
//!
//! Why `emergency`: Crazyswarm2, the swarm stack labs know, names its
//! stop-everything service so; under the launch's `[ros2] namespace` (the
//! node's and the pose topics'), so two launches in one graph keep theirs
//! apart, and with the default namespace it is `/emergency`.
//!
//! The wire is rmw_zenoh's service format (`rmw_zenoh_cpp/src/detail/
//! rmw_service_data.cpp`, commit 028bbe30b72c, read in ros2/rmw_zenoh): a
//! queryable (complete) on the service's key expression (as a topic's:
//! domain, name, the service type `std_srvs::srv::dds_::Trigger_`, the
//! service's `RIHS01_` hash), a liveliness token of kind `SS` of the
//! launch's node (`orchestrator/launch/src/ros2.rs`), services' default QoS (reliable,
//! volatile, keep last 10). The request's attachment carries the client's
//! sequence number and GID; the reply carries the same sequence number and
//! client GID with our wall-clock stamp, and the `TriggerResponse` in CDR.
//!
//! A call becomes the control channel's stop question (`control.rs`): the
//! driver feeds the core its one stop input and answers; this file only
//! speaks the wire.

use super::control::{Answer, Ask, Reply, Request};
use super::ros2::{Ros2Config, NODE_NAME};
use bycoms_ros2::msgs::{RosMessage, TriggerResponse, TRIGGER};
use bycoms_ros2::rmw_zenoh::{liveliness_token, topic_key_expr, Attachment, Endpoint, EntityKind, Node, Qos};
use std::sync::mpsc::Sender;
use zenoh::Wait;

/// The service's entity id within the node: far above the publishers'
/// (`orchestrator/launch/src/ros2.rs` numbers them from 1), so new topics never collide.
pub const SERVICE_ENTITY_ID: u64 = 1_000_000;

/// The service's name under the launch's namespace.
pub fn service_name(cfg: &Ros2Config) -> String {
    format!("{}/emergency", cfg.namespace.trim_end_matches('/'))
}

/// The service as rmw_zenoh announces it: (key expression, token).
pub fn service_wire(cfg: &Ros2Config, zid: &str) -> anyhow::Result<(String, String)> {
    let node = Node {
        domain_id: cfg.domain_id,
        zid: zid.into(),
        id: 0,
        enclave: "/".into(),
        namespace: cfg.namespace.clone(),
        name: NODE_NAME.into(),
    };
    let endpoint = Endpoint {
        id: SERVICE_ENTITY_ID,
        kind: EntityKind::Service,
        topic: service_name(cfg),
        ros_type: TRIGGER.name.into(),
        type_hash: TRIGGER.rihs01(),
        qos: Qos::reliable(10),
    };
    let key = topic_key_expr(cfg.domain_id, &endpoint.topic, &endpoint.ros_type, &endpoint.type_hash);
    Ok((key, liveliness_token(&node, Some(&endpoint))?))
}

/// The service, declared; dropping it undeclares it.
pub struct Ros2Stop {
    _queryable: zenoh::query::Queryable<()>,
    _token: zenoh::liveliness::LivelinessToken,
}

impl Ros2Stop {
    /// Declares the stop service on `session`; its calls go to `requests`.
    pub fn open(
        cfg: &Ros2Config,
        session: &zenoh::Session,
        requests: Sender<Request>,
    ) -> anyhow::Result<Self> {
        let (key, token) = service_wire(cfg, &session.zid().to_string())?;
        let service = service_name(cfg);
        let name = service.clone();
        let queryable = session
            .declare_queryable(key.clone())
            .complete(true)
            .callback(move |query: zenoh::query::Query| {
                let asked = query.attachment().and_then(|a| Attachment::decode(&a.to_bytes()).ok());
                let client = asked.map(|a| hex(&a.gid)).unwrap_or_else(|| "unknown".into());
                let who = format!("ros2 service {name} (client {client})");
                let ask = Ask::Stop { now: true, who, why: "std_srvs/srv/Trigger call".into() };
                let reply: Reply = Box::new(move |answer: &Answer| respond(&query, asked, answer));
                let _ = requests.send(Request { ask, reply });
            })
            .wait()
            .map_err(|e| anyhow::anyhow!("ros2: cannot declare the stop service {service}: {e}"))?;
        let token = session
            .liveliness()
            .declare_token(token)
            .wait()
            .map_err(|e| anyhow::anyhow!("ros2: cannot declare the stop service's token: {e}"))?;
        tracing::info!(service, type_ = TRIGGER.name, "ros2: the stop service takes calls");
        Ok(Self { _queryable: queryable, _token: token })
    }
}

/// The `TriggerResponse` a stop answer becomes.
pub fn response(answer: &Answer) -> TriggerResponse {
    match answer {
        Answer::Stopping { swarm, told, answered, .. } => TriggerResponse {
            success: true,
            message: format!("swarm {swarm} stopped: {answered} of {told} robots said they stopped"),
        },
        Answer::Refused(why) => TriggerResponse { success: false, message: why.clone() },
        Answer::Status(_) | Answer::Revoked { .. } | Answer::OtherLab => {
            TriggerResponse { success: false, message: "not a stop".into() }
        }
    }
}

/// Replies to `query` as rmw_zenoh does: the response in CDR, the
/// request's sequence number and client GID in the attachment.
fn respond(query: &zenoh::query::Query, asked: Option<Attachment>, answer: &Answer) {
    let mut attachment =
        asked.unwrap_or(Attachment { sequence_number: 0, source_timestamp_ns: 0, gid: [0; 16] });
    let since = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
    attachment.source_timestamp_ns = i64::try_from(since.as_nanos()).unwrap_or(i64::MAX);
    let sent = query
        .reply(query.key_expr().clone(), response(answer).to_cdr())
        .attachment(attachment.encode().to_vec())
        .wait();
    if let Err(e) = sent {
        tracing::warn!(error = %e, "ros2: the stop service's reply was not sent");
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The service's key expression and token, pinned: rmw_zenoh's format
    /// (`bycoms-ros2`'s functions, themselves pinned against rmw_zenoh's
    /// examples) with the Trigger hash rosbags computes
    /// (`protocol/ros2/tests/golden.rs`, `PINNED_SERVICES`).
    #[test]
    fn the_stop_service_is_announced_as_rmw_zenoh_announces_a_trigger_service() {
        let hash = "RIHS01_eeff2cd6fa5ad9d27cdf4dec64818317839b62f212a91e6b5304b634b2062c5f";
        let (key, token) = service_wire(&Ros2Config::default(), "1a2b").expect("wire");
        assert_eq!(key, format!("0/emergency/std_srvs::srv::dds_::Trigger_/{hash}"));
        assert_eq!(
            token,
            format!("@ros2_lv/0/1a2b/0/1000000/SS/%/%/bycoms/%emergency/std_srvs::srv::dds_::Trigger_/{hash}/::,10:,:,:,,")
        );
        let lab = Ros2Config { domain_id: 7, namespace: "/lab".into(), router: None };
        assert_eq!(service_name(&lab), "/lab/emergency");
        assert!(service_wire(&lab, "1a2b").expect("wire").0.starts_with("7/lab/emergency/"));
    }

    #[test]
    fn a_stop_answer_is_a_successful_trigger_response_and_anything_else_is_not() {
        let stopping = Answer::Stopping {
            swarm: "lab".into(),
            now: true,
            told: 3,
            answered: 3,
            slowest_us: Some(900),
            recording: None,
            pid: 1,
        };
        let r = response(&stopping);
        assert!(r.success && r.message.contains("lab"), "{r:?}");
        assert!(!response(&Answer::Refused("no".into())).success);
    }
}
