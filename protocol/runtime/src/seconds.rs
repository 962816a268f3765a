//! The one check of a number of seconds a user gives: every flag and config
//! key that takes seconds (`--unreachable-grace`, `supervision.register_timeout`,
//! `--settings-timeout`, `sim-agent lab --duration`, `bench scale
//! --seconds`, `--dwell`, `--time-limit`, …) goes through [`check_seconds`]
//! or, as a clap value parser, [`seconds`] / [`seconds_or_zero`]; every
//! flag that takes milliseconds (`--timeout-ms`, `--heartbeat-ms`, …)
//! through [`millis`] / [`millis_or_zero`], the same range in that unit.
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
        self.range_to(MAX_SECONDS)
    }

    /// The range up to `max` in words ("(0, 100000000000]" for milliseconds).
    fn range_to(self, max: impl core::fmt::Display) -> String {
        let open = if self == Zero::Allowed { '[' } else { '(' };
        format!("{open}0, {max}]")
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

/// `value` milliseconds (a config key, a setting handed over) as a
/// duration, or the message that names `name` and the range in
/// milliseconds: [`check_seconds`] in that unit.
pub fn check_millis(name: &str, value: u64, zero: Zero) -> Result<Duration, String> {
    if !in_range(value as f64 / 1000.0, zero) {
        return Err(format!(
            "{name} must be a number of milliseconds in {}, got {value}",
            zero.range_to(MAX_MILLIS)
        ));
    }
    Ok(Duration::from_millis(value))
}

/// The longest span in milliseconds, [`MAX_SECONDS`] in that unit.
pub const MAX_MILLIS: u64 = MAX_SECONDS as u64 * 1000;

/// A clap value parser of a positive whole number of milliseconds, at most
/// [`MAX_MILLIS`] (the seconds' range: `--timeout-ms 0` could never be met,
/// `--heartbeat-ms 18446744073709551615` is no heartbeat at all).
pub fn millis(text: &str) -> Result<u64, String> {
    parse_millis(text, Zero::Refused)
}

/// A clap value parser of a whole number of milliseconds in [0, [`MAX_MILLIS`]].
pub fn millis_or_zero(text: &str) -> Result<u64, String> {
    parse_millis(text, Zero::Allowed)
}

fn parse_millis(text: &str, zero: Zero) -> Result<u64, String> {
    let value: u64 =
        text.trim().parse().map_err(|_| format!("not a whole number of milliseconds: {text:?}"))?;
    if !in_range(value as f64 / 1000.0, zero) {
        return Err(format!("must be a number of milliseconds in {}", zero.range_to(MAX_MILLIS)));
    }
    Ok(value)
}

/// A clap value parser of a number of seconds in [`least`, `most`] (within
/// [0, [`MAX_SECONDS`]]): a flag with a narrower range than any span
/// (`status --interval`, 0.1 to 60 s) says that one range only.
pub fn seconds_between(text: &str, least: f64, most: f64) -> Result<f64, String> {
    let value = parse(text, Zero::Allowed).ok().filter(|v| (least..=most).contains(v));
    value.ok_or_else(|| format!("must be a number of seconds in [{least}, {most}]"))
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

    #[test]
    fn milliseconds_take_the_same_range_in_their_unit() {
        assert_eq!(millis("500"), Ok(500));
        assert_eq!(millis(&MAX_MILLIS.to_string()), Ok(100_000_000_000));
        assert_eq!(millis_or_zero("0"), Ok(0));
        assert_eq!(millis("0").unwrap_err(), "must be a number of milliseconds in (0, 100000000000]");
        let past = (MAX_MILLIS + 1).to_string();
        for bad in ["18446744073709551615", past.as_str(), "-1", "1.5", "ten"] {
            assert!(millis(bad).is_err(), "{bad}");
            assert!(millis_or_zero(bad).is_err(), "{bad}");
        }
        assert_eq!(seconds_between("0.5", 0.1, 60.0), Ok(0.5));
        for bad in ["0", "0.05", "61", "1e300", "nan", "ten"] {
            assert_eq!(
                seconds_between(bad, 0.1, 60.0).unwrap_err(),
                "must be a number of seconds in [0.1, 60]"
            );
        }
        assert_eq!(check_millis("x", 2500, Zero::Refused), Ok(Duration::from_millis(2500)));
        assert_eq!(
            check_millis("x", u64::MAX, Zero::Allowed).unwrap_err(),
            "x must be a number of milliseconds in [0, 100000000000], got 18446744073709551615"
        );
        assert_eq!(
            millis_or_zero("18446744073709551615").unwrap_err(),
            "must be a number of milliseconds in [0, 100000000000]"
        );
    }
}
