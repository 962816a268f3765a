//! The properties every schedule keeps, stated once: the launch ends with
//! a clear outcome, no robot is deployed twice, verdicts come in deployment
//! order, the budget adds up, every crash or cut link is noticed within
//! 500 ms (the core's supervision timers, in virtual time), re-sends are
//! bounded.

use super::*;
use crate::core::view::StateChange;

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

/// The summary ([`super::super::summary::of`]) says what happened: the
/// core's outcome (an error if the recording failed), success only when a
/// robot arrived, as robots used the robots that took a `Deploy` and were
/// judged or still moving (each with a position, no other robot with one),
/// the budget the core charged.
fn check_summary(report: &Report, schedule: &Schedule, ending: &Ending) -> Result<(), String> {
    let Some(d) = &report.decided else { return Err("no summary".into()) };
    let v = &d.verdict;
    let outcome = if schedule.recording_fails { Outcome::Error } else { ending.outcome };
    if v.outcome != outcome || v.success != (outcome == Outcome::Arrived) {
        return Err(format!("summary says {:?} (success {}) for {:?}", v.outcome, v.success, ending.outcome));
    }
    if (v.outcome == Outcome::Error) != v.error.as_ref().is_some_and(|e| !e.trim().is_empty()) {
        return Err(format!("summary outcome {:?} with error {:?}", v.outcome, v.error));
    }
    let arrived = d.robots.iter().filter(|r| r.end == RobotEnd::Arrived).count();
    if ending.outcome == Outcome::Arrived && arrived != 1 {
        return Err(format!("arrived, but {arrived} robots arrived in the summary"));
    }
    let deployed: Vec<u32> =
        report.gates.iter().filter(|g| g.kind == GateKind::Deployed).map(|g| g.robot.0).collect();
    if d.robots_used as usize != deployed.len() {
        return Err(format!("{} robots used, {} deployment events", d.robots_used, deployed.len()));
    }
    for r in &d.robots {
        let used = deployed.contains(&r.id);
        if used != r.deployed_tick.is_some() || used != r.x.is_some() {
            return Err(format!("robot {} deployed: {used}, but the summary says {r:?}", r.id));
        }
    }
    if d.steps != report.spent || d.steps != d.robots.iter().map(|r| r.steps).sum::<u64>() {
        return Err(format!("summary steps {} for {} spent", d.steps, report.spent));
    }
    Ok(())
}

/// `Stop` goes to the robot that arrived and, when the agents stop stuck
/// robots, to each robot judged stuck whose agent still ran; to no other,
/// but for the `Stop`s each running robot gets from a stop `now` until it
/// answers (its own property, `check_stop`) and the one a revoked robot
/// gets (its own, `check_revoke`).
fn check_stops(report: &Report, schedule: &Schedule) -> Result<(), String> {
    let asked_at = schedule.stop_at_us.map_or(u64::MAX, |s| s.0);
    for (i, &sent) in report.stops_sent.iter().enumerate() {
        let id = i as u32 + 1;
        let told = report.stopped.as_ref().is_some_and(|s| s.now && s.told.contains(&id));
        let by_stop_now = match told {
            true => report.stop_log.iter().filter(|s| s.1 == id && s.0 >= asked_at).count() as u64,
            false => 0,
        };
        let by_revoke = report.after_revoke.iter().filter(|(r, o)| *r == id && is_stop(o)).count() as u64;
        let stops = sent - (by_stop_now + by_revoke).min(sent);
        let verdict = report.gates.iter().find(|g| g.robot.0 == id && g.kind != GateKind::Deployed);
        let stuck = verdict.is_some_and(|g| g.kind == GateKind::Stopped { arrived: false });
        let arrived = verdict.is_some_and(|g| g.kind == GateKind::Stopped { arrived: true });
        let alive = report.deaths.get(i).is_some_and(Option::is_none);
        let stop_when_stuck = schedule.seams().agents.stop_when_stuck;
        let expected = arrived || (stuck && stop_when_stuck);
        if stops > 0 && !expected {
            return Err(format!("robot {id} told to stop ({stops}×) after {:?}", verdict.map(|g| g.kind)));
        }
        if stuck && stop_when_stuck && alive && stops == 0 {
            return Err(format!("robot {id} judged stuck and never told to stop"));
        }
    }
    Ok(())
}

/// Deployments: each robot at most once, in id order (but for robots that
/// joined late, which take a later turn); each verdict follows its robot's
/// deployment and precedes the next one.
fn check_deployments(report: &Report) -> Result<(), String> {
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
    for id in 1..=report.deploys_sent.len() as u32 {
        let deployed =
            report.gates.iter().filter(|g| g.robot.0 == id && g.kind == GateKind::Deployed).count();
        if deployed > 1 {
            return Err(format!("robot {id} deployed {deployed} times"));
        }
    }
    Ok(())
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
    check_deployments(report)?;
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
    check_stop(report, schedule, ending)?;
    let arrived = report.robots.iter().filter(|r| r.0 == SlotState::Arrived).count();
    if arrived > 1 || (arrived == 1) != (ending.outcome == Outcome::Arrived) {
        return Err(format!("{arrived} robots arrived, outcome {:?}", ending.outcome));
    }
    check_summary(report, schedule, ending)?;
    check_stops(report, schedule)?;
    check_wind_down(report)?;
    check_revoke(report, schedule)?;
    check_views(report)?;
    if let Some(why) = &report.view_differs {
        return Err(why.clone());
    }
    let seams = schedule.seams();
    if !seams.agents.senses_beacons && report.beacons_sent > 0 {
        return Err(format!("{} beacons sent to agents that hear each other", report.beacons_sent));
    }
    if seams.poses_on_the_bus && report.forwarded > 0 {
        return Err(format!("{} poses forwarded though they are on the bus", report.forwarded));
    }
    notices(report)?;
    check_real_robots(report, schedule, ending)?;
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

/// A stop asked from outside: when it ended the launch, the summary names
/// who and why. With `now`, every robot whose agent ran was told `Stop`
/// once, all in one step (`told_stop_at`), each told answered it or is
/// named silent, and the launch ended once all had answered or the stop's
/// wait was over ([`STOP_WAIT_US`]).
fn check_stop(report: &Report, schedule: &Schedule, ending: &Ending) -> Result<(), String> {
    let Some(stop) = &report.stopped else {
        return match schedule.stop_at_us {
            Some((at, _)) if at < report.end_us => Err(format!("a stop asked at {at} µs was not taken in")),
            _ => Ok(()),
        };
    };
    if ending.outcome != Outcome::Interrupted && ending.outcome != Outcome::Error {
        return Err(format!("a stop was taken in but the launch ended {:?}", ending.outcome));
    }
    if stop.who != STOP_WHO || stop.why != STOP_WHY {
        return Err(format!("the stop is recorded as by {:?} for {:?}", stop.who, stop.why));
    }
    if Some(stop.now) != schedule.stop_at_us.map(|s| s.1) {
        return Err(format!("a stop with now = {} recorded, {:?} asked", stop.now, schedule.stop_at_us));
    }
    // Ctrl-C or an error taken in the same step end the launch first.
    let (asked_at, _) = schedule.stop_at_us.unwrap_or_default();
    let first =
        ending.outcome == Outcome::Interrupted && schedule.interrupt_at_us.is_none_or(|i| i > asked_at);
    if !first {
        return Ok(());
    }
    if !stop.now {
        return match stop.told.is_empty() {
            true => Ok(()),
            false => Err(format!("a graceful stop told robots {:?} to stop", stop.told)),
        };
    }
    if let Some(missed) = report.running_at_end.iter().find(|id| !stop.told.contains(id)) {
        return Err(format!("robot {missed} ran at the end and was never told to stop"));
    }
    check_stop_answers(report, schedule, stop)
}

/// A stop `now`'s answers: told all in one step at or after it was asked,
/// each robot told answered once or is named silent, the launch over by the
/// stop's wait, and early (without a Ctrl-C) only when every robot still
/// running had answered; no robot sent `Stop` again after it answered
/// (but a revoked one, told by its revocation).
fn check_stop_answers(report: &Report, schedule: &Schedule, stop: &StopSummary) -> Result<(), String> {
    let asked_at = schedule.stop_at_us.map_or(0, |s| s.0);
    let Some(at) = told_stop_at(report, asked_at, stop) else {
        return match stop.told.is_empty() {
            true => Ok(()),
            false => Err(format!("robots {:?} told to stop, but not all in one step", stop.told)),
        };
    };
    let mut heard: Vec<u32> =
        stop.answered.iter().map(|a| a.robot).chain(stop.unanswered.iter().copied()).collect();
    heard.sort_unstable();
    let mut told = stop.told.clone();
    told.sort_unstable();
    if heard != told {
        return Err(format!("told {told:?}, answered or silent {heard:?}"));
    }
    if report.end_us > at + STOP_WAIT_US {
        return Err(format!("a stop told at {at} µs ended the launch only at {} µs", report.end_us));
    }
    if let Some(late) = stop.answered.iter().find(|a| at + a.after_us > report.end_us) {
        return Err(format!("robot {} answered after the end", late.robot));
    }
    let interrupted = schedule.interrupt_at_us.is_some_and(|i| (asked_at..=report.end_us).contains(&i));
    let early = report.end_us < at + STOP_WAIT_US && !interrupted;
    if let Some(id) = stop.unanswered.iter().find(|id| early && report.running_at_end.contains(id)) {
        return Err(format!(
            "the stop ended at {} µs without robot {id}'s answer, before its wait",
            report.end_us
        ));
    }
    let revoked = |id: u32| report.revoked.iter().any(|r| r.robot == id);
    for a in stop.answered.iter().filter(|a| !revoked(a.robot)) {
        if let Some(t) = report.stop_log.iter().find(|s| s.1 == a.robot && s.0 > at + a.after_us) {
            return Err(format!("robot {} sent Stop at {} µs after it answered", a.robot, t.0));
        }
    }
    Ok(())
}

/// When the robots a stop `now` told were sent `Stop`: the step in which
/// the first robot it told was, at or after it was asked, if every robot
/// it told was sent `Stop` in that same step.
fn told_stop_at(report: &Report, asked_at: u64, stop: &StopSummary) -> Option<u64> {
    let first = *stop.told.first()?;
    let at = report.stop_log.iter().find(|s| s.0 >= asked_at && s.1 == first)?.0;
    let sent_at = |id: &u32| report.stop_log.iter().any(|s| s.0 == at && s.1 == *id);
    stop.told.iter().all(sent_at).then_some(at)
}

fn is_stop(out: &Output) -> bool {
    matches!(out, Output::Send(_, ToAgent::Stop))
}

/// A robot revoked (`orchestrator/launch-core/src/revoke.rs`): taken in when asked before
/// the end, told `Stop` at most once and, right after it, `Shutdown` (its
/// agent is told to end; one not running is told neither), nothing of it
/// shown (no `Output::Moved`), and nothing from it changes the
/// launch afterwards: the core starts, deploys, ticks, steers or hears it
/// no more, and judges it at most once more (a beacon where it stopped).
fn check_revoke(report: &Report, schedule: &Schedule) -> Result<(), String> {
    let Some((at, id)) = schedule.revoke_at_us else { return Ok(()) };
    let Some(record) = report.revoked.iter().find(|r| r.robot == id) else {
        return match at < report.end_us {
            true => Err(format!("robot {id}'s revocation at {at} µs was not taken in")),
            false => Ok(()),
        };
    };
    if record.who != STOP_WHO || record.why != REVOKE_WHY {
        return Err(format!("robot {id} is recorded as revoked by {:?} for {:?}", record.who, record.why));
    }
    if report.running_at_end.contains(&id) {
        return Err(format!("revoked robot {id}'s agent still counts as running"));
    }
    let (mut stops, mut ends, mut judged, mut beacons) = (0, 0, 0, 0);
    for (_, out) in report.after_revoke.iter().filter(|(r, _)| *r == id) {
        match out {
            Output::Send(_, ToAgent::Stop) => stops += 1,
            Output::Send(_, ToAgent::Shutdown) if ends < stops => ends += 1,
            Output::Send(_, ToAgent::Refused(r)) if r.why == Refusal::Revoked => {}
            Output::Gate(g) if g.kind == GateKind::Died => judged += 1,
            // Lost (not deployed yet), or judged lost while it moved: a
            // beacon where it stopped.
            Output::State(StateChange { state: SlotState::Lost | SlotState::Died, .. }) => {}
            Output::Beacon(_) => beacons += 1,
            Output::Event(_) | Output::Relay(_) => {}
            other => return Err(format!("revoked robot {id}: {other:?} after its revocation")),
        }
    }
    if stops > 1 || judged > 1 || ends != stops || beacons > judged {
        return Err(format!(
            "revoked robot {id} told Stop {stops}×, Shutdown {ends}× and judged {judged}× after it"
        ));
    }
    Ok(())
}

/// What the views show is what the core applied (its `Output::Moved`,
/// which the driver alone hands to the live view, ROS 2, the recording's
/// scene and `core/moved`, and the trace): no forged pose the core did not
/// take (one plausible by all its rules it applies, and shows); each robot's
/// poses in step order, none shown twice; none of a robot after its
/// revocation (`check_revoke`: nothing about it but its `Stop`, its
/// `Shutdown`, its judgement); and each deployed robot's end (the
/// summary's pose) one of the poses shown of it. (A robot is shown from its
/// start pose on: the poses an operator's placement reads are not.)
fn check_views(report: &Report) -> Result<(), String> {
    let same = |a: &Pose, b: &Pose| {
        (a.robot, a.step, a.x.to_bits(), a.y.to_bits()) == (b.robot, b.step, b.x.to_bits(), b.y.to_bits())
    };
    let mut last_step: Vec<Option<u64>> = vec![None; report.robots.len()];
    for (at, robot, pose) in &report.moved {
        if pose.robot.0 != *robot {
            return Err(format!("robot {}'s pose shown as robot {robot}'s at {at} µs", pose.robot.0));
        }
        let forged = report.forged.iter().filter(|(f, _)| same(f, pose));
        if forged.clone().next().is_some() && !forged.clone().any(|(_, taken)| *taken) {
            return Err(format!("a forged pose the core did not take shown at {at} µs: {pose:?}"));
        }
        let Some(last) = last_step.get_mut(*robot as usize - 1) else {
            return Err(format!("a pose of robot {robot}, not in the launch, shown at {at} µs"));
        };
        if last.is_some_and(|step| pose.step <= step) {
            return Err(format!(
                "robot {robot}'s pose of step {} shown at {at} µs after {last:?}",
                pose.step
            ));
        }
        *last = Some(pose.step);
    }
    for (i, (_, _, end)) in report.robots.iter().enumerate() {
        let id = i as u32 + 1;
        let deployed = report.gates.iter().any(|g| g.robot.0 == id && g.kind == GateKind::Deployed);
        let shown = |end: &Pose| report.moved.iter().any(|(_, r, p)| *r == id && same(p, end));
        if let Some(end) = end.filter(|end| deployed && !shown(end)) {
            return Err(format!("robot {id} ended at {end:?}, a pose never shown"));
        }
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

/// Gateway agents: the real robots kept their safety promises (`real.rs`:
/// told `Stop`, a robot stops within [`super::STOP_BOUND_US`]; a gateway
/// that lost the orchestrator past its grace stopped its robot; a robot
/// whose gateway is gone stops on its own; no goal without a pose), the
/// core deployed only robots motion capture saw at the start, and a launch
/// that ended waiting for a placement names a robot the operator did not
/// place, after the placement timeout.
fn check_real_robots(report: &Report, schedule: &Schedule, ending: &Ending) -> Result<(), String> {
    if let Some(v) = report.violations.first() {
        return Err(v.clone());
    }
    let Some(Fault::NotPlaced { robot, .. }) = &ending.error else { return Ok(()) };
    let placing = schedule.placing.get(*robot as usize - 1);
    if !schedule.gateways || matches!(placing, None | Some(Placing::Prompt(_))) {
        return Err(format!("the launch ended NotPlaced for robot {robot}, placed as {placing:?}"));
    }
    let asked = report.asked_us.get(*robot as usize - 1).copied().flatten();
    let timeout_us = (PLACEMENT.timeout * 1e6) as u64;
    if asked.is_none_or(|t| report.end_us < t + timeout_us) {
        return Err(format!("robot {robot} NotPlaced at {} µs, asked at {asked:?}", report.end_us));
    }
    Ok(())
}

/// The wind-down after the ending: every agent still running is told
/// `Shutdown` once and asked to end; those that have not left when the
/// grace is over, and only those, are ended; it is done as soon as the
/// last has left, never after the grace; and a simulated agent leaves on
/// `Shutdown` by its own rule.
fn check_wind_down(report: &Report) -> Result<(), String> {
    let Some(w) = &report.wound else { return Err("an ending without a wind-down".into()) };
    let running: Vec<u32> = w.leaves.iter().map(|l| l.0).collect();
    if running != report.agents_at_end || w.told != running || !w.asked {
        return Err(format!(
            "wind-down: agents at the end {:?}, running {running:?}, told {:?}, asked {}",
            report.agents_at_end, w.told, w.asked
        ));
    }
    let deadline = w.started_us.saturating_add(w.grace_us);
    let late: Vec<u32> = w.leaves.iter().filter(|l| l.1.is_none_or(|t| t > deadline)).map(|l| l.0).collect();
    if w.ended != late {
        return Err(format!("wind-down ended {:?}, but {late:?} had not left by {deadline} µs", w.ended));
    }
    let last = w.leaves.iter().filter_map(|l| l.1).max().unwrap_or(w.started_us).max(w.started_us);
    let done = if late.is_empty() { last } else { deadline };
    if w.done_us != done {
        return Err(format!("wind-down done at {} µs, expected {done} µs", w.done_us));
    }
    if !w.stayed.is_empty() {
        return Err(format!("simulated agents {:?} did not leave on Shutdown", w.stayed));
    }
    Ok(())
}
