//! The frame maker's faults, and a real UDP session with the server.

use super::*;
use bycoms_protocol::natnet::{encode_packet, parse_packet, ConnectRequest, Packet, Version};
use std::net::{Ipv4Addr, SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

fn config(faults: Faults) -> ServerConfig {
    ServerConfig {
        rate_hz: 100.0,
        app_name: "test lab".into(),
        multicast: None,
        bodies: vec![
            BodyConfig { name: "robot1".into(), id: 1, position: [1.0, 0.0, 2.0], yaw_deg: 90.0 },
            BodyConfig { name: "robot2".into(), id: 2, position: [3.0, 0.0, 4.0], yaw_deg: 0.0 },
        ],
        faults,
    }
}

fn poses(c: &ServerConfig) -> Vec<BodyPose> {
    c.bodies.iter().map(|b| BodyPose::yawed(b.position, b.yaw_deg.to_radians())).collect()
}

#[test]
fn a_body_out_of_view_is_streamed_untracked_and_comes_back_when_seen() {
    let c = config(Faults::default());
    let mut maker = FrameMaker::new(c.clone());
    let f = maker.next_frame_seen(&poses(&c), &[true, false]).expect("no loss configured");
    assert!(f.rigid_bodies[0].tracking_valid());
    assert!(!f.rigid_bodies[1].tracking_valid(), "robot 2 is off the arena");
    assert_eq!(f.rigid_bodies[1].position, [0.0; 3]);
    let f = maker.next_frame_seen(&poses(&c), &[true, true]).expect("no loss configured");
    assert!(f.rigid_bodies[1].tracking_valid() && f.rigid_bodies[1].position == [3.0, 0.0, 4.0]);
    let t = maker.time_s();
    assert!((t - 0.02).abs() < 1e-12, "stamped in the world's time: frame k at k / rate, {t}");
}

#[test]
fn without_faults_every_frame_carries_every_body_exactly() {
    let c = config(Faults::default());
    let mut maker = FrameMaker::new(c.clone());
    for k in 0..10 {
        let f = maker.next_frame(&poses(&c)).expect("no loss configured");
        assert_eq!(f.frame_number, k);
        assert_eq!(f.rigid_bodies.len(), 2);
        assert_eq!(f.rigid_bodies[1].position, [3.0, 0.0, 4.0]);
        assert!(f.rigid_bodies.iter().all(|b| b.tracking_valid()));
        assert_eq!(f.marker_sets[0].markers.len(), 5, "five markers per robot");
        // Yaw 90° about Y turns the marker offset (0.05, 0.1, 0) to (0, 0.1, -0.05).
        let m = f.marker_sets[0].markers[0];
        assert!((m[0] - 1.0).abs() < 1e-6 && (m[2] - 1.95).abs() < 1e-6, "{m:?}");
    }
}

#[test]
fn frame_loss_is_seeded_and_near_its_rate() {
    let c = config(Faults { seed: 7, frame_loss: 0.2, ..Faults::default() });
    let run = |c: &ServerConfig| {
        let mut maker = FrameMaker::new(c.clone());
        (0..2000).map(|_| maker.next_frame(&poses(c)).is_some()).collect::<Vec<_>>()
    };
    let a = run(&c);
    assert_eq!(a, run(&c), "same seed, same losses");
    let lost = a.iter().filter(|kept| !**kept).count();
    assert!((300..500).contains(&lost), "{lost} of 2000 lost at 20 %");
}

#[test]
fn occlusions_show_as_invalid_or_missing_only_inside_their_window() {
    let c = config(Faults {
        occlusions: vec![
            Occlusion { id: 1, from_s: 0.1, to_s: 0.2, mode: OcclusionMode::Invalid },
            Occlusion { id: 2, from_s: 0.15, to_s: 0.3, mode: OcclusionMode::Missing },
        ],
        ..Faults::default()
    });
    let mut maker = FrameMaker::new(c.clone());
    let frames: Vec<_> = (0..40).map(|_| maker.next_frame(&poses(&c)).unwrap()).collect();
    let body = |k: usize, id| frames[k].rigid_bodies.iter().find(|b| b.id == id).copied();
    assert!(body(9, 1).unwrap().tracking_valid());
    assert!(!body(10, 1).unwrap().tracking_valid());
    assert!(!body(19, 1).unwrap().tracking_valid());
    assert!(body(20, 1).unwrap().tracking_valid());
    assert!(body(14, 2).is_some() && body(15, 2).is_none() && body(29, 2).is_none() && body(30, 2).is_some());
}

#[test]
fn a_swap_exchanges_ids_inside_its_window() {
    let c = config(Faults { swaps: vec![Swap { a: 1, b: 2, from_s: 0.05, to_s: 0.1 }], ..Faults::default() });
    let mut maker = FrameMaker::new(c.clone());
    let frames: Vec<_> = (0..12).map(|_| maker.next_frame(&poses(&c)).unwrap()).collect();
    let pos_of = |k: usize, id| frames[k].rigid_bodies.iter().find(|b| b.id == id).unwrap().position;
    assert_eq!(pos_of(4, 1), [1.0, 0.0, 2.0]);
    assert_eq!(pos_of(5, 1), [3.0, 0.0, 4.0], "robot 2's pose under id 1");
    assert_eq!(pos_of(5, 2), [1.0, 0.0, 2.0]);
    assert_eq!(pos_of(10, 1), [1.0, 0.0, 2.0]);
}

#[test]
fn marker_noise_moves_positions_by_about_its_sigma() {
    let c = config(Faults { seed: 3, marker_noise_m: 0.01, ..Faults::default() });
    let mut maker = FrameMaker::new(c.clone());
    let dev: Vec<f32> =
        (0..500).map(|_| maker.next_frame(&poses(&c)).unwrap().rigid_bodies[1].position[0] - 3.0).collect();
    let rms = (dev.iter().map(|d| d * d).sum::<f32>() / dev.len() as f32).sqrt();
    assert!((0.008..0.012).contains(&rms), "rms {rms}");
}

#[test]
fn config_rejects_duplicates_and_bad_rates() {
    let mut c = config(Faults::default());
    c.bodies[1].id = 1;
    assert!(c.validate().unwrap_err().contains("twice"));
    for rate_hz in [0.0, 1e-300, 0.5, 10_000.5, f64::NAN, f64::INFINITY] {
        let c = ServerConfig { rate_hz, ..config(Faults::default()) };
        let e = c.validate().expect_err("out of range");
        assert_eq!(e, format!("rate_hz must be a number of Hz in [1, 10000], got {rate_hz:?}"));
    }
    for rate_hz in [1.0, 120.0, 10_000.0] {
        assert_eq!(ServerConfig { rate_hz, ..config(Faults::default()) }.validate(), Ok(()));
    }
    let toml = "rate_hz = 120.0\nbodies = []\nunknown = 1\n";
    assert!(toml::from_str::<ServerConfig>(toml).is_err(), "unknown keys are refused");
}

fn recv(socket: &UdpSocket, want: impl Fn(&Packet) -> bool) -> Packet {
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut buf = vec![0u8; 65_536];
    while Instant::now() < deadline {
        if let Ok((n, _)) = socket.recv_from(&mut buf) {
            if let Ok(p) = parse_packet(&buf[..n]) {
                if want(&p) {
                    return p;
                }
            }
        }
    }
    panic!("no matching NatNet packet within 5 s");
}

#[test]
fn a_unicast_client_connects_reads_names_and_receives_frames() {
    let server = NatNetServer::start_any_port(config(Faults::default()), Ipv4Addr::LOCALHOST.into()).unwrap();
    let client = UdpSocket::bind(SocketAddr::from((Ipv4Addr::LOCALHOST, 0))).unwrap();
    client.set_read_timeout(Some(Duration::from_millis(100))).unwrap();
    let send = |p: Packet| {
        client.send_to(&encode_packet(&p, Version::V4_1).unwrap(), server.command_addr()).unwrap()
    };
    send(Packet::Connect(ConnectRequest { requested_version: Some([4, 1, 0, 0]) }));
    let Packet::ServerInfo(info) = recv(&client, |p| matches!(p, Packet::ServerInfo(_))) else {
        unreachable!()
    };
    assert_eq!((info.app_name.as_str(), info.version()), ("test lab", Version::V4_1));
    assert_eq!(info.data_port, server.data_addr().port());
    send(Packet::RequestModelDef);
    let Packet::ModelDef(defs) = recv(&client, |p| matches!(p, Packet::ModelDef(_))) else { unreachable!() };
    let names: Vec<_> = defs.rigid_bodies().map(|b| (b.name.clone(), b.id)).collect();
    assert_eq!(names, [("robot1".to_string(), 1), ("robot2".to_string(), 2)]);
    assert!(server.set_pose(2, BodyPose::yawed([5.0, 0.0, 6.0], 0.0)));
    let frame = recv(
        &client,
        |p| matches!(p, Packet::FrameOfData(f) if f.rigid_bodies.iter().any(|b| b.id == 2 && b.position == [5.0, 0.0, 6.0])),
    );
    assert!(matches!(frame, Packet::FrameOfData(_)));
    assert_eq!(server.client_count(), 1);
}

#[test]
fn natnet_serve_config_in_deploy_parses_and_validates() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../deploy/natnet-serve.toml");
    let text = std::fs::read_to_string(path).unwrap();
    let c: ServerConfig = toml::from_str(&text).unwrap();
    c.validate().unwrap();
    assert_eq!(c.bodies.len(), 3);
}
