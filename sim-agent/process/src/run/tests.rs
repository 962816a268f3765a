//! A lost `Register` is made good: the agent repeats it with every
//! heartbeat until the orchestrator has sent it something, and then stops.
//! A repeated `Tick` or `Deploy` (re-sent across a cut link) is answered
//! again and never stepped twice. A robot that will never move again says
//! so (`Parked`) with every tick it still gets.

use super::*;
use bycoms_protocol::bus::memory::MemoryBus;
use bycoms_protocol::bus::Limits;
use bycoms_protocol::msg::{StopDone, Tick};
use bycoms_runtime::lifeline::Lifeline;
use bycoms_sim::terrain::Terrain;
use bycoms_sim::RunConfig;

/// Reads reports until `heartbeats` heartbeats came; returns the number of
/// `Register`s among them (panics after 10 s).
fn registers_over(
    reports: &TypedSubscriber<impl bycoms_protocol::bus::Subscribe, FromAgent>,
    heartbeats: u32,
) -> u32 {
    let deadline = Instant::now() + Duration::from_secs(10);
    let (mut seen, mut registers) = (0, 0);
    while seen < heartbeats {
        assert!(Instant::now() < deadline, "only {seen} heartbeats within 10 s");
        match reports.recv_timeout(Duration::from_millis(50)).expect("receive") {
            Some(FromAgent::Heartbeat(_)) => seen += 1,
            Some(FromAgent::Register(r)) => {
                assert_eq!(r.robot, RobotId(1));
                registers += 1;
            }
            _ => {}
        }
    }
    registers
}

type Commands = TypedPublisher<<MemoryBus as Bus>::Publisher, ToAgent>;
type AgentThread = std::thread::JoinHandle<Result<ExitCause, BusError>>;

/// Robot 1's lockstep agent on `bus`, running in a thread, and a publisher
/// of its commands.
fn start_agent(bus: &MemoryBus, swarm: &Swarm, heartbeat: Duration) -> (Commands, AgentThread) {
    let commands = bus.typed_publisher::<ToAgent>(&swarm.to_agent(RobotId(1))).expect("commands");
    let ports = AgentPorts::open(bus, swarm, RobotId(1)).expect("ports");
    let timing = Timing {
        clock: Clock::Lockstep,
        period: Duration::from_millis(100),
        dt_us: 100_000,
        heartbeat,
        parked_heartbeat: heartbeat,
    };
    let agent = std::thread::spawn(move || {
        let core = RobotCore::new(RobotId(1), Terrain::paper(), RunConfig::paper(2.0));
        Agent::new(core, ports, timing).run(&mut Lifeline::detached())
    });
    (commands, agent)
}

#[test]
fn register_is_repeated_until_the_orchestrator_answers() {
    let bus = MemoryBus::new(Limits::default()).expect("memory bus");
    let swarm = Swarm::new("reg").expect("swarm name");
    let reports = bus.typed_subscriber::<FromAgent>(&swarm.from_agent(RobotId(1))).expect("reports");
    let (commands, agent) = start_agent(&bus, &swarm, Duration::from_millis(5));
    // Unanswered: the first Register, then one with every heartbeat after
    // the first.
    let unanswered = registers_over(&reports, 6);
    assert!(unanswered >= 5, "{unanswered} registrations over 6 heartbeats");
    commands.publish(&ToAgent::Tick(Tick { step: 1 })).expect("tick");
    // Let the tick be taken (its TickDone answers it), then no more.
    let deadline = Instant::now() + Duration::from_secs(10);
    while !matches!(
        reports.recv_timeout(Duration::from_millis(50)).expect("receive"),
        Some(FromAgent::TickDone(_))
    ) {
        assert!(Instant::now() < deadline, "no TickDone within 10 s");
    }
    assert_eq!(registers_over(&reports, 6), 0, "registrations after the orchestrator answered");
    commands.publish(&ToAgent::Shutdown).expect("shutdown");
    let cause = agent.join().expect("agent thread").expect("agent run");
    assert_eq!(cause, ExitCause::Shutdown);
}

/// The next pose on `poses` (panics after 10 s).
fn next_pose(poses: &TypedSubscriber<impl bycoms_protocol::bus::Subscribe, Pose>) -> Pose {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        assert!(Instant::now() < deadline, "no pose within 10 s");
        if let Some(p) = poses.recv_timeout(Duration::from_millis(50)).expect("receive") {
            return p;
        }
    }
}

/// The next `TickDone`'s step (panics after 10 s).
fn next_tick_done(reports: &TypedSubscriber<impl bycoms_protocol::bus::Subscribe, FromAgent>) -> u64 {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        assert!(Instant::now() < deadline, "no TickDone within 10 s");
        if let Some(FromAgent::TickDone(t)) =
            reports.recv_timeout(Duration::from_millis(50)).expect("receive")
        {
            return t.step;
        }
    }
}

#[test]
fn a_repeated_tick_or_deploy_is_answered_again_without_stepping() {
    use bycoms_protocol::msg::{Deploy, GoalBearing};
    let bus = MemoryBus::new(Limits::default()).expect("memory bus");
    let swarm = Swarm::new("repeat").expect("swarm name");
    let reports = bus.typed_subscriber::<FromAgent>(&swarm.from_agent(RobotId(1))).expect("reports");
    let poses = bus.typed_subscriber::<Pose>(&swarm.pose(RobotId(1))).expect("poses");
    let (commands, agent) = start_agent(&bus, &swarm, Duration::from_millis(50));
    let deploy = Deploy { robot: RobotId(1), x: 15.5, y: 15.5, heading: 0.7 };
    commands.publish(&ToAgent::Deploy(deploy)).expect("deploy");
    let start = next_pose(&poses);
    // A repeated Deploy: answered with the same pose, not refused.
    commands.publish(&ToAgent::Deploy(deploy)).expect("deploy again");
    assert_eq!(next_pose(&poses), start);
    let bearing = |step| ToAgent::GoalBearing(GoalBearing { robot: RobotId(1), bearing: 0.7, step });
    commands.publish(&bearing(1)).expect("bearing");
    commands.publish(&ToAgent::Tick(Tick { step: 1 })).expect("tick 1");
    assert_eq!(next_tick_done(&reports), 1);
    let first = next_pose(&poses);
    assert_eq!(first.step, 1);
    assert_ne!((first.x, first.y), (start.x, start.y), "tick 1 moved the robot");
    // The same tick again (its answer was lost): the same pose, answered again.
    commands.publish(&bearing(1)).expect("bearing again");
    commands.publish(&ToAgent::Tick(Tick { step: 1 })).expect("tick 1 again");
    assert_eq!(next_tick_done(&reports), 1);
    assert_eq!(next_pose(&poses), first, "a repeated tick does not step");
    commands.publish(&bearing(2)).expect("bearing 2");
    commands.publish(&ToAgent::Tick(Tick { step: 2 })).expect("tick 2");
    assert_eq!(next_tick_done(&reports), 2);
    assert_eq!(next_pose(&poses).step, 2);
    commands.publish(&ToAgent::Shutdown).expect("shutdown");
    assert_eq!(agent.join().expect("agent thread").expect("agent run"), ExitCause::Shutdown);
}

/// The reports up to and with the next `TickDone`, heartbeats and
/// statuses left out (panics after 10 s).
fn reports_of_a_tick(
    reports: &TypedSubscriber<impl bycoms_protocol::bus::Subscribe, FromAgent>,
) -> Vec<FromAgent> {
    let deadline = Instant::now() + Duration::from_secs(10);
    let mut got = Vec::new();
    loop {
        assert!(Instant::now() < deadline, "no TickDone within 10 s (got {got:?})");
        match reports.recv_timeout(Duration::from_millis(50)).expect("receive") {
            Some(FromAgent::Heartbeat(_) | FromAgent::Status(_) | FromAgent::Register(_)) | None => {}
            Some(done @ FromAgent::TickDone(_)) => {
                got.push(done);
                return got;
            }
            Some(other) => got.push(other),
        }
    }
}

#[test]
fn a_stopped_robot_says_it_is_parked_with_every_tick_it_still_gets() {
    use bycoms_protocol::msg::{Deploy, GoalBearing, Parked, TickDone};
    let bus = MemoryBus::new(Limits::default()).expect("memory bus");
    let swarm = Swarm::new("parked").expect("swarm name");
    let reports = bus.typed_subscriber::<FromAgent>(&swarm.from_agent(RobotId(1))).expect("reports");
    let poses = bus.typed_subscriber::<Pose>(&swarm.pose(RobotId(1))).expect("poses");
    let (commands, agent) = start_agent(&bus, &swarm, Duration::from_millis(50));
    let deploy = Deploy { robot: RobotId(1), x: 15.5, y: 15.5, heading: 0.7 };
    commands.publish(&ToAgent::Deploy(deploy)).expect("deploy");
    next_pose(&poses);
    let tick = |step| {
        let bearing = GoalBearing { robot: RobotId(1), bearing: 0.7, step };
        commands.publish(&ToAgent::GoalBearing(bearing)).expect("bearing");
        commands.publish(&ToAgent::Tick(Tick { step })).expect("tick");
    };
    let done = |step| FromAgent::TickDone(TickDone { robot: RobotId(1), step });
    let parked = |step| FromAgent::Parked(Parked { robot: RobotId(1), step });
    // Moving: no `Parked`.
    tick(1);
    assert_eq!(reports_of_a_tick(&reports), vec![done(1)]);
    let moving = next_pose(&poses);
    commands.publish(&ToAgent::Stop).expect("stop");
    // Stopped: the `Stop` answered at once, then `Parked` before each
    // `TickDone`, and the pose stands.
    let stop_done = FromAgent::StopDone(StopDone { robot: RobotId(1), on_link: false });
    for step in [2, 3] {
        tick(step);
        let mut expected = if step == 2 { vec![stop_done] } else { vec![] };
        expected.extend([parked(step), done(step)]);
        assert_eq!(reports_of_a_tick(&reports), expected);
        let pose = next_pose(&poses);
        assert_eq!((pose.x, pose.y, pose.heading, pose.step), (moving.x, moving.y, moving.heading, step));
    }
    // A repeated tick of a parked robot is answered the same way.
    tick(3);
    assert_eq!(reports_of_a_tick(&reports), vec![parked(3), done(3)]);
    commands.publish(&ToAgent::Shutdown).expect("shutdown");
    assert_eq!(agent.join().expect("agent thread").expect("agent run"), ExitCause::Shutdown);
}
