//! Round trip of every message variant over arbitrary field values, and the
//! proof that the largest encoding fits `MAX_MESSAGE_LEN`.

use bycoms_protocol::msg::*;
use bycoms_protocol::{decode, encode, Message, RobotId, MAX_MESSAGE_LEN};
use core::fmt::Debug;
use proptest::prelude::*;

fn robot() -> impl Strategy<Value = RobotId> {
    any::<u32>().prop_map(RobotId)
}

/// Any f64 bit pattern, NaNs and infinities included.
fn float() -> impl Strategy<Value = f64> {
    any::<u64>().prop_map(f64::from_bits)
}

fn pose() -> impl Strategy<Value = Pose> {
    (robot(), float(), float(), float(), any::<u64>(), any::<u64>())
        .prop_map(|(robot, x, y, heading, step, time_us)| Pose { robot, x, y, heading, step, time_us })
}

fn to_agent() -> impl Strategy<Value = ToAgent> {
    prop_oneof![
        (robot(), float(), float(), float()).prop_map(|(robot, x, y, heading)| ToAgent::Deploy(Deploy {
            robot,
            x,
            y,
            heading
        })),
        (robot(), float(), any::<u64>()).prop_map(|(robot, bearing, step)| {
            ToAgent::GoalBearing(GoalBearing { robot, bearing, step })
        }),
        any::<u64>().prop_map(|step| ToAgent::Tick(Tick { step })),
        (any::<u64>(), any::<u32>()).prop_map(|(step, count)| ToAgent::Ticks(Ticks { step, count })),
        Just(ToAgent::Stop),
        Just(ToAgent::Shutdown),
        (robot(), any::<u64>(), refusal()).prop_map(|(robot, instance, why)| ToAgent::Refused(Refused {
            robot,
            instance,
            why
        })),
    ]
}

fn refusal() -> impl Strategy<Value = Refusal> {
    prop_oneof![
        Just(Refusal::Duplicate),
        any::<u64>().prop_map(|launch| Refusal::Settings { launch }),
        any::<u32>().prop_map(|launch_ms| Refusal::Grace { launch_ms }),
        Just(Refusal::Revoked),
        (any::<i32>(), any::<u32>()).prop_map(|(offset_ms, limit_ms)| Refusal::Clock { offset_ms, limit_ms }),
    ]
}

/// Any f32 bit pattern, NaNs and infinities included.
fn float32() -> impl Strategy<Value = f32> {
    any::<u32>().prop_map(f32::from_bits)
}

fn telemetry() -> impl Strategy<Value = Telemetry> {
    let state = prop_oneof![
        Just(DriveState::Idle),
        Just(DriveState::Driving),
        Just(DriveState::Failsafe),
        Just(DriveState::Stopped),
    ];
    let head = (robot(), any::<u32>(), state, any::<u8>(), prop::array::uniform6(float32()), float32());
    let tail = (prop::option::of(float32()), float32(), float32(), any::<u16>(), any::<u8>(), any::<u32>());
    (head, tail).prop_map(
        |(
            (robot, period, state, mode, mics, v_ave),
            (gradient, left, right, battery_mv, health, robot_drops),
        )| {
            Telemetry {
                robot,
                period,
                state,
                mode,
                mics,
                v_ave,
                gradient,
                left,
                right,
                battery_mv,
                health,
                robot_drops,
            }
        },
    )
}

fn from_agent() -> impl Strategy<Value = FromAgent> {
    let kind = prop_oneof![Just(RobotKind::Simulated), Just(RobotKind::Real)];
    prop_oneof![
        (robot(), kind, any::<u16>(), any::<u64>(), any::<u64>(), any::<u32>()).prop_map(
            |(robot, kind, protocol_version, instance, settings, failsafe_grace_ms)| {
                FromAgent::Register(Register {
                    robot,
                    kind,
                    protocol_version,
                    instance,
                    settings,
                    failsafe_grace_ms,
                })
            }
        ),
        (robot(), any::<u64>()).prop_map(|(robot, seq)| FromAgent::Heartbeat(Heartbeat { robot, seq })),
        (robot(), any::<u8>(), any::<u64>()).prop_map(|(robot, mode, step)| FromAgent::Status(Status {
            robot,
            mode,
            step
        })),
        (robot(), any::<u64>()).prop_map(|(robot, step)| FromAgent::TickDone(TickDone { robot, step })),
        telemetry().prop_map(FromAgent::Telemetry),
        (robot(), any::<bool>(), any::<u32>(), any::<u32>()).prop_map(|(robot, up, silent_ms, refused)| {
            FromAgent::Link(LinkStatus { robot, up, silent_ms, refused })
        }),
        (robot(), any::<u32>())
            .prop_map(|(robot, silent_ms)| FromAgent::Failsafe(FailsafeFired { robot, silent_ms })),
        (robot(), any::<u64>()).prop_map(|(robot, step)| FromAgent::Parked(Parked { robot, step })),
        (robot(), any::<i64>(), any::<u32>()).prop_map(|(robot, offset_us, round_trip_us)| {
            FromAgent::Clock(ClockOffset { robot, offset_us, round_trip_us })
        }),
        (robot(), any::<bool>())
            .prop_map(|(robot, on_link)| FromAgent::StopDone(StopDone { robot, on_link })),
        commanded().prop_map(FromAgent::Commanded),
    ]
}

fn commanded() -> impl Strategy<Value = Commanded> {
    let sensed = proptest::option::of(
        (float(), proptest::option::of(float()))
            .prop_map(|(intensity, gradient)| Sensed { intensity, gradient }),
    );
    (robot(), any::<u64>(), float(), float(), sensed)
        .prop_map(|(robot, step, linear, angular, sensed)| Commanded { robot, step, linear, angular, sensed })
}

fn sensor() -> impl Strategy<Value = Sensor> {
    prop_oneof![
        (robot(), float(), float(), any::<u64>()).prop_map(|(robot, intensity, direction, step)| {
            Sensor::Field(FieldSample { robot, intensity, direction, step })
        }),
        pose().prop_map(Sensor::Pose),
    ]
}

fn gate() -> impl Strategy<Value = GateEvent> {
    let kind = prop_oneof![
        Just(GateKind::Deployed),
        any::<bool>().prop_map(|arrived| GateKind::Stopped { arrived }),
        Just(GateKind::Died),
        Just(GateKind::Timeout),
    ];
    (robot(), kind, float(), float(), any::<u64>()).prop_map(|(robot, kind, x, y, step)| GateEvent {
        robot,
        kind,
        x,
        y,
        step,
    })
}

/// Decoding gives back the same bytes (exact even for NaN payloads) and,
/// when the message has no NaN, an equal message.
fn round_trip<T: Message + PartialEq + Debug>(msg: T) -> Result<(), TestCaseError> {
    let mut buf = [0u8; MAX_MESSAGE_LEN];
    let bytes = encode(&msg, &mut buf).map_err(|e| TestCaseError::fail(e.to_string()))?;
    let back: T = decode(bytes).map_err(|e| TestCaseError::fail(e.to_string()))?;
    let mut again = [0u8; MAX_MESSAGE_LEN];
    let again = encode(&back, &mut again).map_err(|e| TestCaseError::fail(e.to_string()))?;
    prop_assert_eq!(again, bytes);
    #[allow(clippy::eq_op)]
    if msg == msg {
        prop_assert_eq!(back, msg);
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn to_agent_round_trips(msg in to_agent()) { round_trip(msg)?; }

    #[test]
    fn from_agent_round_trips(msg in from_agent()) { round_trip(msg)?; }

    #[test]
    fn mocap_round_trips(msg in pose()) { round_trip(msg)?; }

    #[test]
    fn sensor_round_trips(msg in sensor()) { round_trip(msg)?; }

    #[test]
    fn gate_round_trips(msg in gate()) { round_trip(msg)?; }
}

#[test]
fn largest_encodings_fit_max_message_len() {
    let r = RobotId(u32::MAX);
    let s = u64::MAX;
    let f = f64::MAX;
    let pose = Pose { robot: r, x: f, y: f, heading: f, step: s, time_us: s };
    let sensed = Some(Sensed { intensity: f, gradient: Some(f) });
    let commanded = Commanded { robot: r, step: s, linear: f, angular: f, sensed };
    let largest: [(&str, usize); 12] = [
        ("commanded", len(&FromAgent::Commanded(commanded))),
        (
            "to_agent",
            len(&ToAgent::GoalBearing(GoalBearing { robot: r, bearing: f, step: s }))
                .max(len(&ToAgent::Deploy(Deploy { robot: r, x: f, y: f, heading: f }))),
        ),
        ("from_agent", len(&FromAgent::Status(Status { robot: r, mode: u8::MAX, step: s }))),
        (
            "register",
            len(&FromAgent::Register(Register {
                robot: r,
                kind: RobotKind::Real,
                protocol_version: u16::MAX,
                instance: s,
                settings: s,
                failsafe_grace_ms: u32::MAX,
            })),
        ),
        ("beacon", len(&ToAgent::Beacon(Beacon { robot: r, x: f, y: f, seq: u32::MAX }))),
        (
            "refused",
            len(&ToAgent::Refused(Refused { robot: r, instance: s, why: Refusal::Settings { launch: s } })),
        ),
        ("telemetry", len(&FromAgent::Telemetry(largest_telemetry()))),
        (
            "link",
            len(&FromAgent::Link(LinkStatus { robot: r, up: true, silent_ms: u32::MAX, refused: u32::MAX })),
        ),
        (
            "clock",
            len(&FromAgent::Clock(ClockOffset { robot: r, offset_us: i64::MIN, round_trip_us: u32::MAX }))
                .max(len(&ToAgent::Refused(Refused {
                    robot: r,
                    instance: s,
                    why: Refusal::Clock { offset_ms: i32::MIN, limit_ms: u32::MAX },
                }))),
        ),
        ("mocap", len(&pose)),
        ("sensor", len(&Sensor::Pose(pose))),
        (
            "gate",
            len(&GateEvent { robot: r, kind: GateKind::Stopped { arrived: true }, x: f, y: f, step: s }),
        ),
    ];
    for (name, n) in largest {
        assert!(n <= MAX_MESSAGE_LEN, "{name}: {n} bytes");
    }
    assert_eq!(len(&FromAgent::Telemetry(largest_telemetry())), 64, "the largest message today");
}

fn largest_telemetry() -> Telemetry {
    Telemetry {
        robot: RobotId(u32::MAX),
        period: u32::MAX,
        state: DriveState::Stopped,
        mode: u8::MAX,
        mics: [f32::MAX; 6],
        v_ave: f32::MAX,
        gradient: Some(f32::MAX),
        left: f32::MAX,
        right: f32::MAX,
        battery_mv: u16::MAX,
        health: u8::MAX,
        robot_drops: u32::MAX,
    }
}

fn len<T: Message>(msg: &T) -> usize {
    let mut buf = [0u8; MAX_MESSAGE_LEN];
    encode(msg, &mut buf).map(|b| b.len()).unwrap_or(usize::MAX)
}
