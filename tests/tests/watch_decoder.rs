//! `deploy/clients/watch.py` decodes what our encoder writes: its
//! hand-written postcard readers (PROTOCOL.md) against `encode_vec`, for
//! every message it prints and for the errors it must report. Needs only
//! `python3` (the decoder imports zenoh only in `main`).

use bycoms_protocol::msg::{
    ClockOffset, Commanded, DriveState, FailsafeFired, FromAgent, GateEvent, GateKind, LinkStatus, Parked,
    Pose, Register, RobotKind, Sensed, Status, StopDone, Telemetry,
};
use bycoms_protocol::{encode_vec, RobotId, PROTOCOL_VERSION};
use std::path::PathBuf;
use std::process::Command;

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Runs `expr` (Python, with `watch` imported) and returns what it printed.
fn python(expr: &str) -> String {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../deploy/clients");
    let script =
        format!("import sys; sys.path.insert(0, {:?}); import watch\n{expr}", dir.display().to_string());
    let out = Command::new("python3").args(["-c", &script]).output().expect("python3 runs");
    assert!(out.status.success(), "python failed: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("utf-8").trim().to_owned()
}

#[test]
fn watch_py_decodes_our_messages() {
    let pose =
        Pose { robot: RobotId(300), x: 1.0, y: -2.5, heading: 0.125, step: 70_000, time_us: 7_000_000 };
    let got = python(&format!(
        "p = watch.decode_pose(bytes.fromhex({:?})); print(p['robot'], p['x'], p['y'], p['heading'], p['step'], p['time_us'])",
        hex(&encode_vec(&pose).expect("encode"))
    ));
    assert_eq!(got, "300 1.0 -2.5 0.125 70000 7000000");

    let status = FromAgent::Status(Status { robot: RobotId(2), mode: 2, step: 129 });
    let got = python(&format!(
        "m = watch.decode_from_agent(bytes.fromhex({:?})); print(m['kind'], m['robot'], m['mode'], m['step'])",
        hex(&encode_vec(&status).expect("encode"))
    ));
    assert_eq!(got, "status 2 2 129");

    let telemetry = FromAgent::Telemetry(Telemetry {
        robot: RobotId(3),
        period: 200,
        state: DriveState::Failsafe,
        mode: 2,
        mics: [0.5, 1.0, 0.5, 0.25, 0.5, 1.0],
        v_ave: 0.625,
        gradient: Some(-0.25),
        left: 0.0,
        right: 0.0,
        battery_mv: 7400,
        health: 2,
        robot_drops: 300,
    });
    let got = python(&format!(
        "m = watch.decode_from_agent(bytes.fromhex({:?})); print(m['kind'], m['robot'], m['period'], m['state'], m['mode'], m['mics'], m['v_ave'], m['gradient'], m['battery_mv'], m['health'], m['robot_drops'])",
        hex(&encode_vec(&telemetry).expect("encode"))
    ));
    assert_eq!(got, "telemetry 3 200 2 2 [0.5, 1.0, 0.5, 0.25, 0.5, 1.0] 0.625 -0.25 7400 2 300");
    let link = FromAgent::Link(LinkStatus { robot: RobotId(2), up: false, silent_ms: 300, refused: 7 });
    let got = python(&format!(
        "m = watch.decode_from_agent(bytes.fromhex({:?})); print(m['kind'], m['robot'], m['up'], m['silent_ms'], m['refused'])",
        hex(&encode_vec(&link).expect("encode"))
    ));
    assert_eq!(got, "link 2 False 300 7");
    let register = FromAgent::Register(Register {
        robot: RobotId(4),
        kind: RobotKind::Real,
        protocol_version: PROTOCOL_VERSION,
        instance: 0x0123_4567_89ab_cdef,
        settings: 0xfedc_ba98_7654_3210,
        failsafe_grace_ms: 2500,
    });
    let got = python(&format!(
        "m = watch.decode_from_agent(bytes.fromhex({:?})); print(m['kind'], m['robot'], m['agent'], m['protocol_version'], hex(m['instance']), hex(m['settings']), m['failsafe_grace_ms'])",
        hex(&encode_vec(&register).expect("encode"))
    ));
    assert_eq!(got, format!("register 4 1 {PROTOCOL_VERSION} 0x123456789abcdef 0xfedcba9876543210 2500"));
    let fired = FromAgent::Failsafe(FailsafeFired { robot: RobotId(5), silent_ms: 2100 });
    let got = python(&format!(
        "m = watch.decode_from_agent(bytes.fromhex({:?})); print(m['kind'], m['robot'], m['silent_ms'])",
        hex(&encode_vec(&fired).expect("encode"))
    ));
    assert_eq!(got, "failsafe 5 2100");
    let parked = FromAgent::Parked(Parked { robot: RobotId(6), step: 300 });
    let got = python(&format!(
        "m = watch.decode_from_agent(bytes.fromhex({:?})); print(m['kind'], m['robot'], m['step'])",
        hex(&encode_vec(&parked).expect("encode"))
    ));
    assert_eq!(got, "parked 6 300");
    let clock = FromAgent::Clock(ClockOffset { robot: RobotId(2), offset_us: -1500, round_trip_us: 800 });
    let got = python(&format!(
        "m = watch.decode_from_agent(bytes.fromhex({:?})); print(m['kind'], m['robot'], m['offset_us'], m['round_trip_us'])",
        hex(&encode_vec(&clock).expect("encode"))
    ));
    assert_eq!(got, "clock 2 -1500 800");
    let done = FromAgent::StopDone(StopDone { robot: RobotId(4), on_link: true });
    let got = python(&format!(
        "m = watch.decode_from_agent(bytes.fromhex({:?})); print(m['kind'], m['robot'], m['on_link'])",
        hex(&encode_vec(&done).expect("encode"))
    ));
    assert_eq!(got, "stop_done 4 True");
    let sensed = Some(Sensed { intensity: 2.5, gradient: Some(-0.5) });
    let commanded = Commanded { robot: RobotId(3), step: 300, linear: 0.22, angular: -1.25, sensed };
    for (msg, printed) in [
        (commanded, "commanded 3 300 0.22 -1.25 {'intensity': 2.5, 'gradient': -0.5}"),
        (
            Commanded { sensed: Some(Sensed { intensity: 0.0, gradient: None }), ..commanded },
            "commanded 3 300 0.22 -1.25 {'intensity': 0.0, 'gradient': None}",
        ),
        (Commanded { sensed: None, ..commanded }, "commanded 3 300 0.22 -1.25 None"),
    ] {
        let got = python(&format!(
            "m = watch.decode_from_agent(bytes.fromhex({:?})); print(m['kind'], m['robot'], m['step'], m['linear'], m['angular'], m['sensed'])",
            hex(&encode_vec(&FromAgent::Commanded(msg)).expect("encode"))
        ));
        assert_eq!(got, printed);
    }

    for (kind, printed) in [
        (GateKind::Deployed, "deployed None"),
        (GateKind::Stopped { arrived: true }, "stopped True"),
        (GateKind::Stopped { arrived: false }, "stopped False"),
        (GateKind::Died, "died None"),
        (GateKind::Timeout, "timeout None"),
    ] {
        let event = GateEvent { robot: RobotId(3), kind, x: 44.5, y: -0.25, step: 1234 };
        let got = python(&format!(
            "e = watch.decode_gate(bytes.fromhex({:?})); print(e['robot'], e['kind'], e['arrived'], e['x'], e['y'], e['step'])",
            hex(&encode_vec(&event).expect("encode"))
        ));
        assert_eq!(got, format!("3 {printed} 44.5 -0.25 1234"));
    }
}

#[test]
fn watch_py_reports_bad_payloads() {
    let pose = encode_vec(&Pose { robot: RobotId(1), x: 0.0, y: 0.0, heading: 0.0, step: 1, time_us: 0 })
        .expect("encode");
    let mut other_version = pose.clone();
    other_version[0] = 1;
    let mut trailing = pose.clone();
    trailing.push(0);
    let truncated = &pose[..pose.len() - 1];
    for (bytes, why) in [
        (other_version, "protocol version 1"),
        (trailing, "1 trailing bytes"),
        (truncated.to_vec(), "truncated"),
        (vec![PROTOCOL_VERSION as u8, 2, 1, 9], "bad bool 9"),
    ] {
        let decoder = if why == "bad bool 9" { "decode_gate" } else { "decode_pose" };
        let got = python(&format!(
            "try:\n    watch.{decoder}(bytes.fromhex({:?}))\n    print('accepted')\nexcept watch.DecodeError as e:\n    print(e)",
            hex(&bytes)
        ));
        assert!(got.contains(why), "{why}: got {got}");
    }
    assert_eq!(
        python("print(watch.route('s', 'bycoms/s/robot/7/pose'), watch.route('s', 'bycoms/t/gate'), watch.route('s', 'bycoms/s/robot/7/from_agent'))"),
        "pose None from_agent"
    );
}
