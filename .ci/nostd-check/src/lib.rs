//! Links the no_std cores into a `#![no_std]` static library.
#![no_std]

use bycoms_agent::{Controller, ControllerConfig, Input};

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {}
}

/// One controller step, so the controller's code is really linked.
#[no_mangle]
pub extern "C" fn bycoms_nostd_step(goal: f64, g: f64, field: f64, heading: f64) -> u8 {
    let mut c = Controller::new(ControllerConfig::paper(1.0));
    let out = c.step(&Input { goal_bearing: goal, field_intensity: g, field_direction: field, heading, dt: 0.1 });
    let id = bycoms_protocol::RobotId(1);
    out.motion as u8 + (id.0 as u8)
}
