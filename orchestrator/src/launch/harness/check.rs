//! The properties every schedule keeps, stated once: the launch ends with
//! a clear outcome, no robot is deployed twice, verdicts come in deployment
//! order, the budget adds up, every crash or cut link is noticed within
//! 500 ms (the core's supervision timers, in virtual time), re-sends are
//! bounded.

use super::*;

/// Re-sends a lost message may cost, at most: from the shortest first
/// re-send to once a second is ten doublings.
const RESENDS_PER_LOSS: u64 = 12;

/// The exit code a launch with this ending has (the README's table).
pub fn exit_code(ending: &Ending) -> i32 {
    match ending.outcome {
        Outcome::Arrived => 0,
        Outcome::RobotsExhausted | Outcome::TimeLimit => 3,
        Outcome::Interrupted => 130,
        Outcome::Error => 1,
    }
}

/// The properties every schedule keeps; the first broken one, in words.
pub fn check(report: &Report, schedule: &Schedule) -> Result<(), String> {
    if let Some(f) = &report.failure {
        return Err(f.clone());
    }
    let Some(ending) = &report.ending else { return Err("no ending".into()) };
    if (ending.outcome == Outcome::Error) != ending.error.is_some() {
        return Err(format!("outcome {:?} with error {:?}", ending.outcome, ending.error));
    }
    if ending.error.as_ref().is_some_and(|e| e.to_string().trim().is_empty()) {
        return Err("an error without words".into());
    }
    let _ = exit_code(ending);
    // Deployments: each robot at most once, in id order (but for robots
    // that joined late, which take a later turn); each verdict follows its
    // robot's deployment and precedes the next one.
    let mut open: Option<u32> = None;
    let mut last_deployed = 0;
    for g in &report.gates {
        let id = g.robot.0;
        match g.kind {
            GateKind::Deployed => {
                if let Some(o) = open {
                    return Err(format!("robot {id} deployed while robot {o} was still under watch"));
                }
                if id <= last_deployed && !report.late.contains(&id) {
                    return Err(format!("robot {id} deployed after robot {last_deployed}"));
                }
                last_deployed = last_deployed.max(id);
                open = Some(id);
            }
            _ => {
                if open != Some(id) {
                    return Err(format!("a verdict ({:?}) on robot {id}, which was not under watch", g.kind));
                }
                open = None;
            }
        }
    }
    for (i, &sent) in report.deploys_sent.iter().enumerate() {
        let deployed =
            report.gates.iter().filter(|g| g.robot.0 == i as u32 + 1 && g.kind == GateKind::Deployed).count();
        if deployed > 1 {
            return Err(format!("robot {} deployed {deployed} times", i + 1));
        }
        let _ = sent;
    }
    // Nothing charged twice: the budget is the robots' active steps, and no
    // robot has more active steps than ticks ran or than its agent stepped.
    let sum: u64 = report.robots.iter().map(|r| r.1).sum();
    if sum != report.spent {
        return Err(format!("spent {} but the robots' steps sum to {sum}", report.spent));
    }
    // Periods that ran: lockstep ticks, or real time's wall time × speed.
    let periods = match schedule.realtime {
        None => report.ticks,
        Some(speed) => (report.end_us as f64 * speed / 100_000.0) as u64 + 2,
    };
    for (i, r) in report.robots.iter().enumerate() {
        if r.1 > periods {
            return Err(format!("robot {} charged {} steps in {periods} periods", i + 1, r.1));
        }
        if let Some(p) = r.2 {
            if !(p.x.is_finite() && p.y.is_finite()) {
                return Err(format!("robot {} ended at a non-finite pose", i + 1));
            }
        }
    }
    let arrived = report.robots.iter().filter(|r| r.0 == SlotState::Arrived).count();
    if arrived > 1 || (arrived == 1) != (ending.outcome == Outcome::Arrived) {
        return Err(format!("{arrived} robots arrived, outcome {:?}", ending.outcome));
    }
    notices(report)?;
    // Re-sends are bounded: at most every awaited robot once a second, and
    // a few for each message lost (a wait's first re-sends come after a
    // few answer times, each twice as late as the one before).
    let bound =
        (report.end_us / 1_000_000 + 2) * u64::from(schedule.robots) * 2 + RESENDS_PER_LOSS * report.lost;
    if report.resends > bound {
        return Err(format!(
            "{} re-sends in {} s (bound {bound})",
            report.resends,
            report.end_us / 1_000_000
        ));
    }
    Ok(())
}

/// Every crash of a running agent and every cut of its link is noticed
/// (the agent lost, or unreachable) within [`NOTICE_US`] of virtual time,
/// unless the launch ended first.
fn notices(report: &Report) -> Result<(), String> {
    for &(id, at) in &report.faults {
        let until = at + NOTICE_US;
        if report.end_us < until {
            continue;
        }
        if !report.noticed.iter().any(|&(r, t)| r == id && (at..=until).contains(&t)) {
            return Err(format!("robot {id}'s crash or cut at {at} µs was not noticed within 500 ms"));
        }
    }
    Ok(())
}
