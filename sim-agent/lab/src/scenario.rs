//! Lab scenarios: the room, the frames, the start, the goal and the robots'
//! tones, as TOML files in `deploy/lab/` (two built in: `exp-short`,
//! `exp-long`, after the paper's fig:exp_inside_short / fig:exp_inside_long).
//!
//! Why files: a lab is rebuilt by hand for each experiment; its description
//! should be data a user edits, checked strictly (unknown keys are errors),
//! not code. The paper gives no dimensions for its room or frames, so the
//! built-in geometry is ours and documented in the files.

use super::body::{BodyConfig, Obstacle};
use super::sound::SoundConfig;
use bycoms_sim::terrain::MAX_SIDE;
use serde::{Deserialize, Serialize};

/// A point, m.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Point {
    /// x, m.
    pub x: f64,
    /// y, m.
    pub y: f64,
}

/// A pose, m and rad.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pose {
    /// x, m.
    pub x: f64,
    /// y, m.
    pub y: f64,
    /// Heading, rad.
    pub heading: f64,
}

/// The largest offset from the start mark a robot is set down at, m: half
/// the launch's default placement radius (0.1 m).
pub const MAX_PLACED_OFFSET: f64 = 0.05;

/// One lab scenario.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Name, for logs.
    pub name: String,
    /// Arena width (x), m; the walls reflect sound.
    pub width: f64,
    /// Arena height (y), m.
    pub height: f64,
    /// Where every robot is placed when deployed.
    pub start: Pose,
    /// Where the operator sets robot k down, as an offset from the start
    /// mark, m, in deployment order (robots past the list: on the mark). A
    /// hand is never exact; in a field that is symmetric about the line a
    /// robot drove (the virtual field of the ROS 2 robots), which side the
    /// next robot walks around is decided by such an offset, so a scenario
    /// that reproduces a run says where the robots were set down.
    #[serde(default)]
    pub placed: Vec<Point>,
    /// The goal.
    pub goal: Point,
    /// A robot has arrived within this distance of the goal, m.
    pub goal_radius: f64,
    /// One tone per robot, Hz, in deployment order.
    pub tones: Vec<f64>,
    /// The aluminium frames.
    #[serde(default)]
    pub obstacles: Vec<Obstacle>,
    /// Sound model.
    #[serde(default)]
    pub sound: SoundConfig,
    /// Crawler bodies.
    #[serde(default)]
    pub body: BodyConfig,
}

/// Why a scenario was refused.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// Not valid TOML for a scenario.
    #[error("scenario file: {0}")]
    Parse(#[from] toml::de::Error),
    /// Parsed, but inconsistent.
    #[error("scenario '{name}': {why}")]
    Invalid {
        /// The scenario.
        name: String,
        /// What is wrong.
        why: String,
    },
    /// No built-in scenario has this name.
    #[error("no built-in lab scenario '{0}' (built in: exp-short, exp-long)")]
    Unknown(String),
}

/// The largest arena side, m: a launch draws and records a lab's arena as a
/// terrain of one cell per metre, and terrains are at most [`MAX_SIDE`]
/// cells across (the bound of terrain files, so a lab scenario is bounded
/// as they are; `width = 1e5` once asked for a 10 GB grid).
pub const MAX_SIDE_M: f64 = MAX_SIDE as f64;

/// Largest scenario file read, bytes (the built-in ones are about 2 kB).
pub const MAX_FILE_BYTES: u64 = 64 * 1024;

/// The built-in `exp-short` file.
pub const EXP_SHORT: &str = include_str!("../../../deploy/lab/exp-short.toml");
/// The built-in `exp-long` file.
pub const EXP_LONG: &str = include_str!("../../../deploy/lab/exp-long.toml");

impl Scenario {
    /// Parses and checks a scenario file's text.
    pub fn parse(text: &str) -> Result<Self, ScenarioError> {
        let s: Scenario = toml::from_str(text)?;
        let invalid = |why: &str| Err(ScenarioError::Invalid { name: s.name.clone(), why: why.to_owned() });
        let inside = |x: f64, y: f64| (0.0..=s.width).contains(&x) && (0.0..=s.height).contains(&y);
        let side = |m: f64| m > 0.0 && m <= MAX_SIDE_M;
        if !(side(s.width) && side(s.height)) {
            return invalid(&format!(
                "width and height must be positive and at most {MAX_SIDE_M} m (a launch's terrain has a cell \
                 per metre, at most {MAX_SIDE} across), got {:?} m × {:?} m",
                s.width, s.height
            ));
        }
        if !inside(s.start.x, s.start.y) || !inside(s.goal.x, s.goal.y) {
            return invalid("start and goal must lie in the arena");
        }
        if let Some(why) = s.goal_refused().or_else(|| s.tones_refused()) {
            return invalid(&why);
        }
        if s.obstacles.iter().any(|o| !(o.x0 < o.x1 && o.y0 < o.y1)) {
            return invalid("an obstacle needs x0 < x1 and y0 < y1");
        }
        if s.obstacles.iter().any(|o| o.distance(s.start.x, s.start.y) < s.body.radius) {
            return invalid("the start overlaps an obstacle");
        }
        if let Some(why) = s.placed_refused() {
            return invalid(&why);
        }
        Ok(s)
    }

    /// Why the goal cannot be run to (issue 49: a goal radius of 0 is never
    /// reached, and a start within the goal radius arrives at once).
    fn goal_refused(&self) -> Option<String> {
        let r = self.goal_radius;
        if !(r.is_finite() && r > 0.0) {
            return Some(format!("goal_radius must be a positive number of metres, got {r}"));
        }
        let (dx, dy) = (self.start.x - self.goal.x, self.start.y - self.goal.y);
        let apart = dx.hypot(dy);
        (apart <= r).then(|| {
            format!(
                "the start ({}, {}) lies within goal_radius {r} m of the goal ({}, {}): every robot would arrive \
                 at once",
                self.start.x, self.start.y, self.goal.x, self.goal.y
            )
        })
    }

    /// Where robot `index` (0-based, in deployment order) is set down.
    pub fn placement(&self, index: usize) -> Pose {
        let offset = self.placed.get(index).copied().unwrap_or(Point { x: 0.0, y: 0.0 });
        Pose { x: self.start.x + offset.x, y: self.start.y + offset.y, heading: self.start.heading }
    }

    /// Why a placement is not a hand's error at the start mark: every
    /// offset is finite and within [`MAX_PLACED_OFFSET`], so that the
    /// launch's placement check (a robot within 0.1 m of the start, by
    /// default) accepts the robot where the operator set it down.
    fn placed_refused(&self) -> Option<String> {
        let (k, p) =
            self.placed.iter().enumerate().find(|(_, p)| {
                !(p.x.is_finite() && p.y.is_finite() && p.x.hypot(p.y) <= MAX_PLACED_OFFSET)
            })?;
        Some(format!(
            "placed: robot {} is set down ({}, {}) m from the start mark; an offset is at most {MAX_PLACED_OFFSET} m",
            k + 1,
            p.x,
            p.y
        ))
    }

    /// Why the tones cannot tell the robots apart (issue 49: two robots on
    /// one tone are one robot to every listener).
    fn tones_refused(&self) -> Option<String> {
        if self.tones.is_empty() || self.tones.iter().any(|t| !(t.is_finite() && *t > 0.0)) {
            return Some("tones must be one positive frequency per robot".into());
        }
        let tones = &self.tones;
        let same = (0..tones.len()).find_map(|j| (0..j).find(|&i| tones[i] == tones[j]).map(|i| (i, j)))?;
        let (i, j) = same;
        Some(format!(
            "tones: robots {} and {} both have the tone {} Hz (one tone per robot)",
            i + 1,
            j + 1,
            tones[i]
        ))
    }

    /// A built-in scenario by name.
    pub fn builtin(name: &str) -> Result<Self, ScenarioError> {
        match name {
            "exp-short" => Self::parse(EXP_SHORT),
            "exp-long" => Self::parse(EXP_LONG),
            other => Err(ScenarioError::Unknown(other.to_owned())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn built_in_scenarios_parse() {
        let short = Scenario::builtin("exp-short").unwrap();
        assert_eq!((short.tones.len(), short.obstacles.len()), (2, 1));
        let long = Scenario::builtin("exp-long").unwrap();
        assert_eq!(long.tones, vec![224.0, 320.0, 512.0]);
        assert!(matches!(Scenario::builtin("exp-x"), Err(ScenarioError::Unknown(_))));
    }

    #[test]
    fn bad_scenarios_are_refused_with_a_reason() {
        let bad_key = EXP_SHORT.replace("goal_radius", "goal_radios");
        assert!(matches!(Scenario::parse(&bad_key), Err(ScenarioError::Parse(_))));
        let outside = EXP_SHORT.replace("goal = { x = 2.6", "goal = { x = 9.6");
        let err = Scenario::parse(&outside).unwrap_err().to_string();
        assert!(err.contains("start and goal"), "{err}");
        // Issue 49: a goal never reached, a run won before it starts, two
        // robots no listener can tell apart.
        for (from, to, says) in [
            (
                "goal_radius = 0.15",
                "goal_radius = 0.0",
                "goal_radius must be a positive number of metres, got 0",
            ),
            (
                "goal = { x = 2.6, y = 1.0 }",
                "goal = { x = 0.4, y = 1.0 }",
                "the start (0.4, 1) lies within goal_radius 0.15 m of the goal (0.4, 1)",
            ),
            (
                "tones = [224.0, 320.0]",
                "tones = [224.0, 224.0]",
                "tones: robots 1 and 2 both have the tone 224 Hz",
            ),
        ] {
            assert!(EXP_SHORT.contains(from), "{from}");
            let err = Scenario::parse(&EXP_SHORT.replace(from, to)).unwrap_err().to_string();
            assert!(err.contains(says), "{to}: {err}");
        }
        // An arena no launch could draw: bounded as terrain files are.
        for (key, bad) in [("width", "1e300"), ("width", "1e5"), ("height", "nan"), ("height", "-2.0")] {
            let line = EXP_SHORT.lines().find(|l| l.starts_with(&format!("{key} ="))).expect("key");
            let err = Scenario::parse(&EXP_SHORT.replace(line, &format!("{key} = {bad}"))).unwrap_err();
            assert!(err.to_string().contains("at most 1000 m"), "{key} = {bad}: {err}");
        }
        // A huge side is said as given, not as a 301-digit number.
        let huge = EXP_SHORT.lines().find(|l| l.starts_with("width =")).expect("width");
        let err = Scenario::parse(&EXP_SHORT.replace(huge, "width = 1e300")).unwrap_err().to_string();
        assert!(err.contains("got 1e300 m × "), "{err}");
        assert!(!err.contains("00000000000"), "{err}");
    }

    #[test]
    fn robots_are_set_down_where_placed_says_and_a_placement_off_the_mark_is_refused() {
        let long = Scenario::builtin("exp-long").unwrap();
        let at = |k: usize| {
            let p = long.placement(k);
            (p.x, p.y, p.heading)
        };
        assert_eq!(at(0), (0.4, 1.0, 0.0));
        assert_eq!(at(1), (0.4, 1.04, 0.0), "exp-long sets robot 2 above the mark");
        assert_eq!(at(2), (0.4, 1.0, 0.0), "past the list: on the mark");
        let short = EXP_SHORT.replace("goal = {", "placed = [{ x = 0.0, y = OFF }]\ngoal = {");
        for (off, says) in [("0.06", "robot 1 is set down (0, 0.06) m"), ("nan", "(0, NaN) m")] {
            let err = Scenario::parse(&short.replace("OFF", off)).unwrap_err().to_string();
            assert!(err.contains(says) && err.contains("at most 0.05 m"), "{off}: {err}");
        }
        assert_eq!(Scenario::parse(&short.replace("OFF", "-0.05")).unwrap().placement(0).y, 0.95);
    }
}
