//! This robot's certificate, as its agent will use it: the one its zenoh
//! config names (`transport/link/tls/connect_certificate`), signed by the
//! lab's CA the config names, carrying the robot's common name
//! (`robot-K`), valid today (the agent's own check before it opens its
//! session, `bus::zenoh::certs::check`) and for [`WARN_DAYS`] more.
//!
//! Why the agent's own check and not another: a doctor that judged a
//! certificate differently from the agent would pass a host whose agent
//! then refuses to start. The orchestrator's doctor checks the whole set
//! and its ACL (`orchestrator/src/doctor/certs.rs`); a robot's host has
//! only its own.

use super::{Finding, WARN_DAYS};
use bycoms_protocol::bus::zenoh::{certs, ZenohConfig};
use bycoms_protocol::naming::Member;
use bycoms_protocol::RobotId;
use std::path::Path;
use std::time::SystemTime;

const CHECK: &str = "certs";

/// The findings of robot `robot`'s zenoh config `config` at `now`.
pub fn robot(config: &Path, robot: u32, now: SystemTime) -> Vec<Finding> {
    let d = config.display();
    let zenoh = ZenohConfig { base_config: Some(config.to_path_buf()), ..ZenohConfig::default() };
    let zenoh = match zenoh.to_zenoh() {
        Ok(zenoh) => zenoh,
        Err(e) => {
            let fix = format!("give robot {robot} the robot-{robot}.json5 `orchestrator certs` wrote");
            return vec![Finding::error(CHECK, e.to_string(), fix)];
        }
    };
    let named = certs::named(&zenoh);
    if named.is_empty() {
        return vec![Finding::ok(
            CHECK,
            format!("{d} names no certificates (not secured): nothing to check"),
        )];
    }
    let cn = certs::common_name(Member::Agent(RobotId(robot)));
    let renew = format!(
        "on the orchestrator's host: remove its robot-{robot}.pem, run `orchestrator certs --add-robots --robots N --out DIR` and copy robot-{robot}.pem and robot-{robot}-key.pem here"
    );
    if let Err(e) = certs::check(&zenoh, Some(&cn), now) {
        return vec![Finding::error(CHECK, e.0, renew)];
    }
    let secs = now.duration_since(SystemTime::UNIX_EPOCH).map_or(0, |t| t.as_secs() as i64);
    let mut found = Vec::new();
    for path in &named {
        match certs::not_after(path) {
            Ok((end, date)) if (end - secs).div_euclid(86_400) < WARN_DAYS => {
                let days = (end - secs).div_euclid(86_400);
                let cause = format!("{} expires in {days} days ({date})", path.display());
                found.push(Finding::warn(CHECK, cause, renew.clone()));
            }
            Ok(_) => {}
            Err(e) => found.push(Finding::error(CHECK, e.0, renew.clone())),
        }
    }
    if found.is_empty() {
        found.push(Finding::ok(
            CHECK,
            format!("{d}: {cn}'s certificate signed by the lab's CA, valid {WARN_DAYS} days and more"),
        ));
    }
    found
}
