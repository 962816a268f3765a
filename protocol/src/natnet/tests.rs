//! Codec tests: a frame laid out by hand after the SDK's reference
//! depacketizer, round trips of every message, and garbage that must give
//! errors, never panics.

use super::*;
use proptest::prelude::*;

/// Little-endian bytes written field by field, independent of `Writer`.
fn le(parts: &[&[u8]]) -> Vec<u8> {
    parts.concat()
}

fn robot(id: i32, x: f32) -> RigidBody {
    RigidBody {
        id,
        position: [x, 0.05, -1.5],
        orientation: [0.0, 0.3826834, 0.0, 0.9238795],
        mean_error: 0.0004,
        params: TRACKING_VALID,
    }
}

#[test]
fn a_frame_laid_out_as_the_sdk_reads_it_parses() {
    // NatNet 4.1, one rigid body, every other section empty.
    let f = |v: f32| v.to_le_bytes();
    let i = |v: i32| v.to_le_bytes();
    let body = le(&[
        &i(7), // id
        &f(1.25),
        &f(0.05),
        &f(-1.5), // position
        &f(0.0),
        &f(0.3826834),
        &f(0.0),
        &f(0.9238795),       // qx qy qz qw
        &f(0.0004),          // mean marker error
        &1i16.to_le_bytes(), // params: tracking valid
    ]);
    let empty = le(&[&i(0), &i(0)]); // count 0, size 0
    let payload = le(&[
        &i(4242), // frame number
        &empty,
        &empty, // marker sets, legacy markers
        &i(1),
        &i(body.len() as i32),
        &body, // rigid bodies
        &empty,
        &empty,
        &empty,
        &empty,
        &empty, // skeletons, assets, labeled, plates, devices
        &11u32.to_le_bytes(),
        &2u32.to_le_bytes(),    // timecode, sub
        &12.5f64.to_le_bytes(), // timestamp
        &1u64.to_le_bytes(),
        &2u64.to_le_bytes(),
        &3u64.to_le_bytes(),
        &0u32.to_le_bytes(),
        &0u32.to_le_bytes(), // precision timestamp
        &0i16.to_le_bytes(), // params
    ]);
    let packet = le(&[&7u16.to_le_bytes(), &(payload.len() as u16).to_le_bytes(), &payload]);
    let Packet::FrameOfData(frame) = parse_packet(&packet).expect("parses") else { panic!("not a frame") };
    assert_eq!(frame.frame_number, 4242);
    assert_eq!(frame.rigid_bodies, vec![robot(7, 1.25)]);
    assert!(frame.rigid_bodies[0].tracking_valid());
    assert_eq!(frame.suffix.timestamp, 12.5);
    assert_eq!(frame.suffix.stamp_transmit, 3);
    // And the encoder writes exactly those bytes.
    assert_eq!(encode_packet(&Packet::FrameOfData(frame), Version::V4_1).unwrap(), packet);
}

fn full_frame() -> FrameOfData {
    let marker = LabeledMarker {
        id: (3 << 16) | 2,
        position: [1.0, 2.0, 3.0],
        size: 0.014,
        params: 2,
        residual: 0.0001,
    };
    FrameOfData {
        frame_number: 99,
        marker_sets: vec![MarkerSet { name: "robot1".into(), markers: vec![[0.1, 0.2, 0.3]; 5] }],
        unlabeled_markers: vec![[9.0, 8.0, 7.0]],
        rigid_bodies: vec![robot(1, 0.5), RigidBody { params: 0, ..robot(2, 1.5) }],
        skeletons: vec![Skeleton { id: 4, rigid_bodies: vec![robot(40, 0.0)] }],
        assets: vec![Asset { id: 5, rigid_bodies: vec![robot(50, 0.0)], markers: vec![marker] }],
        labeled_markers: vec![marker, marker],
        force_plates: vec![Channels { id: 6, channels: vec![vec![1.0, 2.0], vec![]] }],
        devices: vec![Channels { id: 7, channels: vec![vec![3.0]] }],
        suffix: Suffix { timecode: 1, timecode_sub: 2, timestamp: 3.5, params: 2, ..Suffix::default() },
    }
}

fn model_defs() -> ModelDefinitions {
    let rb = |name: &str, id| RigidBodyDescription {
        name: name.into(),
        id,
        parent_id: -1,
        offset: [0.0; 3],
        markers: (0..5)
            .map(|k| RigidBodyMarkerDescription {
                offset: [0.01 * k as f32, 0.0, 0.02],
                active_label: 0,
                name: format!("Marker{}", k + 1),
            })
            .collect(),
    };
    ModelDefinitions {
        descriptions: vec![
            DataDescription::MarkerSet(MarkerSetDescription {
                name: "robot1".into(),
                marker_names: vec!["Marker1".into(), "Marker2".into()],
            }),
            DataDescription::RigidBody(rb("robot1", 1)),
            DataDescription::RigidBody(rb("robot2", 2)),
            DataDescription::Skeleton(SkeletonDescription {
                name: "sk".into(),
                id: 3,
                rigid_bodies: vec![rb("bone", 30)],
            }),
            DataDescription::Camera(CameraDescription {
                name: "cam".into(),
                position: [1.0; 3],
                orientation: [0.0, 0.0, 0.0, 1.0],
            }),
            DataDescription::Asset(AssetDescription {
                name: "asset".into(),
                asset_type: 1,
                id: 8,
                rigid_bodies: vec![rb("a", 80)],
                markers: vec![MarkerDescription {
                    name: "m".into(),
                    id: 1,
                    position: [0.0; 3],
                    size: 0.01,
                    params: 0,
                }],
            }),
            DataDescription::Other { kind: 3, bytes: vec![1, 2, 3, 4] },
        ],
    }
}

fn every_packet() -> Vec<Packet> {
    vec![
        Packet::Connect(ConnectRequest { requested_version: Some([4, 1, 0, 0]) }),
        Packet::Connect(ConnectRequest::default()),
        Packet::ServerInfo(ServerInfo {
            app_name: "bycoms lab".into(),
            app_version: [3, 1, 0, 0],
            natnet_version: [4, 1, 0, 0],
            clock_frequency: 1_000_000,
            data_port: 1511,
            multicast: true,
            multicast_group: [239, 255, 42, 99],
        }),
        Packet::Request("Bitstream".into()),
        Packet::Response(Response::Code(0)),
        Packet::Response(Response::Text("Bitstream,4.1".into())),
        Packet::RequestModelDef,
        Packet::ModelDef(model_defs()),
        Packet::RequestFrameOfData,
        Packet::FrameOfData(full_frame()),
        Packet::MessageString("hello".into()),
        Packet::Disconnect,
        Packet::KeepAlive,
        Packet::UnrecognizedRequest,
    ]
}

#[test]
fn every_message_round_trips_in_4_1() {
    for p in every_packet() {
        let bytes = encode_packet(&p, Version::V4_1).unwrap();
        assert_eq!(parse_packet(&bytes).unwrap(), p);
    }
}

#[test]
fn frames_round_trip_in_4_0_without_sizes_or_assets() {
    let frame = FrameOfData { assets: vec![], ..full_frame() };
    let bytes = encode_packet(&Packet::FrameOfData(frame.clone()), Version::V4_0).unwrap();
    let v41 = encode_packet(&Packet::FrameOfData(frame.clone()), Version::V4_1).unwrap();
    assert!(bytes.len() < v41.len(), "4.0 has no section sizes and no asset section");
    assert_eq!(parse_packet_versioned(&bytes, Version::V4_0).unwrap(), Packet::FrameOfData(frame));
    assert!(encode_packet(&Packet::FrameOfData(full_frame()), Version::V4_0).is_err(), "assets need 4.1");
}

#[test]
fn rigid_body_names_come_from_the_model_definitions() {
    let defs = model_defs();
    let names: Vec<_> = defs.rigid_bodies().map(|rb| (rb.name.as_str(), rb.id)).collect();
    assert_eq!(names, [("robot1", 1), ("robot2", 2)]);
}

#[test]
fn the_sdk_clients_connect_and_empty_requests_parse() {
    // As NatNetClient.py sends them: 270-byte body + NUL; empty body + NUL.
    let mut body = vec![0u8; 271];
    body[..4].copy_from_slice(b"Ping");
    body[265..269].copy_from_slice(&[4, 1, 0, 0]);
    let connect = le(&[&0u16.to_le_bytes(), &271u16.to_le_bytes(), &body]);
    assert_eq!(
        parse_packet(&connect).unwrap(),
        Packet::Connect(ConnectRequest { requested_version: Some([4, 1, 0, 0]) })
    );
    assert_eq!(parse_packet(&[4, 0, 0, 0, 0]).unwrap(), Packet::RequestModelDef);
    assert_eq!(parse_packet(&[10, 0, 0, 0, 0]).unwrap(), Packet::KeepAlive);
}

#[test]
fn server_info_is_the_279_byte_sender_server_struct() {
    let bytes = encode_packet(&every_packet()[2], Version::V4_1).unwrap();
    assert_eq!(bytes.len(), 4 + 279);
    assert_eq!(&bytes[4..14], b"bycoms lab");
    assert_eq!(&bytes[4 + 256..4 + 264], &[3, 1, 0, 0, 4, 1, 0, 0]);
    // A server sending only the first 264 bytes (old layout) still parses.
    let mut short = bytes[..4 + 264].to_vec();
    short[2..4].copy_from_slice(&264u16.to_le_bytes());
    let Packet::ServerInfo(info) = parse_packet(&short).unwrap() else { panic!() };
    assert_eq!((info.app_name.as_str(), info.version()), ("bycoms lab", Version::V4_1));
}

#[test]
fn bad_inputs_get_typed_errors() {
    assert!(matches!(parse_packet(&[7]), Err(Error::Truncated { .. })));
    assert!(matches!(
        parse_packet(&[7, 0, 10, 0, 1]),
        Err(Error::LengthMismatch { announced: 10, available: 1 })
    ));
    assert_eq!(parse_packet(&[55, 0, 0, 0]), Err(Error::UnknownMessage(55)));
    // A rigid-body count of a million in a tiny frame.
    let mut frame = encode_packet(&Packet::FrameOfData(FrameOfData::default()), Version::V4_1).unwrap();
    frame[4 + 4 + 16..4 + 4 + 20].copy_from_slice(&1_000_000i32.to_le_bytes());
    assert!(matches!(parse_packet(&frame), Err(Error::BadCount { what: "rigid body", .. })));
    let frame = encode_packet(&Packet::FrameOfData(FrameOfData::default()), Version::V4_1).unwrap();
    assert_eq!(
        parse_packet_versioned(&frame, Version { major: 3, minor: 0 }),
        Err(Error::UnsupportedVersion(3, 0))
    );
    let bad = Packet::Request("a\0b".into());
    assert!(matches!(encode_packet(&bad, Version::V4_1), Err(Error::InteriorNul { .. })));
}

#[test]
fn every_truncation_of_every_message_is_an_error_not_a_panic() {
    for p in every_packet() {
        let bytes = encode_packet(&p, Version::V4_1).unwrap();
        for cut in 0..bytes.len() {
            let mut short = bytes[..cut].to_vec();
            if cut >= 4 {
                // Make the header agree, so the body parser meets the cut.
                short[2..4].copy_from_slice(&((cut - 4) as u16).to_le_bytes());
            }
            let _ = parse_packet(&short);
        }
    }
}

proptest! {
    #[test]
    fn garbage_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let _ = parse_packet(&bytes);
        let _ = parse_packet_versioned(&bytes, Version::V4_0);
    }

    #[test]
    fn garbage_after_a_frame_header_never_panics(body in proptest::collection::vec(any::<u8>(), 0..600)) {
        let mut bytes = vec![7, 0];
        bytes.extend_from_slice(&(body.len() as u16).to_le_bytes());
        bytes.extend_from_slice(&body);
        let _ = parse_packet(&bytes);
    }

    #[test]
    fn random_rigid_bodies_round_trip(
        bodies in proptest::collection::vec(
            (any::<i32>(), any::<[f32; 3]>(), any::<[f32; 4]>(), any::<f32>(), any::<i16>()), 0..60),
        frame_number in any::<i32>(),
    ) {
        let rigid_bodies = bodies
            .into_iter()
            .map(|(id, position, orientation, mean_error, params)| RigidBody { id, position, orientation, mean_error, params })
            .collect();
        let frame = FrameOfData { frame_number, rigid_bodies, ..FrameOfData::default() };
        let bytes = encode_packet(&Packet::FrameOfData(frame.clone()), Version::V4_1).unwrap();
        let Ok(Packet::FrameOfData(back)) = parse_packet(&bytes) else { panic!("no frame") };
        // Compare bit patterns: NaNs must survive too.
        prop_assert_eq!(back.rigid_bodies.len(), frame.rigid_bodies.len());
        for (a, b) in back.rigid_bodies.iter().zip(&frame.rigid_bodies) {
            prop_assert_eq!(a.position.map(f32::to_bits), b.position.map(f32::to_bits));
            prop_assert_eq!(a.orientation.map(f32::to_bits), b.orientation.map(f32::to_bits));
            prop_assert_eq!((a.id, a.params, a.mean_error.to_bits()), (b.id, b.params, b.mean_error.to_bits()));
        }
    }
}

/// Found by the `natnet` fuzz target: a 3-byte text response (no NUL; a
/// NUL would make it 4 bytes, a code) parsed but could not be encoded.
#[test]
fn a_three_byte_text_response_round_trips_without_its_nul() {
    let datagram = [3, 0, 3, 0, 0x01, 0x08, 0x1b];
    let parsed = parse_packet(&datagram).expect("parses");
    assert_eq!(parsed, Packet::Response(Response::Text("\u{1}\u{8}\u{1b}".into())));
    let encoded = encode_packet(&parsed, Version::V4_1).expect("encodes");
    assert_eq!(encoded, datagram, "3 bytes, no NUL");
    assert_eq!(parse_packet(&encoded), Ok(parsed));
    for text in ["abc", "ab", "abcd"] {
        let packet = Packet::Response(Response::Text(text.into()));
        let bytes = encode_packet(&packet, Version::V4_1).expect("encodes");
        assert_eq!(parse_packet(&bytes), Ok(packet), "{text}");
    }
    let bad = Packet::Response(Response::Text("a\0b".into()));
    assert!(matches!(encode_packet(&bad, Version::V4_1), Err(Error::InteriorNul { .. })));
}

/// The `natnet` fuzz finding: a 4.0 model definition ending with an asset
/// whose markers have one-letter names encoded to bytes the parser refused
/// (`BadCount { what: "asset marker" }`: it asked 27 bytes per marker, a
/// marker with an empty name takes 23). Exact-length packets, both versions.
#[test]
fn an_asset_with_minimal_markers_as_the_last_description_round_trips() {
    let marker =
        |name: &str| MarkerDescription { name: name.into(), id: 1, position: [0.0; 3], size: 0.0, params: 0 };
    for names in [["", ""], ["a", "b"]] {
        let defs = ModelDefinitions {
            descriptions: vec![DataDescription::Asset(AssetDescription {
                name: "a".into(),
                asset_type: 0,
                id: 0,
                rigid_bodies: vec![],
                markers: names.iter().map(|n| marker(n)).collect(),
            })],
        };
        for version in [Version::V4_0, Version::V4_1] {
            let bytes = encode_packet(&Packet::ModelDef(defs.clone()), version).unwrap();
            let parsed = parse_packet_versioned(&bytes, version).unwrap();
            assert_eq!(parsed, Packet::ModelDef(defs.clone()), "{version:?} {names:?}");
        }
    }
    // A rigid body with one unnamed marker, last, is exactly long enough too.
    let defs = ModelDefinitions {
        descriptions: vec![DataDescription::RigidBody(RigidBodyDescription {
            name: String::new(),
            id: 1,
            parent_id: -1,
            offset: [0.0; 3],
            markers: vec![RigidBodyMarkerDescription {
                offset: [0.0; 3],
                active_label: 0,
                name: String::new(),
            }],
        })],
    };
    let bytes = encode_packet(&Packet::ModelDef(defs.clone()), Version::V4_0).unwrap();
    assert_eq!(parse_packet_versioned(&bytes, Version::V4_0).unwrap(), Packet::ModelDef(defs));
}

/// The second `natnet` fuzz finding: a server info whose 256-byte name
/// field holds no NUL parsed (the whole field as the name) but could not be
/// encoded again. It is refused now, as C readers would overrun it.
#[test]
fn a_server_name_without_its_nul_is_refused() {
    let mut bytes = encode_packet(&every_packet()[2], Version::V4_1).unwrap();
    bytes[4..4 + 256].fill(b'W');
    assert!(
        matches!(parse_packet(&bytes), Err(Error::Unterminated { what: "server name", at: 0 })),
        "{:?}",
        parse_packet(&bytes)
    );
    // 255 characters and the NUL: the longest name, and it round trips.
    bytes[4 + 255] = 0;
    let parsed = parse_packet(&bytes).unwrap();
    assert_eq!(encode_packet(&parsed, Version::V4_1).unwrap(), bytes);
}
