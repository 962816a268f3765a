//! The robot link's fault proxy: transparent without faults, seeded losses
//! with them, and a cut that loses everything until it is restored. Plain
//! UDP sockets on loopback stand in for the robot and the gateway.

use bycoms_protocol::fault::FaultConfig;
use bycoms_protocol::link::proxy::LinkProxy;
use std::net::UdpSocket;
use std::time::Duration;

struct Ends {
    robot: UdpSocket,
    gateway: UdpSocket,
    proxy: LinkProxy,
}

fn ends(faults: FaultConfig) -> Ends {
    let gateway = UdpSocket::bind("127.0.0.1:0").expect("gateway socket");
    let robot = UdpSocket::bind("127.0.0.1:0").expect("robot socket");
    for s in [&gateway, &robot] {
        s.set_read_timeout(Some(Duration::from_millis(1000))).expect("timeout");
    }
    let proxy = LinkProxy::start(gateway.local_addr().expect("addr"), faults).expect("proxy");
    robot.connect(proxy.robot_side()).expect("robot talks to the proxy");
    Ends { robot, gateway, proxy }
}

/// Sends `n` numbered datagrams robot → gateway and returns what arrived.
fn robot_to_gateway(e: &Ends, n: u16) -> Vec<u16> {
    for i in 0..n {
        e.robot.send(&i.to_le_bytes()).expect("send");
    }
    let mut got = Vec::new();
    let mut buf = [0u8; 16];
    while let Ok((len, _)) = e.gateway.recv_from(&mut buf) {
        if len == 2 {
            got.push(u16::from_le_bytes([buf[0], buf[1]]));
        }
    }
    got
}

#[test]
fn transparent_both_ways_without_faults() {
    let e = ends(FaultConfig::none(1));
    assert_eq!(robot_to_gateway(&e, 100), (0..100).collect::<Vec<u16>>());
    // The gateway answers the proxy (the robot as it sees it); the robot gets it.
    let mut buf = [0u8; 16];
    e.robot.send(b"hello").expect("send");
    let (n, proxy_addr) = e.gateway.recv_from(&mut buf).expect("hello through");
    assert_eq!(&buf[..n], b"hello");
    e.gateway.send_to(b"welcome", proxy_addr).expect("answer");
    let n = e.robot.recv(&mut buf).expect("welcome through");
    assert_eq!(&buf[..n], b"welcome");
    assert_eq!(e.proxy.stats().to_gateway.dropped, 0);
}

#[test]
fn seeded_drops_and_a_cut_that_heals() {
    let lossy = FaultConfig { drop: 0.3, ..FaultConfig::none(7) };
    let e = ends(lossy);
    let got = robot_to_gateway(&e, 200);
    let stats = e.proxy.stats();
    assert_eq!(stats.to_gateway.received, 200);
    assert_eq!(got.len() as u64, 200 - stats.to_gateway.dropped);
    assert!((30..90).contains(&stats.to_gateway.dropped), "{stats:?}");
    assert!(got.windows(2).all(|w| w[0] < w[1]), "drops only: order kept");

    let clean = ends(FaultConfig::none(7));
    clean.proxy.set_cut(true);
    assert_eq!(robot_to_gateway(&clean, 20), Vec::<u16>::new(), "a cut link loses everything");
    assert_eq!(clean.proxy.stats().cut, 20);
    clean.proxy.set_cut(false);
    assert_eq!(robot_to_gateway(&clean, 20), (0..20).collect::<Vec<u16>>(), "restored");
}

#[test]
fn bad_rates_are_refused() {
    let gateway = UdpSocket::bind("127.0.0.1:0").expect("socket");
    let bad = FaultConfig { duplicate: 2.0, ..FaultConfig::none(1) };
    assert!(LinkProxy::start(gateway.local_addr().expect("addr"), bad).is_err());
}
