//! Each firmware rule on virtual time, with the gateway side played by
//! `GatewayLink` and microphones synthesised as sums of sines.

use super::*;
use bycoms_protocol::link::{GatewayEvent, GatewayLink, SessionId, MAX_FRAME_LEN};
use core::f64::consts::TAU;

const ROBOT: RobotId = RobotId(2);
const KEY: [u8; 32] = [0x42; 32];

fn ms(t: u64) -> Micros {
    t * 1000
}

/// What the firmware sends first at `now` (one `poll` after `advance`).
fn send_at(fw: &mut Firmware<2>, now: Micros) -> Option<Vec<u8>> {
    fw.advance(now);
    fw.poll().map(<[u8]>::to_vec)
}

/// One datagram into the firmware at `now`: its event or refusal.
fn receive(fw: &mut Firmware<2>, bytes: &[u8], now: Micros) -> Handled {
    fw.handle(now, FirmwareInput::Datagram(bytes))
}

/// One microphone frame: ADC mid-scale plus sines (Hz, amplitude in
/// counts), rounded to the ADC's counts.
fn tone_frame(tones: &[(f64, f64)]) -> Frame {
    core::array::from_fn(|i| {
        let t = i as f64 / 4096.0;
        libm::round(2048.0 + tones.iter().map(|&(f, a)| a * libm::sin(TAU * f * t)).sum::<f64>()) as u16
    })
}

/// Six frames: the robot's own 320 Hz tone loud and equal everywhere, and
/// robot 1's 224 Hz tone with amplitude `mean` plus `slope`·cos(angle of the
/// mic − `towards`): a source in direction `towards` (robot frame).
fn mics(mean: f64, slope: f64, towards: f64) -> MicFrames {
    core::array::from_fn(|n| {
        let angle = TAU * n as f64 / MICS as f64;
        let a = mean + slope * libm::cos(angle - towards);
        tone_frame(&[(320.0, 400.0), (224.0, a)])
    })
}

struct Rig {
    fw: Firmware<2>,
    gw: GatewayLink,
    buf: [u8; MAX_FRAME_LEN],
}

impl Rig {
    fn new() -> Self {
        let config = FirmwareConfig::paper(ROBOT, 320.0, [224.0, 512.0]);
        let fw = Firmware::new(config, LinkKey::new(&KEY), [7; 32]).unwrap();
        Self { fw, gw: GatewayLink::new(ROBOT, LinkKey::new(&KEY)), buf: [0; MAX_FRAME_LEN] }
    }

    /// Everything the firmware wants to send at `now`, delivered to the gateway.
    fn robot_to_gateway(&mut self, now: Micros) -> Vec<GatewayEvent> {
        let mut events = vec![];
        self.fw.advance(now);
        while let Some(frame) = self.fw.poll() {
            let frame = frame.to_vec();
            if let Ok(accepted) = self.gw.receive(&frame) {
                events.push(accepted.event);
            }
        }
        events
    }

    fn connect(&mut self, now: Micros) {
        let events = self.robot_to_gateway(now);
        let Some(GatewayEvent::Hello(nonce)) = events.first().copied() else { panic!("{events:?}") };
        let welcome = self.gw.welcome(nonce, SessionId(99), &mut self.buf).unwrap().to_vec();
        assert!(matches!(receive(&mut self.fw, &welcome, now), Ok(Some(RobotEvent::Connected(_)))));
        self.robot_to_gateway(now + ms(100)); // the first frame in session confirms it
        assert_eq!(self.gw.session(), Some(SessionId(99)));
    }

    /// A gateway command, returned as bytes (so tests can replay it).
    fn command(&mut self, payload: Payload) -> Vec<u8> {
        self.gw.send(payload, &mut self.buf).unwrap().to_vec()
    }

    fn deliver(&mut self, payload: Payload, now: Micros) -> Vec<u8> {
        let bytes = self.command(payload);
        receive(&mut self.fw, &bytes, now).unwrap();
        bytes
    }

    fn control(&mut self, now: Micros, mean: f64, slope: f64, towards: f64) {
        let frames = mics(mean, slope, towards);
        assert_eq!(self.fw.handle(now, FirmwareInput::Mics(&frames)), Ok(None));
    }
}

#[test]
fn hello_is_repeated_until_welcomed_then_telemetry_flows() {
    let mut rig = Rig::new();
    let mut b = [0u8; MAX_FRAME_LEN];
    let first = send_at(&mut rig.fw, ms(0)).unwrap();
    assert!(send_at(&mut rig.fw, ms(100)).is_none(), "retry not yet due");
    assert_eq!(rig.fw.deadline(), Some(ms(250)));
    let again = send_at(&mut rig.fw, ms(250)).unwrap();
    assert_eq!(first, again, "the same hello (same nonce) until answered");
    let GatewayEvent::Hello(nonce) = rig.gw.receive(&again).unwrap().event else { panic!("hello expected") };
    let welcome = rig.gw.welcome(nonce, SessionId(1), &mut b).unwrap().to_vec();
    assert_eq!(receive(&mut rig.fw, &welcome, ms(300)), Ok(Some(RobotEvent::Connected(SessionId(1)))));
    rig.control(ms(500), 50.0, 0.0, 0.0);
    let events = rig.robot_to_gateway(ms(500));
    let [GatewayEvent::Telemetry(t)] = events[..] else { panic!("{events:?}") };
    assert_eq!((t.state, t.mode, t.link_drops), (RobotState::Idle, 1, 0));
    assert!((f64::from(t.v_ave) - 50.0 * 256.0).abs() < 50.0, "V_ave {}", t.v_ave);
    assert_eq!(rig.robot_to_gateway(ms(550)), vec![], "heartbeat not due yet");
    assert!(matches!(rig.robot_to_gateway(ms(600))[..], [GatewayEvent::Heartbeat { uptime_ms: 600 }]));
}

#[test]
fn enable_and_goal_drive_the_motors_with_the_paper_law() {
    let mut rig = Rig::new();
    rig.connect(ms(0));
    rig.deliver(Payload::Enable, ms(200));
    assert_eq!(rig.fw.tone(), Some(320.0));
    rig.control(ms(250), 40.0, 0.0, 0.0);
    assert_eq!(rig.fw.motors(), Motors::default(), "no goal yet");
    rig.deliver(Payload::Goal { bearing: 0.5 }, ms(300));
    rig.control(ms(375), 40.0, 0.0, 0.0);
    // Mode 1, goal 0.5 rad counter-clockwise: u = 100·wrap(0 − 0.5) = −50.
    let m = rig.fw.motors();
    assert!((m.left - 70.0).abs() < 1e-3 && (m.right - 170.0).abs() < 1e-3, "{m:?}");
    assert_eq!(rig.fw.state(), RobotState::Driving);
}

#[test]
fn failsafe_turns_the_motors_off_500_ms_after_the_last_valid_command() {
    let mut rig = Rig::new();
    rig.connect(ms(0));
    rig.deliver(Payload::Enable, ms(100));
    rig.deliver(Payload::Goal { bearing: 0.0 }, ms(100));
    rig.control(ms(200), 40.0, 0.0, 0.0);
    assert_eq!(rig.fw.motors(), Motors { left: 120.0, right: 120.0 });
    for t in [200, 300, 400, 500] {
        assert_eq!(rig.fw.deadline(), Some(ms(t)), "heartbeat (or telemetry) due");
        rig.robot_to_gateway(ms(t));
    }
    assert_eq!(rig.fw.deadline(), Some(ms(600)), "the failsafe deadline (and a heartbeat)");
    rig.fw.advance(ms(599));
    assert_eq!(rig.fw.state(), RobotState::Driving);
    assert_ne!(rig.fw.motors(), Motors::default());
    rig.fw.advance(ms(600));
    assert_eq!(rig.fw.state(), RobotState::Failsafe);
    assert_eq!(rig.fw.motors(), Motors::default());
    rig.control(ms(700), 40.0, 0.0, 0.0);
    assert_eq!(rig.fw.motors(), Motors::default(), "a control period does not restart them");
    assert_eq!(rig.fw.last_telemetry().map(|t| t.state), Some(RobotState::Failsafe));
    // Heartbeats are not commands; a fresh goal is.
    let hb = rig.command(Payload::GatewayHeartbeat { uptime_ms: 1 });
    receive(&mut rig.fw, &hb, ms(750)).unwrap();
    rig.control(ms(800), 40.0, 0.0, 0.0);
    assert_eq!(rig.fw.motors(), Motors::default());
    rig.deliver(Payload::Goal { bearing: 0.0 }, ms(850));
    rig.control(ms(900), 40.0, 0.0, 0.0);
    assert_eq!(rig.fw.motors(), Motors { left: 120.0, right: 120.0 });
}

#[test]
fn stop_turns_the_motors_off_until_enabled_and_keeps_the_tone() {
    let mut rig = Rig::new();
    rig.connect(ms(0));
    assert_eq!(rig.fw.tone(), None, "silent until deployed");
    rig.deliver(Payload::Enable, ms(100));
    rig.deliver(Payload::Goal { bearing: 0.0 }, ms(100));
    rig.control(ms(150), 40.0, 0.0, 0.0);
    rig.deliver(Payload::Stop, ms(200));
    assert_eq!(rig.fw.motors(), Motors::default());
    assert_eq!(rig.fw.state(), RobotState::Stopped);
    rig.deliver(Payload::Goal { bearing: 0.0 }, ms(250));
    rig.control(ms(300), 40.0, 0.0, 0.0);
    assert_eq!(rig.fw.motors(), Motors::default(), "a goal alone does not re-enable");
    assert_eq!(rig.fw.tone(), Some(320.0), "a stopped robot is a beacon");
    rig.deliver(Payload::Enable, ms(350));
    rig.control(ms(400), 40.0, 0.0, 0.0);
    assert_ne!(rig.fw.motors(), Motors::default());
}

#[test]
fn replayed_and_forged_commands_never_move_the_robot() {
    let mut rig = Rig::new();
    rig.connect(ms(0));
    let enable = rig.deliver(Payload::Enable, ms(100));
    let goal = rig.deliver(Payload::Goal { bearing: 0.0 }, ms(100));
    rig.deliver(Payload::Stop, ms(200));
    // A sniffer replays the captured enable and goal.
    assert_eq!(receive(&mut rig.fw, &enable, ms(300)), Err(DropReason::Replayed));
    assert_eq!(receive(&mut rig.fw, &goal, ms(300)), Err(DropReason::Replayed));
    // A forger without the key, and a frame for another robot.
    let mut forged = rig.command(Payload::Enable);
    forged[20 - 2] ^= 1;
    assert_eq!(receive(&mut rig.fw, &forged, ms(300)), Err(DropReason::BadTag));
    let mut foreign = enable.clone();
    foreign[2] = 3;
    assert_eq!(receive(&mut rig.fw, &foreign, ms(300)), Err(DropReason::ForeignRobot));
    assert_eq!(receive(&mut rig.fw, b"garbage", ms(300)), Err(DropReason::Truncated));
    rig.control(ms(350), 40.0, 0.0, 0.0);
    assert_eq!(rig.fw.motors(), Motors::default());
    assert_eq!(rig.fw.state(), RobotState::Stopped);
    assert_eq!(rig.fw.drops().total(), 5);
    assert_eq!(rig.fw.last_telemetry().map(|t| t.link_drops), Some(5));
}

#[test]
fn a_silent_link_is_left_and_a_new_session_starts_disabled() {
    let mut rig = Rig::new();
    rig.connect(ms(0));
    let mut b = [0u8; MAX_FRAME_LEN];
    rig.deliver(Payload::Enable, ms(100));
    rig.deliver(Payload::Goal { bearing: 0.0 }, ms(100));
    let old = rig.command(Payload::Goal { bearing: 0.0 });
    // The gateway goes silent; heartbeats keep going out, no frames come in.
    for t in (200..1100).step_by(100) {
        send_at(&mut rig.fw, ms(t));
    }
    assert!(rig.fw.connected());
    let hello = send_at(&mut rig.fw, ms(1100)).unwrap();
    assert!(!rig.fw.connected());
    assert_eq!(hello[1], 0x01, "a hello");
    assert_eq!(receive(&mut rig.fw, &old, ms(1150)), Err(DropReason::NoSession));
    let accepted = rig.gw.receive(&hello).unwrap();
    let GatewayEvent::Hello(nonce) = accepted.event else { panic!() };
    let welcome = rig.gw.welcome(nonce, SessionId(100), &mut b).unwrap().to_vec();
    assert_eq!(receive(&mut rig.fw, &welcome, ms(1200)), Ok(Some(RobotEvent::Connected(SessionId(100)))));
    assert_eq!(rig.fw.state(), RobotState::Idle, "a new session must be enabled again");
}

#[test]
fn field_readings_give_gradient_and_mode_2_near_a_loud_source() {
    let mut rig = Rig::new();
    rig.connect(ms(0));
    rig.deliver(Payload::Enable, ms(100));
    // Goal straight ahead; robot 1 ahead-left (0.6 rad) and loud: V_ave ≈
    // 120·256 = 30720 > V_target, gradient within π/2 of the goal → mode 2.
    rig.deliver(Payload::Goal { bearing: 0.0 }, ms(100));
    rig.control(ms(150), 120.0, 20.0, 0.6);
    let t = *rig.fw.last_telemetry().unwrap();
    assert_eq!(t.mode, 2);
    let g = f64::from(t.gradient.unwrap());
    assert!((g - 0.6).abs() < 0.01, "gradient {g}");
    assert!((f64::from(t.v_ave) - 120.0 * 256.0).abs() < 100.0);
    // Per mic: V_n = 256·(120 + 20 cos(θ_n − 0.6)).
    for (n, v) in t.mics.iter().enumerate() {
        let want = 256.0 * (120.0 + 20.0 * libm::cos(TAU * n as f64 / 6.0 - 0.6));
        assert!((f64::from(*v) - want).abs() < 0.01 * want, "mic {n}: {v} vs {want}");
    }
    // The own 320 Hz tone (400 counts) is not part of any V_n, and the
    // clipping flag stays clear.
    assert_eq!(t.health, Health(0));
}

#[test]
fn health_flags_report_clipping_and_low_battery() {
    let mut rig = Rig::new();
    rig.fw.set_battery(4500);
    let mut frames = mics(40.0, 0.0, 0.0);
    frames[3][10] = 4095;
    rig.fw.handle(ms(10), FirmwareInput::Mics(&frames)).unwrap();
    let h = rig.fw.last_telemetry().unwrap().health.0;
    assert_eq!(h, Health::LOW_BATTERY | Health::MIC_CLIPPING);
}

#[test]
fn nonces_differ_across_boots_and_attempts() {
    let config = FirmwareConfig::paper(ROBOT, 320.0, [224.0, 512.0]);
    let hello_nonce = |entropy: [u8; 32]| {
        let mut fw = Firmware::new(config, LinkKey::new(&KEY), entropy).unwrap();
        send_at(&mut fw, ms(0)).unwrap()[18..34].to_vec()
    };
    assert_ne!(hello_nonce([1; 32]), hello_nonce([2; 32]));
    assert_eq!(hello_nonce([1; 32]), hello_nonce([1; 32]), "deterministic for a given entropy");
}

#[test]
fn an_enable_goes_idle_to_driving_without_a_failsafe_in_between() {
    // The gateway enables, then sends the first goal bearing: the robot is
    // waiting for that goal (motors off, Idle), not in failsafe; failsafe
    // is only for commands gone stale.
    let mut rig = Rig::new();
    rig.connect(ms(0));
    let mut states = vec![rig.fw.state()];
    let mut record = |s: RobotState| {
        if states.last() != Some(&s) {
            states.push(s);
        }
    };
    rig.deliver(Payload::Enable, ms(100));
    record(rig.fw.state());
    rig.control(ms(150), 40.0, 0.0, 0.0);
    record(rig.fw.state());
    assert_eq!(rig.fw.motors(), Motors::default(), "no goal yet: motors off");
    rig.deliver(Payload::Goal { bearing: 0.0 }, ms(200));
    record(rig.fw.state());
    assert_eq!(states, [RobotState::Idle, RobotState::Driving]);
    // Enabled, no goal, and no command for 500 ms: that is a failsafe.
    let mut rig = Rig::new();
    rig.connect(ms(0));
    rig.deliver(Payload::Enable, ms(100));
    rig.fw.advance(ms(600));
    assert_eq!(rig.fw.state(), RobotState::Failsafe);
}
