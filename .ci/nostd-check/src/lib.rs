//! Links the no_std cores into a `#![no_std]` static library: the point
//! controller, the robot link (HMAC-SHA256 frames and sessions) and the
//! firmware core (tone isolation, gradient, drive, failsafe). Each exported
//! function calls into them with run-time inputs, so their code is really
//! linked, not optimised away.
#![no_std]

use bycoms_agent::firmware::{Firmware, FirmwareConfig, FirmwareInput, MicFrames};
use bycoms_agent::{Controller, ControllerConfig, Input};
use bycoms_protocol::link::{self, Direction, LinkKey, MAX_FRAME_LEN};
use bycoms_protocol::{RobotId, SansIo};

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {}
}

/// One controller step, so the controller's code is really linked.
#[no_mangle]
pub extern "C" fn bycoms_nostd_step(goal: f64, g: f64, field: f64, heading: f64) -> u8 {
    let mut c = Controller::new(ControllerConfig::paper(1.0));
    let out =
        c.step(&Input { goal_bearing: goal, field_intensity: g, field_direction: field, heading, dt: 0.1 });
    let id = bycoms_protocol::RobotId(1);
    out.motion as u8 + (id.0 as u8)
}

/// Decodes the first `len` bytes of `frame` as a link datagram for robot
/// `robot`: 0 if accepted, 1 + the drop reason otherwise.
#[no_mangle]
pub extern "C" fn bycoms_nostd_link_decode(
    frame: &[u8; MAX_FRAME_LEN],
    len: usize,
    key: &[u8; 32],
    robot: u32,
) -> u8 {
    let bytes = &frame[..len.min(MAX_FRAME_LEN)];
    match link::decode(bytes, &LinkKey::new(key), RobotId(robot), Direction::ToRobot) {
        Ok(_) => 0,
        Err(reason) => 1 + reason as u8,
    }
}

/// Boots the firmware core, feeds it a datagram and one control period of
/// silence, and returns the length of its first frame (a hello) plus its
/// state.
#[no_mangle]
pub extern "C" fn bycoms_nostd_firmware(key: &[u8; 32], robot: u32, level: u16, now_ms: u64) -> usize {
    let config = FirmwareConfig::paper(RobotId(robot), 320.0, [224.0, 512.0]);
    let Ok(mut fw) = Firmware::new(config, LinkKey::new(key), *key) else { return 0 };
    let now = now_ms.saturating_mul(1000);
    let _ = fw.handle(now, FirmwareInput::Datagram(&key[..]));
    let frames: MicFrames = [[level; 512]; 6];
    let _ = fw.handle(now, FirmwareInput::Mics(&frames));
    fw.advance(now);
    let sent = fw.poll().map_or(0, |f| f.len());
    sent + fw.state() as usize + fw.motors().left as usize
}
