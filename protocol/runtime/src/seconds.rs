//! The one check of a number of seconds a user gives: every flag and config
//! key that takes seconds (`--unreachable-grace`, `supervision.register_timeout`,
//! `--settings-timeout`, `sim-agent lab --duration`, `bench scale
//! --seconds`, `--dwell`, `--time-limit`, …) goes through [`check_seconds`]
//! or, as a clap value parser, [`seconds`] / [`seconds_or_zero`].
//!
//! Why one check: `Duration::from_secs_f64` panics on a NaN, a negative
//! number or one past `u64::MAX` seconds, and an `Instant` plus a few
//! centuries overflows; `--unreachable-grace 1e300` ended a launch with a panic
//! (exit 101) instead of a usage error naming the flag. Every span of ours
//! is bounded by [`MAX_SECONDS`], far below both limits and above any run
//! (a crowd bench's time limit is 1e7 s), so what passes here is a valid
//! `Duration` and may be added to any `Instant`. Always built, with no
//! dependencies (the simulator's run parameters use it without the
//! process pieces).

use core::time::Duration;

/// The longest span any flag or key takes, seconds (over three years).
pub const MAX_SECONDS: f64 = 1e8;

/// Whether zero seconds is a valid value (a grace of 0: at once) or not (a
/// timeout of 0 could never be met).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Zero {
    /// 0 is allowed: the range is [0, [`MAX_SECONDS`]].
    Allowed,
    /// 0 is refused: the range is (0, [`MAX_SECONDS`]].
    Refused,
}

impl Zero {
    /// The range in words, "(0, 100000000]" or "[0, 100000000]".
    pub fn range(self) -> String {
        let open = if self == Zero::Allowed { '[' } else { '(' };
        format!("{open}0, {MAX_SECONDS}]")
    }
}

/// `value` seconds as a duration, or the message that names `name` (a
/// flag, a config key) and the range: "--unreachable-grace must be a number of
/// seconds in [0, 100000000], got 1e300". NaN, infinities and negative
/// numbers are refused too.
pub fn check_seconds(name: &str, value: f64, zero: Zero) -> Result<Duration, String> {
    if !in_range(value, zero) {
        return Err(format!("{name} must be a number of seconds in {}, got {value:?}", zero.range()));
    }
    Ok(Duration::from_secs_f64(value))
}

fn in_range(value: f64, zero: Zero) -> bool {
    let least_ok = match zero {
        Zero::Allowed => value >= 0.0,
        Zero::Refused => value > 0.0,
    };
    least_ok && value <= MAX_SECONDS
}

/// A clap value parser of a positive number of seconds, at most
/// [`MAX_SECONDS`]; clap's error names the flag and exits 2.
pub fn seconds(text: &str) -> Result<f64, String> {
    parse(text, Zero::Refused)
}

/// A clap value parser of a number of seconds in [0, [`MAX_SECONDS`]].
pub fn seconds_or_zero(text: &str) -> Result<f64, String> {
    parse(text, Zero::Allowed)
}

fn parse(text: &str, zero: Zero) -> Result<f64, String> {
    let value: f64 = text.trim().parse().map_err(|_| format!("not a number of seconds: {text:?}"))?;
    if !in_range(value, zero) {
        return Err(format!("must be a number of seconds in {}", zero.range()));
    }
    Ok(value)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn huge_negative_and_undefined_seconds_are_refused_with_the_name_and_the_range() {
        for bad in [1e300, 1e20, MAX_SECONDS * 1.5, f64::INFINITY, f64::NAN, -1.0, f64::NEG_INFINITY] {
            for zero in [Zero::Allowed, Zero::Refused] {
                let e = check_seconds("--unreachable-grace", bad, zero).expect_err("refused");
                assert!(e.starts_with("--unreachable-grace must be a number of seconds in "), "{e}");
                assert!(e.contains("0, 100000000]"), "{e}");
            }
        }
        assert_eq!(
            check_seconds("supervision.unreachable_grace", 0.0, Zero::Refused).unwrap_err(),
            "supervision.unreachable_grace must be a number of seconds in (0, 100000000], got 0.0"
        );
        assert_eq!(check_seconds("x", 0.0, Zero::Allowed), Ok(Duration::ZERO));
        assert_eq!(check_seconds("x", 2.5, Zero::Refused), Ok(Duration::from_millis(2500)));
        assert!(check_seconds("x", MAX_SECONDS, Zero::Refused).is_ok());
    }

    #[test]
    fn the_parsers_take_numbers_in_range_only() {
        assert_eq!(seconds("1.5"), Ok(1.5));
        assert_eq!(seconds_or_zero("0"), Ok(0.0));
        for bad in ["0", "-1", "1e300", "nan", "inf", "ten"] {
            assert!(seconds(bad).is_err(), "{bad}");
        }
        assert!(seconds("1e300").unwrap_err().contains("(0, 100000000]"));
    }
}
