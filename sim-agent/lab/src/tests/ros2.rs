//! ROS 2 robots in the lab world: placed by the operator, driven by
//! `cmd_vel` commands on the lab clock, colliding with each other.

use crate::ros2_body::DiffDriveConfig;
use crate::scenario::Scenario;
use crate::world::{Lab, PHYSICS_DT};
use bycoms_agent::wheeled::{Limits, Velocity};
use bycoms_protocol::RobotId;
use std::time::Duration;

fn lab(n: u32) -> Lab {
    let scenario = Scenario::builtin("exp-short").expect("exp-short");
    let config =
        DiffDriveConfig::new(Limits::TURTLEBOT3_BURGER, scenario.body.radius, Duration::from_millis(300));
    let robots: Vec<_> = (1..=n).map(|id| (RobotId(id), config)).collect();
    Lab::ros2(scenario, &robots, 5)
}

/// Steps `lab` for `seconds`, commanding `v` to `robot` every 100 ms (none when `None`).
fn drive(lab: &mut Lab, seconds: f64, robot: Option<(RobotId, Velocity)>) {
    let steps = (seconds / PHYSICS_DT.as_secs_f64()).round() as u32;
    for k in 0..steps {
        if let Some((id, v)) = robot.filter(|_| k % 20 == 0) {
            let now = lab.now();
            assert!(lab.command(id, now, v), "robot {} is placed", id.0);
        }
        lab.step().expect("a step without sockets");
    }
}

fn pose(lab: &Lab, id: u32) -> crate::scenario::Pose {
    let all = lab.poses();
    all.iter().find(|(r, _)| r.0 == id).and_then(|(_, p)| *p).expect("placed")
}

#[test]
fn a_ros2_lab_places_drives_and_stops_its_robots_without_any_esp32() {
    let mut lab = lab(2);
    assert!(lab.robots().is_empty());
    assert_eq!(lab.poses(), vec![(RobotId(1), None), (RobotId(2), None)]);
    assert!(
        !lab.command(RobotId(1), Duration::ZERO, Velocity { linear: 0.2, angular: 0.0 }),
        "off the arena"
    );
    assert!(lab.place(0) && !lab.place(0), "placed once");
    assert!(!lab.place(2), "no robot 3");
    let start = lab.scenario().start;
    assert_eq!(pose(&lab, 1), start);
    drive(&mut lab, 2.0, Some((RobotId(1), Velocity { linear: 0.2, angular: 0.0 })));
    let moved = pose(&lab, 1);
    assert!((moved.x - start.x - 0.4).abs() < 0.02 && (moved.y - start.y).abs() < 0.01, "{moved:?}");
    // No more commands: it stops 300 ms after the last one.
    drive(&mut lab, 1.0, None);
    let stopped = pose(&lab, 1);
    assert!(stopped.x - moved.x < 0.2 * 0.35 && stopped.x > moved.x, "{moved:?} {stopped:?}");
    drive(&mut lab, 1.0, None);
    assert_eq!(pose(&lab, 1), stopped, "still");
    // Robot 2 drives into robot 1 and sticks there.
    assert!(lab.place(1));
    drive(&mut lab, 4.0, Some((RobotId(2), Velocity { linear: 0.2, angular: 0.0 })));
    let (one, two) = (pose(&lab, 1), pose(&lab, 2));
    let gap = one.x - two.x;
    let radius = lab.scenario().body.radius;
    assert!(gap >= 2.0 * radius && gap < 2.0 * radius + 0.005, "{one:?} {two:?}");
    assert!(lab.ros2_robots()[1].body.as_ref().is_some_and(|b| b.stuck));
    assert!(lab.ros2_robots()[0].body.as_ref().is_some_and(|b| !b.stuck));
}
