//! Why a launch ended in error, typed: the core decides the reason as data
//! ([`Fault`]), and only the edge (the summary, the terminal) renders it
//! as words ([`std::fmt::Display`]). So a test asserts the variant, the
//! robot and the agent's [`Gone`] reason, never a message with its numbers
//! stripped, and a change of wording changes no test of a rule.

use crate::Gone;

/// What ended a launch in error ([`super::Outcome::Error`]).
#[derive(Clone, Debug, PartialEq)]
pub enum Fault {
    /// A shell failed to carry something out ([`super::Input::Failed`]).
    Failed(String),
    /// Robot `robot`'s agent never registered (with `--missing fail`).
    NeverRegistered {
        /// The robot.
        robot: u32,
        /// How its agent went.
        why: Gone,
        /// Why, in words (with its last error line, when it said one).
        reason: String,
    },
    /// No agent ever registered (a broken agent executable): the first
    /// robot whose agent is gone, and how.
    NoneRegistered {
        /// The robot.
        robot: u32,
        /// How its agent went.
        why: Option<Gone>,
        /// Why, in words.
        reason: String,
    },
    /// While every agent was awaited at the start, these never came.
    NeverCame {
        /// The robots, in id order.
        robots: Vec<u32>,
        /// The agent source's kind.
        kind: String,
        /// The registration timeout, s.
        timeout_s: f64,
        /// How to start a missing agent (may be empty).
        hint: String,
    },
    /// With `--on-agent-death abort`: robot `robot`'s agent was lost
    /// before its deployment, while moving, or after its verdict.
    Died {
        /// The robot.
        robot: u32,
        /// When: before its deployment, while moving, after.
        when: DiedWhen,
        /// How its agent went.
        why: Gone,
        /// Why, in words.
        reason: String,
    },
    /// The operator did not place robot `robot` at the start in time.
    NotPlaced {
        /// The robot.
        robot: u32,
        /// The start.
        start: (f64, f64),
        /// The placement timeout, s.
        timeout_s: f64,
        /// Where motion capture saw it last.
        last: Option<(f64, f64)>,
    },
    /// No pose of any robot for `silent_ms`: motion capture (the lab, its
    /// cameras or their network) is gone.
    MocapGone {
        /// How long no pose came, ms.
        silent_ms: u64,
        /// The robot whose link was lost with it, if that is how it showed.
        lost_link: Option<u32>,
        /// The gate's dwell, ms (how long is too long without a lost link).
        dwell_ms: u64,
    },
}

/// When a robot's agent died, for [`Fault::Died`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DiedWhen {
    /// Registered, not deployed yet (or awaiting its start pose).
    BeforeDeployment,
    /// Under the gate's watch.
    Moving,
    /// After its verdict (a beacon).
    After,
}

impl std::fmt::Display for Fault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Failed(e) => f.write_str(e),
            Self::NeverRegistered { robot, reason, .. } => {
                write!(f, "robot {robot}'s agent never registered: {reason}")
            }
            Self::NoneRegistered { robot, reason, .. } => {
                write!(f, "no agent ever registered: robot {robot}'s agent never registered: {reason}")
            }
            Self::NeverCame { robots, kind, timeout_s, hint } => {
                let noun = if robots.len() == 1 { "robot" } else { "robots" };
                let ids: Vec<String> = robots.iter().map(u32::to_string).collect();
                write!(f, "the {kind} agents of {noun} {} never registered within {timeout_s} s{hint}", ids.join(", "))
            }
            Self::Died { robot, when, reason, .. } => match when {
                DiedWhen::BeforeDeployment => {
                    write!(f, "robot {robot}'s agent was lost before its deployment: {reason}")
                }
                DiedWhen::Moving => write!(f, "robot {robot}'s agent died while moving: {reason}"),
                DiedWhen::After => write!(f, "robot {robot}'s agent died: {reason}"),
            },
            Self::NotPlaced { robot, start, timeout_s, last } => {
                let last = last.map_or("never".into(), |(x, y)| format!("at ({x:.2}, {y:.2})"));
                write!(
                    f,
                    "robot {robot} was not seen at the start ({:.2}, {:.2}) within {timeout_s} s (last seen: {last})",
                    start.0, start.1
                )
            }
            Self::MocapGone { silent_ms, lost_link: Some(id), .. } => write!(
                f,
                "motion capture gone: no pose of any robot for {silent_ms} ms, and robot {id}'s link was lost with it (the lab, its cameras or their network are gone)"
            ),
            Self::MocapGone { silent_ms, lost_link: None, dwell_ms } => write!(
                f,
                "motion capture gone: no pose of any robot for {silent_ms} ms (the gate's dwell is {dwell_ms} ms)"
            ),
        }
    }
}
