//! The gateway's rules against a robot's side of the link (`RobotLink`),
//! with no sockets and a hand-driven clock.

use super::*;
use bycoms_protocol::link::{Health, RobotEvent, RobotLink, Telemetry as LinkTelemetry};
use bycoms_protocol::msg::{Deploy, GoalBearing, Tick};
use core::f64::consts::{FRAC_PI_2, PI};

const ROBOT: SocketAddr = SocketAddr::V4(std::net::SocketAddrV4::new(std::net::Ipv4Addr::LOCALHOST, 4000));

fn key(b: u8) -> LinkKey {
    LinkKey::new(&[b; 32])
}

struct Bench {
    gw: GatewayCore,
    robot: RobotLink,
    t0: Micros,
}

impl Bench {
    fn new() -> Self {
        let t0: Micros = 0;
        let gw = GatewayCore::new(RobotId(1), key(7), Timers::paper(1.0), 42, t0);
        Self { gw, robot: RobotLink::new(RobotId(1), key(7)), t0 }
    }

    /// `ms` after the start, in the core's µs.
    fn at(&self, ms: u64) -> Micros {
        self.t0 + ms * 1000
    }

    fn outputs(&mut self) -> Vec<Output> {
        std::iter::from_fn(|| self.gw.poll()).collect()
    }

    /// Delivers every queued datagram to the robot; returns its events and
    /// the reports.
    fn deliver(&mut self) -> (Vec<RobotEvent>, Vec<FromAgent>) {
        let (mut events, mut reports) = (vec![], vec![]);
        for o in self.outputs() {
            match o {
                Output::Datagram(bytes, to) => {
                    assert_eq!(to, ROBOT);
                    events.push(self.robot.receive(&bytes).expect("the robot accepts the gateway's frames"));
                }
                Output::Report(r) => reports.push(r),
            }
        }
        (events, reports)
    }

    fn robot_sends(&mut self, payload: Payload, ms: u64) -> Result<(), DropReason> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = self.robot.send(payload, &mut buf).expect("robot frame").to_vec();
        self.gw.on_datagram(self.at(ms), &frame, ROBOT)
    }

    fn connect(&mut self) {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let hello = self.robot.hello([9; 16], &mut buf).unwrap().to_vec();
        self.gw.on_datagram(self.at(0), &hello, ROBOT).unwrap();
        let (events, reports) = self.deliver();
        assert!(matches!(events[..], [RobotEvent::Connected(_)]), "{events:?}");
        assert!(matches!(reports[..], [FromAgent::Link(LinkStatus { up: true, .. })]), "{reports:?}");
    }
}

fn telemetry(state: RobotState) -> Payload {
    Payload::Telemetry(LinkTelemetry {
        step: 5,
        state,
        mode: 2,
        mics: [1.0; 6],
        v_ave: 1.0,
        gradient: Some(0.5),
        left: 10.0,
        right: 20.0,
        battery_mv: 7400,
        health: Health(0),
        link_drops: 0,
    })
}

#[test]
fn a_hello_gets_a_welcome_and_telemetry_comes_out_as_status_and_telemetry() {
    let mut b = Bench::new();
    b.connect();
    b.robot_sends(telemetry(RobotState::Idle), 10).unwrap();
    let (_, reports) = b.deliver();
    let [FromAgent::Status(s), FromAgent::Telemetry(t)] = reports[..] else { panic!("{reports:?}") };
    assert_eq!((s.robot, s.mode, s.step), (RobotId(1), 2, 5));
    assert_eq!((t.period, t.v_ave, t.gradient, t.left, t.right), (5, 1.0, Some(0.5), 10.0, 20.0));
}

#[test]
fn deploy_enables_and_goal_bearings_reach_the_robot_in_its_own_frame() {
    let mut b = Bench::new();
    b.connect();
    b.robot_sends(telemetry(RobotState::Idle), 10).unwrap();
    b.deliver();
    let deploy = Deploy { robot: RobotId(1), x: 0.4, y: 1.0, heading: 0.0 };
    assert_eq!(b.gw.on_command(b.at(20), &ToAgent::Deploy(deploy)), Ok(false));
    // No pose yet: the goal waits (the robot's failsafe keeps it still).
    b.gw.on_command(b.at(21), &ToAgent::GoalBearing(GoalBearing { robot: RobotId(1), bearing: PI, step: 1 }))
        .unwrap();
    assert_eq!(b.deliver().0, [RobotEvent::Enable]);
    b.gw.on_pose(&Pose { robot: RobotId(1), x: 0.4, y: 1.0, heading: FRAC_PI_2, step: 1, time_us: 0 });
    b.gw.advance(b.at(22));
    let (events, _) = b.deliver();
    let [RobotEvent::Goal(g)] = events[..] else { panic!("{events:?}") };
    assert!(
        (f64::from(g) - FRAC_PI_2).abs() < 1e-6,
        "world π at heading π/2 is +π/2 in the robot frame: {g}"
    );
    // Repeated every 100 ms while enabled, with the newest heading.
    b.gw.on_pose(&Pose { robot: RobotId(1), x: 0.4, y: 1.0, heading: PI, step: 2, time_us: 0 });
    b.gw.advance(b.at(100));
    assert!(b.deliver().0.is_empty(), "not yet due");
    b.gw.advance(b.at(122));
    assert_eq!(b.deliver().0, [RobotEvent::Goal(0.0)]);
    // Stop: no more goals, Stop on the wire; Shutdown stops too and says exit.
    b.gw.on_command(b.at(130), &ToAgent::Stop).unwrap();
    let stop_done = FromAgent::StopDone(StopDone { robot: RobotId(1), on_link: true });
    assert_eq!(b.deliver(), (vec![RobotEvent::Stop], vec![stop_done]), "answered once the stop frame is out");
    b.gw.advance(b.at(300));
    assert!(!b.deliver().0.contains(&RobotEvent::Goal(0.0)));
    assert_eq!(b.gw.on_command(b.at(310), &ToAgent::Shutdown), Ok(true));
    assert_eq!(b.deliver().0, [RobotEvent::Stop]);
}

#[test]
fn a_robot_that_reports_idle_while_enabled_is_enabled_again() {
    let mut b = Bench::new();
    b.connect();
    b.gw.on_command(b.at(5), &ToAgent::Deploy(Deploy { robot: RobotId(1), x: 0.0, y: 0.0, heading: 0.0 }))
        .unwrap();
    b.outputs(); // the Enable is lost on the way
    b.robot_sends(telemetry(RobotState::Idle), 130).unwrap();
    assert!(b.deliver().0.contains(&RobotEvent::Enable));
}

#[test]
fn silence_is_reported_as_a_lost_link_at_the_timeout_and_the_next_frame_restores_it() {
    let mut b = Bench::new();
    b.connect();
    b.robot_sends(Payload::RobotHeartbeat { uptime_ms: 1 }, 100).unwrap();
    b.deliver();
    b.gw.advance(b.at(399));
    assert!(b.deliver().1.is_empty(), "299 ms of silence is not yet lost");
    b.gw.advance(b.at(400));
    let (_, reports) = b.deliver();
    assert!(
        matches!(reports[..], [FromAgent::Link(LinkStatus { up: false, silent_ms: 300, .. })]),
        "{reports:?}"
    );
    assert!(!b.gw.link_up());
    b.robot_sends(Payload::RobotHeartbeat { uptime_ms: 2 }, 900).unwrap();
    let (_, reports) = b.deliver();
    assert!(
        matches!(reports[..], [FromAgent::Link(LinkStatus { up: true, silent_ms: 800, .. })]),
        "{reports:?}"
    );
}

#[test]
fn forged_replayed_and_foreign_frames_are_refused_counted_and_reported_once_a_second() {
    let mut b = Bench::new();
    b.connect();
    let mut buf = [0u8; MAX_FRAME_LEN];
    let frame = b.robot.send(telemetry(RobotState::Idle), &mut buf).unwrap().to_vec();
    b.gw.on_datagram(b.at(10), &frame, ROBOT).unwrap();
    assert_eq!(b.gw.on_datagram(b.at(11), &frame, ROBOT), Err(DropReason::Replayed));
    let mut forged = frame.clone();
    forged[30] ^= 1;
    assert_eq!(b.gw.on_datagram(b.at(12), &forged, ROBOT), Err(DropReason::BadTag));
    let mut other = RobotLink::new(RobotId(2), key(8));
    let foreign = other.hello([1; 16], &mut buf).unwrap().to_vec();
    assert_eq!(b.gw.on_datagram(b.at(13), &foreign, ROBOT), Err(DropReason::ForeignRobot));
    assert_eq!(b.gw.on_datagram(b.at(14), b"garbage", ROBOT), Err(DropReason::Truncated));
    b.outputs();
    b.gw.advance(b.at(15));
    let reports: Vec<_> = b.outputs();
    let link = |o: &Output| match o {
        Output::Report(FromAgent::Link(l)) => Some(*l),
        _ => None,
    };
    let got: Vec<LinkStatus> = reports.iter().filter_map(link).collect();
    assert_eq!(got, [LinkStatus { robot: RobotId(1), up: true, silent_ms: 5, refused: 4 }]);
    b.gw.on_datagram(b.at(20), &forged, ROBOT).unwrap_err();
    b.robot_sends(Payload::RobotHeartbeat { uptime_ms: 1 }, 890).unwrap();
    b.gw.advance(b.at(900));
    assert!(b.outputs().iter().filter_map(link).next().is_none(), "at most once a second");
    b.robot_sends(Payload::RobotHeartbeat { uptime_ms: 2 }, 1010).unwrap();
    b.gw.advance(b.at(1015));
    assert_eq!(b.outputs().iter().filter_map(link).map(|l| l.refused).collect::<Vec<_>>(), [5]);
    assert_eq!(b.gw.drops().count(DropReason::Replayed), 1);
}

#[test]
fn commands_for_another_robot_ticks_and_non_finite_bearings_are_refused() {
    let mut b = Bench::new();
    let now = b.at(0);
    let other = Deploy { robot: RobotId(2), x: 0.0, y: 0.0, heading: 0.0 };
    assert_eq!(b.gw.on_command(now, &ToAgent::Deploy(other)), Err(Refused::WrongRobot { got: 2, mine: 1 }));
    assert_eq!(b.gw.on_command(now, &ToAgent::Tick(Tick { step: 1 })), Err(Refused::Tick));
    let nan = GoalBearing { robot: RobotId(1), bearing: f64::NAN, step: 1 };
    assert_eq!(b.gw.on_command(now, &ToAgent::GoalBearing(nan)), Err(Refused::NotFinite));
}
