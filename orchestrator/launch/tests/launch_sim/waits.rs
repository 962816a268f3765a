//! What lockstep waits for: a lost answer costs a quick re-send, the launch
//! says what it waits for, a robot judged at once starts its successor once.

use super::*;

/// Issue 31: lockstep with `[faults] drop = 0.05` took 114 s where the run
/// takes 0.15 s, silent, and ended otherwise than without faults. A lost
/// answer (a `TickDone`, or the moving robot's pose) costs a re-send after
/// a few answer times, not a second, and the tick waits for the moving
/// robot's pose, so the run is the one without faults, bit for bit.
#[test]
fn lost_answers_in_lockstep_cost_a_quick_resend_and_change_nothing() {
    let mut lost = 0;
    for seed in (0..432).step_by(9) {
        let case = Case::small(seed);
        let clean = registered(harness::run(
            &case,
            &Schedule { net_faults: harness::NetFaults::perfect(50), ..Schedule::clean(seed, case.robots) },
        ));
        for drop in [0.05, 0.3] {
            let what = format!("seed {seed}, drop {drop}");
            let lossy = Schedule {
                net_faults: harness::NetFaults::faults(50, drop),
                ..Schedule::clean(seed, case.robots)
            };
            let report = harness::run(&case, &lossy);
            harness::check(&report, &lossy).unwrap_or_else(|e| panic!("{what}: {e}"));
            let report = registered(report);
            same_run(&clean, &report, &what);
            assert_simulates(&case, &report, &what);
            // A lost registration costs a heartbeat (0.5 s); anything else
            // a re-send after a few answer times.
            let bound = clean.end_us + 1_000_000 + report.lost * 20_000;
            assert!(
                report.end_us <= bound,
                "{what}: {} µs, {} lost, clean {} µs",
                report.end_us,
                report.lost,
                clean.end_us
            );
            lost += report.lost;
        }
    }
    assert!(lost > 1000, "messages were lost: {lost}");
}

/// Issue 31: a launch that waited looked hung. What it waits for is said
/// in words (the terminal prints it when a wait lasts, `launch::progress`).
#[test]
fn the_launch_says_what_it_waits_for() {
    use bycoms_launch::core::{Input, LaunchCore};
    use bycoms_protocol::msg::{FromAgent, TickDone, ToAgent};
    use bycoms_protocol::RobotId;
    let case = Case::small(0);
    // Answers may be lost (injected faults): unanswered ticks are re-sent.
    let lossy =
        Schedule { net_faults: harness::NetFaults::faults(50, 0.05), ..Schedule::clean(0, case.robots) };
    let mut core = LaunchCore::new(harness::setup(&case, &lossy));
    let waiting = |core: &LaunchCore| core.waiting().map(|w| (w.what, w.resent));
    core.advance(0);
    core.handle(0, Input::Started { robot: 1, pid: Some(7), how: "started".into() });
    core.advance(0);
    assert_eq!(waiting(&core), Some(("robot 1's agent to register".into(), 0)));
    let register = simulated_register(1);
    core.handle(1_000, Input::Report(FromAgent::Register(register)));
    core.advance(1_000);
    assert_eq!(waiting(&core), Some(("robot 1's answer to tick 1".into(), 0)));
    // Nothing comes: sent again after a tenth of a second (nothing timed yet).
    core.advance(101_000);
    assert_eq!(waiting(&core), Some(("robot 1's answer to tick 1".into(), 1)));
    while core.poll().is_some() {}
    core.handle(102_000, Input::Report(FromAgent::TickDone(TickDone { robot: RobotId(1), step: 1 })));
    core.advance(102_000);
    let deploy = std::iter::from_fn(|| core.poll())
        .any(|o| matches!(o, bycoms_launch::core::Output::Send(1, ToAgent::Deploy(_))));
    assert!(deploy, "robot 1 is told to deploy");
    assert_eq!(waiting(&core), Some(("robot 1's start pose".into(), 0)));
    // Agents on this host, nothing lost: a late answer is awaited, not re-sent.
    let mut core = LaunchCore::new(harness::setup(&case, &Schedule::clean(0, case.robots)));
    core.advance(0);
    core.handle(0, Input::Started { robot: 1, pid: Some(7), how: "started".into() });
    core.handle(1_000, Input::Report(FromAgent::Register(simulated_register(1))));
    core.advance(1_000);
    while core.poll().is_some() {}
    core.advance(101_000);
    assert_eq!(waiting(&core), Some(("robot 1's answer to tick 1".into(), 0)));
    assert!(core.poll().is_none(), "nothing sent again");
}

/// Issue 31: at `--speed 100000` every robot's agent was started twice: a
/// robot deployed and judged in one `advance` (its start pose and the poses
/// of its dwell arrived together) left its prespawned successor looking not
/// started, and the successor was started again.
#[test]
fn a_robot_deployed_and_judged_at_once_starts_its_successor_once() {
    use bycoms_launch::core::{Input, LaunchCore, Output};
    use bycoms_protocol::msg::{FromAgent, Pose, ToAgent};
    use bycoms_protocol::RobotId;
    let case = Case::small(0);
    let schedule = Schedule { realtime: Some(100_000.0), ..Schedule::clean(0, case.robots) };
    let mut core = LaunchCore::new(harness::setup(&case, &schedule));
    let mut starts = vec![0; case.robots as usize];
    let mut deployed = false;
    let mut drain = |core: &mut LaunchCore, starts: &mut Vec<u32>| {
        while let Some(out) = core.poll() {
            match out {
                Output::Start(id) => starts[id as usize - 1] += 1,
                Output::Send(1, ToAgent::Deploy(_)) => deployed = true,
                _ => {}
            }
        }
        deployed
    };
    core.advance(0);
    drain(&mut core, &mut starts);
    core.handle(0, Input::Started { robot: 1, pid: Some(7), how: "started".into() });
    let register = simulated_register(1);
    core.handle(10, Input::Report(FromAgent::Register(register)));
    let mut now = 10;
    while !drain(&mut core, &mut starts) {
        core.advance(now);
        now += 1;
        assert!(now < 1_000_000, "robot 1 is told to deploy");
    }
    // Its start pose and two simulated seconds of standing still, at once.
    let start = case.terrain.start();
    for step in 0..=20 {
        let pose =
            Pose { robot: RobotId(1), x: start.x, y: start.y, heading: 0.0, step, time_us: step * 100_000 };
        core.handle(now, Input::Pose { topic: 1, pose });
    }
    core.advance(now);
    drain(&mut core, &mut starts);
    assert_eq!(core.slots()[0].state(), SlotState::Stuck, "deployed and judged in one advance");
    assert_eq!(starts[..2], [1, 1], "each agent started once");
}

/// `report` with every robot whose agent is still registering taken as
/// registered: a robot never deployed is not part of the run.
fn registered(mut report: Report) -> Report {
    for robot in report.robots.iter_mut().filter(|r| r.0 == SlotState::Spawned) {
        robot.0 = SlotState::Registered;
    }
    report
}

/// Issue 49: the progress line's "step" was the lockstep tick of the whole
/// run in lockstep and the robot's own count in real time (it went down
/// from robot 2 to robot 3). Each gate line says the robot's own steps
/// after its deployment, the summary's, on either clock.
#[test]
fn a_gate_line_says_the_robots_own_steps_on_either_clock() {
    for (seed, realtime) in [(0, None), (1, None), (0, Some(100.0)), (1, Some(100.0))] {
        let case = Case::small(seed);
        let schedule = Schedule { realtime, ..Schedule::clean(seed, case.robots) };
        let report = harness::run(&case, &schedule);
        harness::check(&report, &schedule).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let mut judged = 0;
        for (i, (state, steps, _)) in report.robots.iter().enumerate() {
            if !matches!(state, SlotState::Arrived | SlotState::Stuck | SlotState::Unfinished) {
                continue;
            }
            let head = format!("robot {}: ", i + 1);
            let line = report
                .notes
                .iter()
                .find(|n| n.starts_with(&head) && n.contains(" steps after its deployment"))
                .unwrap_or_else(|| panic!("seed {seed}, {realtime:?}: no gate line of robot {}", i + 1));
            assert!(line.ends_with(&format!(", {steps} steps after its deployment")), "{line}");
            judged += 1;
        }
        assert!(judged >= 2, "seed {seed}, {realtime:?}: {:?}", report.notes);
    }
}
